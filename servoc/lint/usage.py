"""Usage rules: declarations nothing uses, statements nothing reaches."""

from __future__ import annotations

from ..diagnostics import Reporter, Severity
from ..plan import LoopStep, Plan, PlayStep, RepeatStep
from . import rule
from ..plan import bodies
from .walk import never_ends


_USE = {"servo": "name it in a pose", "group": "name it in a pose", "pose": "`move` to it",
        "sequence": "`play` it from `main`"}


def _unused(kind: str, items, plan: Plan, reporter: Reporter) -> None:
    for item in items:
        if item.name not in plan.program.references:
            reporter.warning(f"unused-{kind}", f"{kind} `{item.name}` is never used", item.span,
                             label="declared here", help=f"remove the {kind}, or {_USE[kind]}")


def _register_unused(kind: str, declarations: str) -> None:
    def unused(plan: Plan, reporter: Reporter) -> None:
        _unused(kind, getattr(plan.program, declarations), plan, reporter)
    unused.__doc__ = f"A {kind} that nothing uses."
    rule(f"unused-{kind}", Severity.WARNING)(unused)


for _kind, _declarations in (("servo", "servos"), ("group", "groups"), ("pose", "poses"), ("sequence", "sequences")):
    _register_unused(_kind, _declarations)


@rule("unreachable", Severity.WARNING)
def unreachable(plan: Plan, reporter: Reporter) -> None:
    for body in bodies(plan):
        for i, st in enumerate(body[:-1]):
            ends = isinstance(st, LoopStep) or (
                isinstance(st, (RepeatStep, PlayStep)) and never_ends(plan, (st,)))
            if ends:
                nxt = body[i + 1]
                what = "`loop` never ends" if isinstance(st, LoopStep) else "the statement before never ends"
                reporter.warning("unreachable", f"unreachable statement: {what}", nxt.span,
                                 label="never runs", help="move it before the loop, or remove it")
                break
