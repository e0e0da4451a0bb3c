"""unused-servo, unused-group, unused-pose, unused-sequence, unused-input: a declaration nothing uses.

One rule for four kinds of declaration, registered once per kind. Up to `EACH`
unused declarations of a kind get a warning each; more get one warning, at the
first of them, that counts them and names the first few."""

from __future__ import annotations

from ...diagnostics import Severity
from ...flow import hosted
from ...steps import Plan
from .. import Report, rule

EACH = 5        # unused declarations of one kind reported one by one; beyond, one warning for all
NAMED = 5       # names the one warning lists

# how to use a declaration of each kind: (one, several)
_USE = {"servo": ("name it in a pose", "name them in poses"), "group": ("name it in a pose", "name them in poses"),
        "pose": ("`move` to it", "`move` to them"), "sequence": ("`play` it from `main`", "`play` them from `main`"),
        "input": ("wait for it (`wait NAME`, or `on NAME` in a `select`)", "wait for them with `wait` or `on`")}


def _unused(kind: str, declarations: str) -> None:
    def unused(plan: Plan, report: Report) -> None:
        used = plan.program.references
        if declarations in ("servos", "sequences") and hosted(plan):    # the host moves any servo, plays any sequence
            used = used | {item.name for item in getattr(plan.program, declarations)}
        items = [item for item in getattr(plan.program, declarations) if item.name not in used]
        if len(items) <= EACH:
            for item in items:
                report(f"{kind} `{item.name}` is never used", item.span,
                       label="declared here", help=f"remove the {kind}, or {_USE[kind][0]}")
            return
        items.sort(key=lambda item: item.span.start)
        names = ", ".join(f"`{item.name}`" for item in items[:NAMED])
        report(f"{len(items)} {kind}s are never used: {names} and {len(items) - NAMED} more", items[0].span,
               label="the first declared here", help=f"remove them, or {_USE[kind][1]}")
    unused.__doc__ = f"A {kind} that nothing uses."
    rule(f"unused-{kind}", Severity.WARNING)(unused)


for _kind, _declarations in (("servo", "servos"), ("group", "groups"), ("pose", "poses"), ("sequence", "sequences"),
                             ("input", "inputs")):
    _unused(_kind, _declarations)
