"""host-takes-bytes: a select whose meanwhile body runs `host` cannot wait for a byte."""

from __future__ import annotations

from ...diagnostics import Label, Severity
from ...flow import host_watchers
from ...steps import HostStep, OnBranch, Plan, SelectStep, steps
from .. import Report, rule


@rule("host-takes-bytes", Severity.ERROR)
def host_takes_bytes(plan: Plan, report: Report) -> None:
    """A select whose meanwhile body runs `host` cannot wait for a byte: the host parser reads them all."""
    watchers = host_watchers(plan)
    for st in steps(plan):
        if not isinstance(st, SelectStep) or id(st) not in watchers:
            continue
        for br in st.branches:
            if isinstance(br, OnBranch) and br.event.input is None:
                host = next(s for s in steps(plan) if isinstance(s, HostStep))
                report(f"`on {br.event.text}` waits for a byte while `host` runs, and `host` reads every byte "
                       "(the SSC-32 commands)", br.event.span, label="never comes",
                       secondary=(Label(host.span, "reads every byte"),),
                       help="end `host` with an input (`host until press stop`), or with `after`")
