"""level-in-loop (warning): `on NAME` (the input's level) in a select that a loop comes back to:
a button still held is taken again on every pass; `on press NAME` is taken once per press."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import AfterBranch, bodies, LoopStep, Plan, SelectStep
from ... import walk
from .. import Report, rule


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
