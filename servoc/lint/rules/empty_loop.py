"""empty-loop: a loop whose body takes no frame: each pass waits for the next frame, so it only
repeats the current targets (and sends, once a frame) forever."""

from __future__ import annotations

from ...diagnostics import Severity
from ...flow import takes_frames
from ...steps import LoopStep, Plan, SelectStep, steps
from .. import Report, rule


@rule("empty-loop", Severity.WARNING)
def empty_loop(plan: Plan, report: Report) -> None:
    memo: dict = {}
    # `loop { ... } until EVENT`: the loop waits a frame a pass until the event, like `wait EVENT`
    waits = {id(m) for st in steps(plan) if isinstance(st, SelectStep) and st.until for m in st.meanwhile}
    for st in steps(plan):
        if isinstance(st, LoopStep) and id(st) not in waits and not takes_frames(st.body, plan, memo):
            report("this loop takes no frames: each pass waits for the next frame, so it repeats the current "
                   "targets forever", st.span,
                   help="put a `move`, a `hold` of at least one frame or a `select` inside the loop; "
                        "or drop the loop (when `main` ends, its last targets repeat forever)")
