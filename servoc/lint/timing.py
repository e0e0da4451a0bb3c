"""Frame timing rules: the period, holds, and counters the firmware keeps."""

from __future__ import annotations

from ..diagnostics import Reporter, Severity
from ..plan import HoldStep, LoopStep, MoveStep, Plan, RepeatStep
from ..units import LONGEST_PULSE_US, TAIL_US, fmt_ms
from . import rule
from .speed import fmt_duration
from ..plan import steps
from .walk import fewest_frames

MAX_PERIOD_US = 65535        # Timer2 counts 16 bits of machine cycles
MAX_FRAMES = 65535           # frames of one move or hold, and passes of one repeat


def _ports(n: int) -> str:
    return f"{n} port{'s' if n != 1 else ''}"


@rule("period-too-short", Severity.ERROR)
def period_too_short(plan: Plan, reporter: Reporter) -> None:
    if plan.period_us < plan.min_period_us:
        reporter.error(
            "period-too-short",
            f"frame period {fmt_ms(plan.period_us)} is too short for the {_ports(len(plan.ports))} in use: "
            f"the firmware needs at least {fmt_ms(plan.min_period_us)}",
            plan.program.frame_span, label="too short",
            help=f"use `frame {fmt_duration(plan.min_period_us)}` or longer, or drop `frame` for the default")


@rule("period-too-long", Severity.ERROR)
def period_too_long(plan: Plan, reporter: Reporter) -> None:
    if plan.period_us > MAX_PERIOD_US:
        reporter.error(
            "period-too-long",
            f"frame period {fmt_ms(plan.period_us)} is longer than Timer2 can count "
            f"({fmt_duration(MAX_PERIOD_US)[:-2]} ms at most)",
            plan.program.frame_span, label="too long",
            help=f"use `frame {MAX_PERIOD_US // 1000}ms` or shorter; hobby servos expect a pulse at least every 20 ms")


@rule("short-gap", Severity.WARNING)
def short_gap(plan: Plan, reporter: Reporter) -> None:
    gap = plan.period_us - LONGEST_PULSE_US
    if plan.period_us >= plan.min_period_us and gap < TAIL_US and plan.ports:
        reporter.warning(
            "short-gap",
            f"frame period {fmt_ms(plan.period_us)} leaves {fmt_ms(gap)} after a 2.5 ms pulse, "
            f"under the {fmt_ms(TAIL_US)} gap the servo is known to follow reliably",
            plan.program.frame_span, label="short gap",
            help=f"use `frame {fmt_duration(LONGEST_PULSE_US + TAIL_US)}` or longer unless your servos are tested at this rate")


@rule("short-hold", Severity.WARNING)
def short_hold(plan: Plan, reporter: Reporter) -> None:
    for st in steps(plan):
        if isinstance(st, HoldStep) and st.duration_us < plan.period_us:
            reporter.warning(
                "short-hold",
                f"hold {fmt_ms(st.duration_us)} is shorter than one frame ({fmt_ms(plan.period_us)}): "
                f"it lasts {st.frames} frame{'s' if st.frames != 1 else ''}",
                st.span, label="shorter than a frame",
                help=f"holds last whole frames; use `hold {fmt_duration(plan.period_us)}` or drop it")


@rule("empty-loop", Severity.ERROR)
def empty_loop(plan: Plan, reporter: Reporter) -> None:
    for st in steps(plan):
        if isinstance(st, LoopStep) and fewest_frames(plan, st.body) == 0:
            reporter.error(
                "empty-loop", "this loop takes no frames: it would run forever without sending a pulse",
                st.span, help="put a `move` or a `hold` of at least one frame inside the loop")


@rule("too-long", Severity.ERROR)
def too_long(plan: Plan, reporter: Reporter) -> None:
    for st in steps(plan):
        count = st.count if isinstance(st, RepeatStep) else getattr(st, "frames", None)
        if count is not None and count > MAX_FRAMES:
            what = "passes" if isinstance(st, RepeatStep) else "frames"
            reporter.error(
                "too-long", f"this statement runs {count} {what}; the firmware counts at most {MAX_FRAMES}",
                st.span, help="split it into several statements (e.g. a repeat around a shorter one)")
    for inst in plan.moves:
        if isinstance(inst.step, MoveStep) and inst.step.frames is None and inst.frames > MAX_FRAMES:
            reporter.error("too-long", f"this move runs {inst.frames} frames; the firmware counts at most {MAX_FRAMES}",
                           inst.step.span, help="split it into several moves")
