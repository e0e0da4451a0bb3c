"""eased-overspeed: an eased curve's steepest frame asks for more than the servo's top speed."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...speed import peak_step, step_too_fast, t_dav_of, too_fast
from ...units import DAV_DEG, fmt_deg, fmt_ms
from .. import Report, rule
from ..common import whole_ms_for


@rule("eased-overspeed", Severity.WARNING)
def eased_overspeed(plan: Plan, report: Report) -> None:
    """An eased curve's steepest frame asks for more than the servo's top speed (`servoc.speed`,
    the rule the plot draws in red).

    Not said of a move that is infeasible anyway: its error says more."""
    seen: set[int] | None = None        # the infeasible moves, found at the first eased one
    for inst in plan.moves:
        step = inst.step
        if step.ease == "linear":
            continue
        if seen is None:
            seen = set(too_fast(plan))
        if id(step) in seen:
            continue
        for m in inst.motions:
            if m.n0 is None:
                continue
            ch = plan.channels[m.channel]
            t_dav = t_dav_of(plan, m.channel)
            peak = peak_step(m.n0, m.n1, inst.frames, step.ease)
            if not step_too_fast(peak, t_dav, plan.period_us):
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
                while step_too_fast(peak_step(m.n0, m.n1, f, step.ease), t_dav, plan.period_us):
                    f += 1
                help_ = f"use `in {whole_ms_for(f, plan.period_us)}` or longer, or `ease linear`"
            report(
                f"`ease {step.ease}` asks `{ch.name}` for {peak} DAV ({fmt_deg(peak * DAV_DEG)}) in one "
                f"{fmt_ms(plan.period_us)} frame at its steepest, but at its top speed ({fmt_ms(t_dav)} per DAV) "
                f"that takes {fmt_ms(peak * t_dav)}: it will lag and lose the curve's shape",
                step.span, label="peak speed too high", help=help_)
            break
