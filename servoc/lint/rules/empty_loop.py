"""empty-loop: a loop whose body takes no frames would run forever without a pulse."""

from __future__ import annotations

from ... import walk
from ...diagnostics import Severity
from ...plan import AfterBranch, HoldStep, LoopStep, MoveStep, Plan, RepeatStep, SelectStep, SendStep, Step, steps
from .. import Report, rule
from ..common import body_of


@rule("empty-loop", Severity.ERROR)
def empty_loop(plan: Plan, report: Report) -> None:
    for st in steps(plan):
        if isinstance(st, LoopStep) and fewest_frames(plan, st.body) == 0:
            report("this loop takes no frames: it would run forever without sending a pulse",
                   st.span, help="put a `move` or a `hold` of at least one frame inside the loop")


def _fewest(acc: int, st: Step, inner) -> int:
    if isinstance(st, SendStep):
        return acc
    if isinstance(st, SelectStep):
        # it looks at its events after each frame: an `on` branch after one, `after` after its F
        return acc + min((v + (max(b.frames, 1) if isinstance(b, AfterBranch) else 1)
                          for b, v in zip(st.branches, inner)), default=1)
    if isinstance(st, MoveStep):
        return acc + (st.frames or 1)
    if isinstance(st, HoldStep):
        return acc + st.frames
    return acc + (st.count if isinstance(st, RepeatStep) else 1) * inner


def fewest_frames(plan: Plan, body: tuple[Step, ...]) -> int:
    """The fewest frames one pass of `body` can take (a move takes at least one, and so does a
    select: it looks at its events after each frame)."""
    return walk.fold(body, body_of(plan), 0, _fewest)
