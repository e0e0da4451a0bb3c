"""Rules of reacting programs and power-up:

- no-home (note): the program's first move sets its servos at once from power-up, at full speed;
  said once, at that move, naming `home`.
- level-in-loop (warning): `on NAME` (the input's level) in a select that a loop comes back to:
  a button still held is taken again on every pass; `on press NAME` is taken once per press.
- until-no-frame (warning): `STATEMENT until EVENT` on a statement that takes no frame: there is
  nothing for the event to cut short.
"""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import AfterBranch, LoopStep, Plan, SelectStep, bodies, takes_frames
from ... import walk
from .. import Report, rule


@rule("no-home", Severity.NOTE)
def no_home(plan: Plan, report: Report) -> None:
    if plan.program.home is not None:
        return
    first = next((inst for inst in plan.moves if any(m.n0 is None for m in inst.motions)), None)
    if first is None:
        return
    names = [plan.channels[m.channel].name for m in first.motions if m.n0 is None]
    shown = ", ".join(f"`{n}`" for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
    report(f"at power-up {shown} {'has' if len(names) == 1 else 'have'} no position yet: this move sets "
           f"{'it' if len(names) == 1 else 'them'} at once, and the servo{'s' if len(names) != 1 else ''} "
           "jump there at full speed from wherever they were switched off", first.step.span,
           label="first position set at once",
           help="declare where the robot is parked, e.g. `home rest` with `pose rest { ... }`: its first frames "
                "command that pose and the first moves are speed-checked from it (`stagger 100ms` switches the "
                "servos on one by one)")


@rule("level-in-loop", Severity.WARNING)
def level_in_loop(plan: Plan, report: Report) -> None:
    seen: set[int] = set()
    for body in bodies(plan):
        for st in body:
            if not isinstance(st, LoopStep):
                continue
            for inner in walk.statements([st.body]):
                if not isinstance(inner, SelectStep) or id(inner) in seen:
                    continue
                seen.add(id(inner))
                for b in inner.branches:
                    if isinstance(b, AfterBranch) or b.event.input is None or b.event.edge is not None:
                        continue
                    if _waits_release(b.body, b.event.input, plan):
                        continue
                    name = b.event.input
                    word = "wait" if inner.wait else "on"
                    report(f"`{word} {name}` is taken while `{name}` is active: held down, it is taken again each "
                           "time the loop comes back", b.event.span, label="the input's level",
                           help=f"to react once per press, write `{word} press {name}`; "
                                f"or keep the level and wait for the release in the branch (`wait release {name}`)")


def _waits_release(body: tuple, name: str, plan: Plan) -> bool:
    return any(isinstance(st, SelectStep) and any(not isinstance(b, AfterBranch) and b.event.input == name
                                                  and b.event.edge == "release" for b in st.branches)
               for st in walk.statements([body]))


@rule("until-no-frame", Severity.WARNING)
def until_no_frame(plan: Plan, report: Report) -> None:
    memo: dict = {}
    for body in bodies(plan):
        for st in body:
            if isinstance(st, SelectStep) and st.until and not takes_frames(st.meanwhile, plan, memo):
                report("this statement takes no frame, so there is nothing for `until` to cut short", st.span,
                       label="takes no frame",
                       help="a `hold` shorter than half a frame takes none; make it longer, or drop `until`")
