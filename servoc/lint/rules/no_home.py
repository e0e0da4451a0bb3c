"""no-home (note): the program's first move sets its servos at once from power-up, at full speed;
said once, at that move, naming `home` (also for servos a `home` pose leaves out)."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from .. import Report, rule


@rule("no-home", Severity.NOTE)
def no_home(plan: Plan, report: Report) -> None:
    first = next((inst for inst in plan.moves if any(m.n0 is None for m in inst.motions)), None)
    if first is None:
        return
    names = [plan.channels[m.channel].name for m in first.motions if m.n0 is None]
    shown = ", ".join(f"`{n}`" for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
    one = len(names) == 1
    home = None if plan.program.home is None else plan.program.home.name
    left_out = "" if home is None else f" (the `home` pose `{home}` leaves {'it' if one else 'them'} out)"
    report(f"at power-up {shown} {'has' if one else 'have'} no position yet{left_out}: this move sets "
           + ("it at once, and the servo jumps there at full speed from wherever it was switched off" if one
              else "them at once, and the servos jump there at full speed from wherever they were switched off"),
           first.step.span,
           label="first position set at once",
           help=(f"add {'it' if one else 'them'} to the pose `{home}`: the first frames then command "
                 f"{'its' if one else 'their'} parked position too, and the first moves are speed-checked from it"
                 if home is not None else
                 "declare where the robot is parked, e.g. `home rest` with `pose rest { ... }`: its first frames "
                 "command that pose and the first moves are speed-checked from it (`stagger 100ms` switches the "
                 "servos on one by one)"))
