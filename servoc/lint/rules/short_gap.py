"""short-gap: the frame leaves less than the known-good gap after the longest pulse."""

from __future__ import annotations

from ...diagnostics import Severity
from ...flow import port_tops
from ...steps import Plan
from ...units import BASE_US, DIV_US, TAIL_US, fmt_ms
from .. import Report, rule
from ..common import fmt_duration


@rule("short-gap", Severity.WARNING)
def short_gap(plan: Plan, report: Report) -> None:
    """The gap after the longest pulse any line of the program has (the highest N it reaches)."""
    if not plan.ports or plan.period_us < plan.min_period_us:
        return
    pulse = BASE_US + DIV_US * max(port_tops(plan))
    gap = plan.period_us - pulse
    if gap < TAIL_US:
        report(f"frame period {fmt_ms(plan.period_us)} leaves {fmt_ms(gap)} after the longest pulse "
               f"({fmt_ms(pulse)}), under the {fmt_ms(TAIL_US)} gap the servo is known to follow reliably",
               plan.program.frame_span, label="short gap",
               help=f"use `frame {fmt_duration(pulse + TAIL_US)}` or longer unless your servos are tested at this rate")
