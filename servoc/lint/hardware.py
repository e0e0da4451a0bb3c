"""Hardware rules: what the board needs beyond the firmware."""

from __future__ import annotations

from ..diagnostics import Reporter, Severity
from ..plan import Plan
from . import rule


@rule("p0-pull-up", Severity.NOTE)
def p0_pull_up(plan: Plan, reporter: Reporter) -> None:
    p0 = [c.servo for c in plan.channels if c.port == 0]
    if p0:
        reporter.note(
            "p0-pull-up",
            f"P0 has open-drain outputs: {'the servo' if len(p0) == 1 else f'the {len(p0)} servos'} on P0 need"
            f"{'s' if len(p0) == 1 else ''} pull-up resistors on real hardware",
            p0[0].span, label="on P0",
            help="fit a 4.7-10 kΩ pull-up from each P0 servo line to VCC (or a resistor network)")
