"""until-no-frame (warning): `STATEMENT until EVENT` on a statement that takes no frame: there is
nothing for the event to cut short."""

from __future__ import annotations

from ...diagnostics import Severity
from ...flow import takes_frames
from ...steps import bodies, LoopStep, Plan, SelectStep
from .. import Report, rule


@rule("until-no-frame", Severity.WARNING)
def until_no_frame(plan: Plan, report: Report) -> None:
    memo: dict = {}
    for body in bodies(plan):
        for st in body:
            if (isinstance(st, SelectStep) and st.until and not takes_frames(st.meanwhile, plan, memo)
                    and not any(isinstance(m, LoopStep) for m in st.meanwhile)):    # a loop waits a frame a pass
                report("this statement takes no frame, so there is nothing for `until` to cut short", st.span,
                       label="takes no frame",
                       help="a `hold` shorter than half a frame takes none; make it longer, or drop `until`")
