"""host-play-waits: a sequence `PL` can play has a select that only a byte ends."""

from __future__ import annotations

from ... import walk
from ...diagnostics import Severity
from ...flow import hosted
from ...steps import AfterBranch, Plan, SelectStep, host_playable
from .. import Report, rule


@rule("host-play-waits", Severity.WARNING)
def host_play_waits(plan: Plan, report: Report) -> None:
    """While a sequence `PL 0 SQ n` started plays, the bytes received are the host's: a select in it
    that waits only for bytes (no input, no `after`) keeps it playing until the host ends it."""
    if plan.program.serial is None or not hosted(plan):
        return
    names = [q.name for q in plan.program.sequences]
    told: set[int] = set()
    for name in host_playable(plan.program):
        body = plan.sequence(name).body
        inner = walk.reachable(body, lambda n: plan.sequence(n).body)
        for st in walk.statements([body] + [plan.sequence(n).body for n in sorted(inner)]):
            if (not isinstance(st, SelectStep) or id(st) in told
                    or any(isinstance(b, AfterBranch) or b.event.input is not None for b in st.branches)):
                continue
            told.add(id(st))
            report(f"`PL 0 SQ {names.index(name)}` plays `{name}`, whose select waits only for bytes; while it "
                   "plays the bytes received are the host's, so it waits until the host ends the sequence "
                   "(`STOP`, a group line or a `PL` line)",
                   st.span, label="only a byte ends it",
                   help="give the select an input or an `after` branch, or keep it out of the sequences the host plays")
