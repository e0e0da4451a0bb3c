"""period-too-long: the frame period is longer than Timer2 can count."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from ...units import fmt_ms
from .. import Report, rule
from ..common import fmt_duration

MAX_PERIOD_CYCLES = 65535    # Timer2 counts 16 bits of machine cycles


def max_period_us(target) -> int:
    """The longest whole-µs frame period whose machine cycles Timer2 can count."""
    return target.us_at_least(MAX_PERIOD_CYCLES + 1) - 1


@rule("period-too-long", Severity.ERROR)
def period_too_long(plan: Plan, report: Report) -> None:
    most = max_period_us(plan.program.target)
    if plan.period_us > most:
        report(f"frame period {fmt_ms(plan.period_us)} is longer than Timer2 can count "
               f"({fmt_duration(most)[:-2]} ms at most at {plan.program.target.describe()})",
               plan.program.frame_span, label="too long",
               help=f"use `frame {most // 1000}ms` or shorter; hobby servos expect a pulse at least every 20 ms")
