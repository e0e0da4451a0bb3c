"""period-too-long: the frame period is longer than Timer2 can count."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from ...units import fmt_ms
from .. import Report, rule
from ..common import fmt_duration

MAX_PERIOD_US = 65535        # Timer2 counts 16 bits of machine cycles


@rule("period-too-long", Severity.ERROR)
def period_too_long(plan: Plan, report: Report) -> None:
    if plan.period_us > MAX_PERIOD_US:
        report(f"frame period {fmt_ms(plan.period_us)} is longer than Timer2 can count "
               f"({fmt_duration(MAX_PERIOD_US)[:-2]} ms at most)",
               plan.program.frame_span, label="too long",
               help=f"use `frame {MAX_PERIOD_US // 1000}ms` or shorter; hobby servos expect a pulse at least every 20 ms")
