"""The linter: Plan -> diagnostics. Lint only reads the plan.

Each rule is a function registered under its diagnostic code with `@rule`;
`lint(plan, reporter)` runs them all in registration order.
"""

from __future__ import annotations

from typing import Callable

from ..diagnostics import Reporter, Severity
from ..plan import Plan

RuleFn = Callable[[Plan, Reporter], None]
RULES: dict[str, tuple[Severity, RuleFn]] = {}


def rule(code: str, severity: Severity) -> Callable[[RuleFn], RuleFn]:
    def register(fn: RuleFn) -> RuleFn:
        RULES[code] = (severity, fn)
        return fn
    return register


def lint(plan: Plan, reporter: Reporter) -> None:
    for _, fn in RULES.values():
        fn(plan, reporter)


from . import speed, positions, timing, usage, hardware, resources  # noqa: E402,F401  (registers the rules)
