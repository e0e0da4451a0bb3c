"""Speed rules: a move must not ask a servo to go faster than it can."""

from __future__ import annotations

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


@rule("infeasible-speed", Severity.ERROR)
def infeasible_speed(plan: Plan, reporter: Reporter) -> None:
    """|delta| x t_DAV > F x P: the servo cannot get there in time."""
    worst: dict[int, tuple[Fraction, MoveInstance, int]] = {}
    for inst in plan.moves:
        for m in inst.motions:
            t_dav = plan.class_t_dav_us[plan.channels[m.channel].speed_class]
            need = abs(m.delta) * t_dav
            excess = need - inst.frames * plan.period_us
            if excess > 0 and (id(inst.step) not in worst or excess > worst[id(inst.step)][0]):
                worst[id(inst.step)] = (excess, inst, m.channel)
    for excess, inst, ch in worst.values():
        m = next(x for x in inst.motions if x.channel == ch)
        ch_ = plan.channels[ch]
        t_dav = plan.class_t_dav_us[ch_.speed_class]
        need = abs(m.delta) * t_dav
        asked = inst.frames * plan.period_us
        frames_min = plan.speed_tables[ch_.speed_class][abs(m.delta)]
        step = inst.step
        reporter.error(
            "infeasible-speed",
            f"servo `{ch_.name}` cannot move {abs(m.delta)} DAV ({fmt_deg(abs(m.delta) * DAV_DEG)}) "
            f"in {fmt_ms(asked)} ({inst.frames} frame{'s' if inst.frames != 1 else ''}): "
            f"it needs {fmt_ms(need)} at its top speed",
            step.span, label=f"too fast for `{ch_.name}`",
            help=f"use `in {fmt_duration(frames_min * plan.period_us)}` or drop the duration "
                 f"(`move {step.pose}`) to go as fast as the slowest servo allows")


@rule("eased-overspeed", Severity.WARNING)
def eased_overspeed(plan: Plan, reporter: Reporter) -> None:
    """An eased curve's steepest frame asks for more than the servo's top speed."""
    seen: set[int] = set()
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
            f = inst.frames
            while _peak_step(m.n0, m.n1, f, step.ease) * t_dav > plan.period_us and f < 100_000:
                f += 1
            seen.add(id(step))
            reporter.warning(
                "eased-overspeed",
                f"`ease {step.ease}` asks `{ch.name}` for {peak} DAV ({fmt_deg(peak * DAV_DEG)}) in one "
                f"{fmt_ms(plan.period_us)} frame at its steepest, faster than its top speed "
                f"({fmt_ms(t_dav)} per DAV): it will lag and lose the curve's shape",
                step.span, label="peak speed too high",
                help=f"use `in {fmt_duration(f * plan.period_us)}` or longer, or `ease linear`")
            break


def _peak_step(n0: int, n1: int, frames: int, ease: str) -> int:
    prev, peak = n0, 0
    for k in range(1, frames + 1):
        cur = frame_value(n0, n1, k, frames, ease)
        peak = max(peak, abs(cur - prev))
        prev = cur
    return peak
