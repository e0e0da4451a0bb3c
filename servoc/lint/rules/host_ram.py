"""host-ram: `host` keeps a parser, a receive queue and 5 bytes per servo in RAM (docs/host-protocol.md)."""

from __future__ import annotations

from ... import costs
from ...diagnostics import Severity
from ...flow import HOST_PER_SERVO, frame_wrapped, host_queue, host_ram, host_vars, hosted, select_ram, watches
from ...steps import HostStep, Plan, steps
from .. import Report, rule


def host_short(plan: Plan) -> int:
    """Bytes of RAM the firmware lacks for `host` (0: it fits): with no repeat or play nested, the
    stack room left must still hold the runtime's, the edge handler's and the serial handler's."""
    if not hosted(plan):
        return 0
    serial = plan.program.serial is not None
    room = costs.stack_room(serial, select_ram(plan), len(plan.ports))
    return max(0, costs.stack_bytes(0, serial, watches(plan) or hosted(plan), frame_wrapped(plan)) - room)


@rule("host-ram", Severity.ERROR)
def host_ram_rule(plan: Plan, report: Report) -> None:
    """`host` keeps a parser, a receive queue and 5 bytes per servo in RAM; with several ports of
    servos there may be no room for them."""
    short = host_short(plan)
    if not short:
        return
    first = next(st for st in steps(plan) if isinstance(st, HostStep))
    n = len(plan.channels)
    report(f"`host` needs {host_ram(plan)} bytes of RAM ({host_vars(plan)} for its parser, a receive queue of "
           f"{host_queue(plan)} bytes, {HOST_PER_SERVO} for each of the {n} servos); with "
           f"{len(plan.ports)} port{'s' if len(plan.ports) != 1 else ''} of servos and the serial line the chip "
           f"is {short} byte{'s' if short != 1 else ''} short", first.span, label="needs the RAM",
           help="use fewer servos, or put them on fewer ports (each port in use takes 40 bytes of RAM), "
                "or a shorter frame (a smaller receive queue)")
