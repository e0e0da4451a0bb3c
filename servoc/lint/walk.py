"""Helpers shared by lint rules: what running a body can do."""

from __future__ import annotations

from ..plan import HoldStep, LoopStep, MoveStep, Plan, PlayStep, RepeatStep, Step


def never_ends(plan: Plan, body: tuple[Step, ...], _memo: dict | None = None) -> bool:
    """True when running `body` never finishes (it reaches a `loop`)."""
    memo = {} if _memo is None else _memo     # per sequence name: sequences may be played many times
    for st in body:
        if isinstance(st, LoopStep):
            return True
        if isinstance(st, RepeatStep) and never_ends(plan, st.body, memo):
            return True
        if isinstance(st, PlayStep):
            if st.sequence not in memo:
                memo[st.sequence] = never_ends(plan, plan.sequence(st.sequence).body, memo)
            if memo[st.sequence]:
                return True
    return False


def fewest_frames(plan: Plan, body: tuple[Step, ...], _memo: dict | None = None) -> int:
    """The fewest frames one pass of `body` can take (a move takes at least one)."""
    memo = {} if _memo is None else _memo     # per sequence name
    total = 0
    for st in body:
        if isinstance(st, MoveStep):
            total += st.frames or 1
        elif isinstance(st, HoldStep):
            total += st.frames
        elif isinstance(st, RepeatStep):
            total += st.count * fewest_frames(plan, st.body, memo)
        elif isinstance(st, LoopStep):
            total += fewest_frames(plan, st.body, memo)
        else:
            if st.sequence not in memo:
                memo[st.sequence] = fewest_frames(plan, plan.sequence(st.sequence).body, memo)
            total += memo[st.sequence]
    return total
