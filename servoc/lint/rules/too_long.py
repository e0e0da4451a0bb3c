"""too-long: a move, hold or repeat that runs more frames or passes than the firmware counts (or, for
a repeat whose pass can take no frame, writes out)."""

from __future__ import annotations

from ...diagnostics import Severity
from ...layout import MAX_AFTER_FRAMES, MAX_FRAMELESS_PASSES
from ...flow import frameless_repeats
from ...steps import MoveStep, Plan, RepeatStep, SelectStep, steps
from .. import Report, rule

MAX_FRAMES = 65535           # frames of one move or hold, and passes of one repeat


@rule("too-long", Severity.ERROR)
def too_long(plan: Plan, report: Report) -> None:
    for st in steps(plan):
        count = st.count if isinstance(st, RepeatStep) else getattr(st, "frames", None)
        if count is not None and count > MAX_FRAMES:
            what = "passes" if isinstance(st, RepeatStep) else "frames"
            report(f"this statement runs {count} {what}; the firmware counts at most {MAX_FRAMES}",
                   st.span, help="split it into several statements (e.g. a repeat around a shorter one)")
    for st in steps(plan):
        after = st.after if isinstance(st, SelectStep) else None
        if after is not None and after.frames > MAX_AFTER_FRAMES:
            report(f"this `after` waits {after.frames} frames; the firmware counts at most {MAX_AFTER_FRAMES}",
                   after.span, help="wait in several steps: an inner `select` in the `after` branch")
    for inst in plan.moves:
        if isinstance(inst.step, MoveStep) and inst.step.frames is None and inst.frames > MAX_FRAMES:
            report(f"this move runs {inst.frames} frames; the firmware counts at most {MAX_FRAMES}",
                   inst.step.span, help="split it into several moves")
    for st, passes in frameless_repeats(plan):
        if passes > MAX_FRAMELESS_PASSES:
            report(f"a pass of this repeat can take no frame (a select whose event is already there), so the "
                   f"firmware writes it out pass by pass: {passes} passes, at most {MAX_FRAMELESS_PASSES}",
                   st.span, help="put a frame in each pass (a `move`, or a `hold` of one frame), or use fewer passes")
