"""infeasible-speed: |delta| x t_DAV > F x P, the servo cannot get there in time."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from ...speed import t_dav_of, too_fast
from ...units import DAV_DEG, fmt_deg, fmt_ms
from .. import Report, rule
from ..common import whole_ms_for


@rule("infeasible-speed", Severity.ERROR)
def infeasible_speed(plan: Plan, report: Report) -> None:
    """|delta| x t_DAV > F x P: the servo cannot get there in time (`servoc.speed`, the rule the
    plot draws in red)."""
    for excess, inst, ch in too_fast(plan).values():
        m = next(x for x in inst.motions if x.channel == ch)
        ch_ = plan.channels[ch]
        t_dav = t_dav_of(plan, ch)
        need = abs(m.delta) * t_dav
        asked = inst.frames * plan.period_us
        frames_min = plan.speed_tables[ch_.speed_class][abs(m.delta)]
        step = inst.step
        written = fmt_ms(step.duration_us) if step.duration_us is not None else fmt_ms(asked)
        report(
            f"servo `{ch_.name}` cannot move {abs(m.delta)} DAV ({fmt_deg(abs(m.delta) * DAV_DEG)}) "
            f"in {written} ({inst.frames} frame{'s' if inst.frames != 1 else ''} = {fmt_ms(asked)}): "
            f"at its top speed it needs {fmt_ms(need)}",
            step.span, label=f"too fast for `{ch_.name}`",
            help=f"use `in {whole_ms_for(frames_min, plan.period_us, need)}` or longer, or drop the duration "
                 f"(`move {step.pose}`) to go as fast as the slowest servo allows")
