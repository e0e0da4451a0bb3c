"""host-ram: `host` keeps a parser, a receive queue and 5 bytes per servo in RAM (docs/host-protocol.md)."""

from __future__ import annotations

from ...diagnostics import Severity
from ...flow import host_ram_text, host_short
from ...steps import HostStep, Plan, steps
from .. import Report, rule


@rule("host-ram", Severity.ERROR)
def host_ram_rule(plan: Plan, report: Report) -> None:
    """`host` keeps a parser, a receive queue and 5 bytes per servo in RAM; with several ports of
    servos there may be no room for them."""
    short = host_short(plan)
    if not short:
        return
    first = next(st for st in steps(plan) if isinstance(st, HostStep))
    message, hint = host_ram_text(plan, short)
    report(message, first.span, label="needs the RAM", help=hint)
