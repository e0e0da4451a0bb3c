"""too-deep: nested repeats and plays keep their counters and return addresses on the stack (the RAM
the program's ports, variables and features leave: `costs.stack_room`).

The checker reports it too, through `report_too_deep`, for programs nested so deeply that the
later passes cannot walk them; lint reports the rest."""

from __future__ import annotations

from ... import costs, layout, walk
from ...diagnostics import Reporter, Severity
from ...flow import frame_wrapped, hosted, select_ram, state_may_go_to_xram, watches
from ...steps import Plan
from ...source import Span
from .. import RULES, Report, rule
from ..common import body_of


@rule("too-deep", Severity.ERROR)
def too_deep(plan: Plan, report: Report) -> None:
    """Nested repeats and plays keep their counters and return addresses on the stack."""
    serial = plan.program.serial is not None
    watch, taken, ports = watches(plan) or hosted(plan), select_ram(plan), len(plan.ports)
    wrapped = frame_wrapped(plan)
    if hosted(plan):
        return              # code generation says it (host-ram or too-deep), from the RAM it allocates
    xram = state_may_go_to_xram(plan)     # the motion state moves there where the stack needs its RAM
    if plan.nesting > costs.max_nesting(serial, watch, taken, ports, wrapped, xram):
        _report(report, plan.nesting, plan.main, body_of(plan), plan.program.main_span, serial, watch, taken, ports,
                wrapped, xram)


def report_too_deep(reporter: Reporter, depth: int, main: tuple, body_of: walk.BodyOf, main_span: Span) -> None:
    """`too-deep` for a program of any of the three trees nested `depth` levels deep (deeper than
    any configuration allows: the limit named is that of one port, the most room)."""
    _report(Report(reporter, "too-deep", RULES["too-deep"][0]), depth, main, body_of, main_span, ports=1)


def _report(report: Report, depth: int, main: tuple, body_of: walk.BodyOf, main_span: Span,
            serial: bool = False, watch: bool = False, taken: int = 0, ports: int = 3,
            wrapped: bool = False, xram: bool = False) -> None:
    """At the first repeat or play past the limit."""
    limit = max(0, costs.max_nesting(serial, watch, taken, ports, wrapped, xram))
    st = walk.first_too_deep(main, body_of, limit)
    message, label = walk.too_deep_text(depth, costs.stack_room(serial, taken, ports, xram), limit, st)
    report(message, st.span if st is not None else main_span, label=label,
           help=layout.FLATTEN)
