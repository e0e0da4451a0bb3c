"""The linter: Plan -> diagnostics. Lint only reads the plan.

Each rule lives in its own module of `servoc.lint.rules` and is a function
registered with `@rule(code, severity)`, which states its code and severity
once: the function is handed the plan and a `Report` that files diagnostics
under that code and severity. `lint(plan, reporter)` runs them all in
registration order (the order of `rules.ORDER`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..diagnostics import Diagnostic, Label, Reporter, Severity
from ..steps import Plan
from ..source import NO_SPAN, Span


@dataclass(frozen=True)
class Report:
    """Files a rule's diagnostics with the rule's code and registered severity."""
    reporter: Reporter
    code: str
    severity: Severity

    def __call__(self, message: str, span: Span = NO_SPAN, *, label: str = "", help: str = "",
                 secondary: tuple[Label, ...] = ()) -> None:
        self.reporter.report(Diagnostic(self.code, self.severity, message, span, label, help, tuple(secondary)))


RuleFn = Callable[[Plan, Report], None]
RULES: dict[str, tuple[Severity, RuleFn]] = {}


def rule(code: str, severity: Severity) -> Callable[[RuleFn], RuleFn]:
    def register(fn: RuleFn) -> RuleFn:
        RULES[code] = (severity, fn)
        return fn
    return register


def lint(plan: Plan, reporter: Reporter) -> None:
    for code, (severity, fn) in RULES.items():
        fn(plan, Report(reporter, code, severity))


from . import rules  # noqa: E402,F401  (registers the rules)
