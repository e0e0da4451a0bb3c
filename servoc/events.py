"""Events for `servoc verify --events`: text -> timed input levels for ucsim.

One change per line, times from reset, `#` starts a comment:

    # a button pressed for 300 ms, half a second after reset
    500ms   button  active
    800ms   button  inactive

TIME is a number with `us`, `ms` or `s`; NAME an `input` of the program;
then `active` or `inactive` (what the input means, whatever its `low` or
`high`). Every input starts inactive. Serial bytes (`TIME "w"`) are part of
the format, but the firmware does not build `serial` yet, so they are refused.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction

from . import model
from .target import Target

_LINE = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*(us|ms|s)\s+(\S+)(?:\s+(\S+))?\s*$")
_SCALE = {"us": 1, "ms": 1000, "s": 1_000_000}


class EventsError(Exception):
    """A line of an events file that cannot be used: its line number and why."""

    def __init__(self, line: int, message: str):
        super().__init__(f"line {line}: {message}")
        self.line = line


@dataclass(frozen=True)
class InputEvent:
    time_us: Fraction
    input: str
    active: bool


def parse(text: str, inputs: tuple[model.Input, ...]) -> list[InputEvent]:
    """The events of a file, in time order (changes of one input at one time: the last one counts)."""
    names = {i.name for i in inputs}
    out: list[InputEvent] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _LINE.match(line)
        if m is None:
            raise EventsError(number, f"`{line}` is not `TIME NAME active|inactive` (e.g. `500ms button active`)")
        value, unit, name, level = m.groups()
        if name.startswith('"') or name.isdigit():
            raise EventsError(number, "serial bytes need `serial`, which the firmware does not build yet")
        if name not in names:
            known = ", ".join(sorted(names)) or "none"
            raise EventsError(number, f"`{name}` is not an input of the program (inputs: {known})")
        if level not in ("active", "inactive"):
            raise EventsError(number, f"`{level or ''}`: say `active` or `inactive`")
        out.append(InputEvent(Fraction(value) * _SCALE[unit], name, level == "active"))
    return sorted(out, key=lambda e: e.time_us)


def pin_changes(events: list[InputEvent], inputs: tuple[model.Input, ...], target: Target) -> list[tuple[int, int, int]]:
    """(cycle, port, outside level of the port's pins) for ucsim: every input inactive from cycle 1
    (an active-high input's pin low), then each event at its machine cycle (changes less than
    MIN_SPACING cycles apart move that much later)."""
    by_name = {i.name: i for i in inputs}
    levels = {p: 0xFF for p in range(4)}

    def apply(inp: model.Input, active: bool) -> None:
        high = active == inp.active_high
        bit = 1 << inp.bit
        levels[inp.port] = (levels[inp.port] | bit) if high else (levels[inp.port] & ~bit & 0xFF)

    changes: dict[int, dict[int, int]] = {}
    for inp in inputs:
        apply(inp, False)
        changes.setdefault(1, {})[inp.port] = levels[inp.port]
    for ev in events:
        at = max(2, target.cycles(ev.time_us))
        apply(by_name[ev.input], ev.active)
        changes.setdefault(at, {})[by_name[ev.input].port] = levels[by_name[ev.input].port]
    out: list[tuple[int, int, int]] = []
    for at in sorted(changes):
        for port, level in sorted(changes[at].items()):
            if out and at < out[-1][0] + MIN_SPACING:
                at = out[-1][0] + MIN_SPACING
            out.append((at, port, level))
    return out


# ucsim stops once for each change (the run goes on at the next); changes closer than its longest
# instruction could fall in one, so they are kept this many machine cycles apart.
MIN_SPACING = 8
