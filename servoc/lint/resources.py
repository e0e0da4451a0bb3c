"""Resource rules: what the AT89C52 has room for."""

from __future__ import annotations

from .. import costs
from ..diagnostics import Reporter, Severity
from ..plan import LoopStep, Plan, PlayStep, RepeatStep, Step
from . import rule


@rule("too-deep", Severity.ERROR)
def too_deep(plan: Plan, reporter: Reporter) -> None:
    """Nested repeats and plays keep their counters and return addresses on a 32-byte stack."""
    limit = costs.max_nesting()
    if plan.nesting > limit:
        memo: dict[str, int] = {}
        st = _first_too_deep(plan, plan.main, 0, limit, memo)
        word = "play" if isinstance(st, PlayStep) else "repeat"
        reporter.error(
            "too-deep",
            f"repeats and plays nest {plan.nesting} levels deep, but the firmware's {costs.STACK_BYTES}-byte "
            f"stack has room for {limit} levels (2 bytes each); this `{word}` is level {limit + 1}",
            st.span if st is not None else plan.program.main_span, label=f"level {limit + 1}",
            help="flatten the program: play a sequence once with a larger repeat count instead of nesting")


def _levels(plan: Plan, body: tuple[Step, ...], memo: dict[str, int]) -> int:
    """The deepest stack of repeats and plays inside `body` (memo: per sequence name)."""
    deepest = 0
    for st in body:
        if isinstance(st, RepeatStep):
            deepest = max(deepest, 1 + _levels(plan, st.body, memo))
        elif isinstance(st, LoopStep):
            deepest = max(deepest, _levels(plan, st.body, memo))
        elif isinstance(st, PlayStep):
            if st.sequence not in memo:
                memo[st.sequence] = _levels(plan, plan.sequence(st.sequence).body, memo)
            deepest = max(deepest, 1 + memo[st.sequence])
    return deepest


def _first_too_deep(plan: Plan, body: tuple[Step, ...], used: int, limit: int,
                    memo: dict[str, int]) -> Step | None:
    """The first `repeat` or `play` (in program order) that needs level limit + 1."""
    for st in body:
        if isinstance(st, (RepeatStep, PlayStep)):
            if used + 1 > limit:
                return st
            inner = st.body if isinstance(st, RepeatStep) else plan.sequence(st.sequence).body
            if used + 1 + _levels(plan, inner, memo) > limit:
                return _first_too_deep(plan, inner, used + 1, limit, memo)
        elif isinstance(st, LoopStep) and used + _levels(plan, st.body, memo) > limit:
            return _first_too_deep(plan, st.body, used, limit, memo)
    return None
