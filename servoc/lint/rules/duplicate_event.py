"""duplicate-event: two `on` of one select wait for the same event; the second is never taken."""

from __future__ import annotations

from ...diagnostics import Label, Severity
from ...steps import OnBranch, Plan, SelectStep, steps
from .. import Report, rule


@rule("duplicate-event", Severity.WARNING)
def duplicate_event(plan: Plan, report: Report) -> None:
    """Branches are tried in the order written, so a later `on` of an event an earlier one of the same
    select waits for never runs (`"A"` and `65` are the same byte)."""
    for st in steps(plan):
        if not isinstance(st, SelectStep):
            continue
        first: dict[tuple, OnBranch] = {}
        for b in st.branches:
            if not isinstance(b, OnBranch):
                continue
            key = (b.event.input, b.event.byte, b.event.edge, b.event.other)
            if key not in first:
                first[key] = b
                continue
            earlier = first[key]
            same = "" if earlier.event.text == b.event.text else f" (`{earlier.event.text}` is byte {b.event.byte})"
            report(f"`on {b.event.text}` is the second `on` of this select for the same event{same}: "
                   "it is never taken", b.event.span, label="never taken",
                   help="the branches are tried in the order written; merge the two branches, or remove one",
                   secondary=(Label(earlier.event.span, "the first `on` of it"),))
