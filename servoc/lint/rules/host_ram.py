"""host-ram: `host` keeps a parser, a receive queue and 5 bytes per servo in RAM (docs/host-protocol.md).
Whether they fit is found from the RAM the firmware generated for the plan allocates (code
generation's `host-ram`), so that lint refuses exactly what compile refuses."""

from __future__ import annotations

from ...diagnostics import Severity, limit_diagnostic
from ...steps import Plan
from .. import Report, rule


@rule("host-ram", Severity.ERROR)
def host_ram_rule(plan: Plan, report: Report) -> None:
    """`host` keeps a parser, a receive queue and 5 bytes per servo in RAM; with several ports of
    servos there may be no room for them."""
    for code, message, help_, span, labels in plan.firmware_limit or ():
        if code == "host-ram":
            report.reporter.report(limit_diagnostic(code, message, help_, span or plan.program.main_span, labels))
