"""eased-overspeed: an eased curve's steepest frame asks for more than the servo's top speed."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan, frame_value
from ...units import DAV_DEG, fmt_deg, fmt_ms
from .. import Report, rule
from ..common import too_fast, whole_ms_for


@rule("eased-overspeed", Severity.WARNING)
def eased_overspeed(plan: Plan, report: Report) -> None:
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
            report(
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
