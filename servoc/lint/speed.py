"""Speed rules: a move must not ask a servo to go faster than it can."""

from __future__ import annotations

import math
from fractions import Fraction

from ..diagnostics import Reporter, Severity
from ..plan import MoveInstance, Plan, frame_value
from ..units import DAV_DEG, fmt_deg, fmt_ms
from . import rule


def fmt_duration(us: int) -> str:
    """A duration as the user would write it: `306ms` or `270.3ms`."""
    ms = Fraction(us, 1000)
    text = f"{float(ms):.3f}".rstrip("0").rstrip(".")
    return f"{text}ms"


def whole_ms_for(frames: int, period_us: int, at_least_us: Fraction = Fraction(0)) -> str:
    """The shortest whole-ms `in` duration D >= at_least_us with floor(D/P + 1/2) >= frames, e.g. `306ms`."""
    low = max(Fraction(at_least_us), (frames - Fraction(1, 2)) * period_us)
    return f"{math.ceil(low / 1000)}ms"


def too_fast(plan: Plan) -> dict[int, tuple[Fraction, MoveInstance, int]]:
    """Moves that ask a servo for |delta| x t_DAV > F x P, by id of their step:
    (the largest excess in us, the instance, the channel) of the worst context."""
    worst: dict[int, tuple[Fraction, MoveInstance, int]] = {}
    for inst in plan.moves:
        for m in inst.motions:
            t_dav = plan.class_t_dav_us[plan.channels[m.channel].speed_class]
            need = abs(m.delta) * t_dav
            excess = need - inst.frames * plan.period_us
            if excess > 0 and (id(inst.step) not in worst or excess > worst[id(inst.step)][0]):
                worst[id(inst.step)] = (excess, inst, m.channel)
    return worst


@rule("infeasible-speed", Severity.ERROR)
def infeasible_speed(plan: Plan, reporter: Reporter) -> None:
    """|delta| x t_DAV > F x P: the servo cannot get there in time."""
    for excess, inst, ch in too_fast(plan).values():
        m = next(x for x in inst.motions if x.channel == ch)
        ch_ = plan.channels[ch]
        t_dav = plan.class_t_dav_us[ch_.speed_class]
        need = abs(m.delta) * t_dav
        asked = inst.frames * plan.period_us
        frames_min = plan.speed_tables[ch_.speed_class][abs(m.delta)]
        step = inst.step
        written = fmt_ms(step.duration_us) if step.duration_us is not None else fmt_ms(asked)
        reporter.error(
            "infeasible-speed",
            f"servo `{ch_.name}` cannot move {abs(m.delta)} DAV ({fmt_deg(abs(m.delta) * DAV_DEG)}) "
            f"in {written} ({inst.frames} frame{'s' if inst.frames != 1 else ''} = {fmt_ms(asked)}): "
            f"at its top speed it needs {fmt_ms(need)}",
            step.span, label=f"too fast for `{ch_.name}`",
            help=f"use `in {whole_ms_for(frames_min, plan.period_us, need)}` or longer, or drop the duration "
                 f"(`move {step.pose}`) to go as fast as the slowest servo allows")


@rule("eased-overspeed", Severity.WARNING)
def eased_overspeed(plan: Plan, reporter: Reporter) -> None:
    """An eased curve's steepest frame asks for more than the servo's top speed.

    Not said of a move that is infeasible anyway: its error says more."""
    seen: set[int] = set(too_fast(plan))
    for inst in plan.moves:
        step = inst.step
        if step.ease == "linear" or id(step) in seen:
            continue
        for m in inst.motions:
            if m.n0 is None:
                continue
            ch = plan.channels[m.channel]
            t_dav = plan.class_t_dav_us[ch.speed_class]
            peak = _peak_step(m.n0, m.n1, inst.frames, step.ease)
            if peak * t_dav <= plan.period_us:
                continue
            seen.add(id(step))
            if t_dav > plan.period_us:
                # Every curve steps at least 1 DAV in some frame: no duration is slow enough.
                help_ = (f"`{ch.name}` takes {fmt_ms(t_dav)} per DAV, longer than one frame, so it cannot "
                         f"follow any eased curve; use `ease linear`")
            else:
                # The steps sum to |delta|, so F is at least the linear need; from there the
                # peak falls to 1 DAV within about 2 x |delta| frames.
                f = max(inst.frames + 1, plan.speed_tables[ch.speed_class][abs(m.delta)])
                while _peak_step(m.n0, m.n1, f, step.ease) * t_dav > plan.period_us:
                    f += 1
                help_ = f"use `in {whole_ms_for(f, plan.period_us)}` or longer, or `ease linear`"
            reporter.warning(
                "eased-overspeed",
                f"`ease {step.ease}` asks `{ch.name}` for {peak} DAV ({fmt_deg(peak * DAV_DEG)}) in one "
                f"{fmt_ms(plan.period_us)} frame at its steepest, but at its top speed ({fmt_ms(t_dav)} per DAV) "
                f"that takes {fmt_ms(peak * t_dav)}: it will lag and lose the curve's shape",
                step.span, label="peak speed too high", help=help_)
            break


def _peak_step(n0: int, n1: int, frames: int, ease: str) -> int:
    """The largest step in DAV between two frames of a move (frame 0 is n0)."""
    if n0 == n1:
        return 0
    if 2 * abs(n1 - n0) < frames:
        # e' <= 2 for every easing, so no frame moves 1 DAV or more before rounding,
        # hence at most 1 after; and the steps add up to |delta| > 0.
        return 1
    prev, peak = n0, 0
    for k in range(1, frames + 1):
        cur = frame_value(n0, n1, k, frames, ease)
        peak = max(peak, abs(cur - prev))
        prev = cur
    return peak
