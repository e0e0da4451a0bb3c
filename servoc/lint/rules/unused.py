"""unused-servo, unused-group, unused-pose, unused-sequence: a declaration nothing uses.

One rule for four kinds of declaration, registered once per kind."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from .. import Report, rule

_USE = {"servo": "name it in a pose", "group": "name it in a pose", "pose": "`move` to it",
        "sequence": "`play` it from `main`"}


def _unused(kind: str, declarations: str) -> None:
    def unused(plan: Plan, report: Report) -> None:
        for item in getattr(plan.program, declarations):
            if item.name not in plan.program.references:
                report(f"{kind} `{item.name}` is never used", item.span,
                       label="declared here", help=f"remove the {kind}, or {_USE[kind]}")
    unused.__doc__ = f"A {kind} that nothing uses."
    rule(f"unused-{kind}", Severity.WARNING)(unused)


for _kind, _declarations in (("servo", "servos"), ("group", "groups"), ("pose", "poses"), ("sequence", "sequences")):
    _unused(_kind, _declarations)
