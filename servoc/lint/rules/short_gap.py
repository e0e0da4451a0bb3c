"""short-gap: the frame leaves less than the known-good gap after the longest pulse."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...units import LONGEST_PULSE_US, TAIL_US, fmt_ms
from .. import Report, rule
from ..common import fmt_duration


@rule("short-gap", Severity.WARNING)
def short_gap(plan: Plan, report: Report) -> None:
    gap = plan.period_us - LONGEST_PULSE_US
    if plan.period_us >= plan.min_period_us and gap < TAIL_US and plan.ports:
        report(f"frame period {fmt_ms(plan.period_us)} leaves {fmt_ms(gap)} after a 2.5 ms pulse, "
               f"under the {fmt_ms(TAIL_US)} gap the servo is known to follow reliably",
               plan.program.frame_span, label="short gap",
               help=f"use `frame {fmt_duration(LONGEST_PULSE_US + TAIL_US)}` or longer unless your servos are tested at this rate")
