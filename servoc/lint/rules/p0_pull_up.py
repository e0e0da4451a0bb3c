"""p0-pull-up: P0's open-drain outputs need pull-up resistors on real hardware."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from .. import Report, rule


@rule("p0-pull-up", Severity.NOTE)
def p0_pull_up(plan: Plan, report: Report) -> None:
    p0 = [c.servo for c in plan.channels if c.port == 0]
    if p0:
        report(f"P0 has open-drain outputs: {'the servo' if len(p0) == 1 else f'the {len(p0)} servos'} on P0 need"
               f"{'s' if len(p0) == 1 else ''} pull-up resistors on real hardware",
               p0[0].span, label="on P0",
               help="fit a 4.7-10 kΩ pull-up from each P0 servo line to VCC (or a resistor network)")
