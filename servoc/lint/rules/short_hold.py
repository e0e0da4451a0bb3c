"""short-hold: a hold shorter than one frame (it lasts whole frames)."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import HoldStep, Plan, steps
from ...units import fmt_ms
from .. import Report, rule
from ..common import fmt_duration


@rule("short-hold", Severity.WARNING)
def short_hold(plan: Plan, report: Report) -> None:
    for st in steps(plan):
        if isinstance(st, HoldStep) and st.duration_us < plan.period_us:
            report(f"hold {fmt_ms(st.duration_us)} is shorter than one frame ({fmt_ms(plan.period_us)}): "
                   f"it lasts {st.frames} frame{'s' if st.frames != 1 else ''}",
                   st.span, label="shorter than a frame",
                   help=f"holds last whole frames; use `hold {fmt_duration(plan.period_us)}` or drop it")
