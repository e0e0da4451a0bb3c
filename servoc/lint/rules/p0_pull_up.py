"""p0-pull-up: P0's pins are open-drain: servo lines and inputs on P0 need pull-up resistors on
real hardware, or they float. A warning, so that every command that builds firmware (compile,
verify, flash) and the language server show it, not only lint."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from .. import Report, rule


def _count(n: int, what: str) -> str:
    return f"the {what}" if n == 1 else f"the {n} {what}s"


@rule("p0-pull-up", Severity.WARNING)
def p0_pull_up(plan: Plan, report: Report) -> None:
    servos = [c.servo for c in plan.channels if c.port == 0]
    inputs = [i for i in plan.program.inputs if i.port == 0]
    if not servos and not inputs:
        return
    parts = ([_count(len(servos), "servo") + " on P0"] if servos else []) + \
        ([_count(len(inputs), "input") + " on P0 (" + ", ".join(f"`{i.name}`" for i in inputs) + ")"] if inputs else [])
    first = min([s.span for s in servos] + [i.span for i in inputs], key=lambda sp: sp.start)
    report("P0 has open-drain pins with no pull-ups: " + " and ".join(parts) + " will float without pull-up "
           "resistors (a servo line cannot go high, a released button does not read high)",
           first, label="on P0",
           help="fit a 4.7-10 kΩ pull-up from each P0 line to VCC (or a resistor network), or use P1, P2 or P3")
