"""period-too-short: the frame period is shorter than the firmware needs for the ports in use."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...units import fmt_ms
from .. import Report, rule
from ..common import fmt_duration


@rule("period-too-short", Severity.ERROR)
def period_too_short(plan: Plan, report: Report) -> None:
    if not plan.period_holds:       # the code's model evaluated at P itself (a longer P may need more:
                                    # the serial line's runs grow with the frame)
        ports = len(plan.ports)
        report(f"frame period {fmt_ms(plan.period_us)} is too short for the {ports} port{'s' if ports != 1 else ''} "
               f"in use: the firmware needs at least {fmt_ms(plan.min_period_us)}",
               plan.program.frame_span, label="too short",
               help=f"use `frame {fmt_duration(plan.min_period_us)}` or longer, or drop `frame` for the default")
