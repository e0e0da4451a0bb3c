"""period-too-long: the frame period is longer than the frame timer (Timer0) can count."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...units import fmt_ms
from .. import Report, rule
from ..common import fmt_duration


@rule("period-too-long", Severity.ERROR)
def period_too_long(plan: Plan, report: Report) -> None:
    most = plan.program.target.max_period_us()
    if plan.period_us > most:
        report(f"frame period {fmt_ms(plan.period_us)} is longer than the frame timer (Timer0) can count "
               f"({fmt_duration(most)[:-2]} ms at most at {plan.program.target.describe()})",
               plan.program.frame_span, label="too long",
               help=f"use `frame {most // 1000}ms` or shorter; hobby servos expect a pulse at least every 20 ms")
