"""The resource limits the generated code hits (serial-too-fast, send-overrun, ram-overflow, ...):
found from the code generated for the plan, without the assembler, so lint and the language server
report them as compile does. A limit another rule reports first (too-deep, too-long) is not repeated.
The ROM (rom-overflow) comes from the period stage, which measures the code (api.choose_period)."""

from __future__ import annotations

from ...diagnostics import Severity, limit_diagnostic
from ...steps import Plan
from .. import Report, rule


@rule("serial-too-fast", Severity.ERROR)
def firmware_limit(plan: Plan, report: Report) -> None:
    if plan.firmware_limit is None:
        return
    for code, message, help_, span, labels in plan.firmware_limit:
        if any(d.code == code and d.is_error for d in report.reporter.diagnostics):
            continue
        report.reporter.report(limit_diagnostic(code, message, help_, span or plan.program.main_span, labels))
