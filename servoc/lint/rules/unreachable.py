"""unreachable: a statement after one that never ends (a `loop`, or a `select` every branch of
which never ends, or a repeat or a play of such)."""

from __future__ import annotations

from ... import walk
from ...diagnostics import Severity
from ...steps import bodies, LoopStep, Plan, SelectStep, Step
from .. import Report, rule
from ..common import body_of


@rule("unreachable", Severity.WARNING)
def unreachable(plan: Plan, report: Report) -> None:
    for body in bodies(plan):
        for i, st in enumerate(body[:-1]):
            if walk.kind(st) in ("loop", "repeat", "play", "select") and never_ends(plan, (st,)):
                what = ("`loop` never ends" if isinstance(st, LoopStep) else
                        "no branch of the `select` before ever ends, so it is never left"
                        if isinstance(st, SelectStep) else "the statement before never ends")
                report(f"unreachable statement: {what}", body[i + 1].span,
                       label="never runs", help="move it before the loop, or remove it")
                break


def _ends_never(acc: bool, st: Step, inner) -> bool:
    if walk.kind(st) == "select":
        return acc or (bool(inner) and all(inner))
    return acc or walk.kind(st) == "loop" or bool(inner)


def never_ends(plan: Plan, body: tuple[Step, ...]) -> bool:
    """True when running `body` never finishes (it reaches a `loop`, or a `select` whose every
    branch never finishes)."""
    return walk.fold(body, body_of(plan), False, _ends_never)
