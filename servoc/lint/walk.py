"""Helpers shared by lint rules: what running a body can do."""

from __future__ import annotations

from .. import walk
from ..plan import HoldStep, MoveStep, Plan, RepeatStep, Step


def body_of(plan: Plan):
    """The plan's `body_of` for the folds of `servoc.walk`."""
    return lambda name: plan.sequence(name).body


def _ends_never(acc: bool, st: Step, inner: bool | None) -> bool:
    return acc or walk.kind(st) == "loop" or bool(inner)


def never_ends(plan: Plan, body: tuple[Step, ...]) -> bool:
    """True when running `body` never finishes (it reaches a `loop`)."""
    return walk.fold(body, body_of(plan), False, _ends_never)


def _fewest(acc: int, st: Step, inner: int | None) -> int:
    if isinstance(st, MoveStep):
        return acc + (st.frames or 1)
    if isinstance(st, HoldStep):
        return acc + st.frames
    return acc + (st.count if isinstance(st, RepeatStep) else 1) * inner


def fewest_frames(plan: Plan, body: tuple[Step, ...]) -> int:
    """The fewest frames one pass of `body` can take (a move takes at least one)."""
    return walk.fold(body, body_of(plan), 0, _fewest)
