"""Events for `servoc verify --events`: text -> timed input levels for ucsim.

One change per line, times from reset, `#` starts a comment:

    # a button pressed for 300 ms, half a second after reset
    500ms   button  active
    800ms   button  inactive

    # the host sends "w" at 1.2 s, then 119 and "s" back to back at 2 s
    1.2s    "w"
    2s      119 "s"

TIME is a number with `us`, `ms` or `s`; NAME an `input` of the program;
then `active` or `inactive` (what the input means, whatever its `low` or
`high`). Every input starts inactive. A line of bytes (strings, integers
0..255 or hex bytes 0x00..0xFF, one or more) is what the host sends on the
serial line: a string is its characters' bytes, with the escapes \\r, \\n,
\\t, \\0, \\\\, \\" and \\xHH, so a host command is one line (`3s "#0P1500T500\\r"`);
the first byte's start bit begins at TIME, the others follow back to back;
a byte arrives (its stop bit ends) one byte time (10 bits) after it starts.
A line of bytes must not begin before the bytes before it are through; one that begins less
than half a byte time after them follows them back to back.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction

from . import model
from .target import Target

_LINE = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*(us|ms|s)\s+(\S+)(?:\s+(\S+))?\s*$")
_SCALE = {"us": 1, "ms": 1000, "s": 1_000_000}


class EventsError(Exception):
    """A line of an events file that cannot be used: its line number and why."""

    def __init__(self, line: int, message: str):
        super().__init__(f"line {line}: {message}" if line else message)
        self.line = line


@dataclass(frozen=True)
class InputEvent:
    time_us: Fraction
    input: str
    active: bool
    line: int = field(default=0, compare=False)     # its line in the events file


@dataclass(frozen=True)
class ByteEvent:
    """Bytes the host sends back to back, the first starting at `time_us`."""
    time_us: Fraction
    data: bytes
    line: int = field(default=0, compare=False)     # its line in the events file
    input = None        # not an input's change


_BYTE = re.compile(r'"((?:[^"\\]|\\.)*)"|0[xX]([0-9A-Fa-f]+)|(\d+)')
_ESCAPE = re.compile(r'\\(x[0-9A-Fa-f]{2}|[rnt0\\"])|\\(.?)')
_ESCAPES = {"r": "\r", "n": "\n", "t": "\t", "0": "\0", "\\": "\\", '"': '"'}


def _string(text: str, number: int) -> bytes:
    """The bytes of a quoted string's inside: ASCII characters and the escapes \\r \\n \\t \\0
    \\\\ \\" and \\xHH (any byte)."""
    def one(m: re.Match) -> str:
        if m.group(1) is None:
            raise EventsError(number, f"`\\{m.group(2)}` is not an escape: write \\r, \\n, \\t, \\0, "
                                      f"\\\\, \\\" or \\xHH (e.g. \\x1b for ESC)")
        code = m.group(1)
        return chr(int(code[1:], 16)) if code[0] == "x" else _ESCAPES[code]
    plain = _ESCAPE.sub("", text)
    if not text or any(ord(c) > 127 for c in plain):
        raise EventsError(number, f'`"{text}"` is not a string of ASCII characters: write a byte past 127 '
                                  f"as \\xHH or a number")
    return _ESCAPE.sub(one, text).encode("latin-1")


def _bytes(rest: str, number: int) -> bytes:
    out = bytearray()
    pos = 0
    rest = rest.strip()
    while pos < len(rest):
        m = _BYTE.match(rest, pos)
        token = rest[pos:].split()[0] if m is None or m.group(1) is None else m.group(0)
        value = None if m is None or m.group(1) is not None else \
            int(m.group(2), 16) if m.group(2) is not None else int(m.group(3))
        if m is None or (m.end() < len(rest) and rest[m.end()] not in " \t") or (value or 0) > 255:
            raise EventsError(number, f"`{token}` is not a byte: write a string such as \"w\" or \"#0P1500T500\\r\", "
                                      f"an integer 0..255 or a hex byte 0x00..0xFF")
        out += _string(m.group(1), number) if m.group(1) is not None else bytes([value])
        pos = m.end()
        while pos < len(rest) and rest[pos] in " \t":
            pos += 1
    return bytes(out)


_COMMENT = re.compile(r'("(?:[^"\\]|\\.)*")|#.*')     # a `#` starts a comment, except inside a string
_TIME = re.compile(r"^\s*([0-9]+(?:\.[0-9]+)?)\s*(us|ms|s)\s+(.*)$")


def parse(text: str, inputs: tuple[model.Input, ...], serial: bool = False) -> list[InputEvent | ByteEvent]:
    """The events of a file, in time order (changes of one input at one time: the last one counts).
    `serial`: whether the program declares the serial line (lines of bytes need it)."""
    names = {i.name for i in inputs}
    out: list[InputEvent | ByteEvent] = []
    last: tuple[Fraction, int] | None = None       # the time of the line before, and its number
    for number, raw in enumerate(text.removeprefix("\ufeff").splitlines(), start=1):
        line = _COMMENT.sub(lambda m: m.group(1) or "", raw).strip()
        if not line:
            continue
        tm = _TIME.match(line)
        if tm is not None and (tm.group(3).startswith('"') or tm.group(3)[:1].isdigit()):
            if not serial:
                raise EventsError(number, "bytes on the serial line, but the program declares no `serial`")
            out.append(ByteEvent(Fraction(tm.group(1)) * _SCALE[tm.group(2)], _bytes(tm.group(3), number), number))
            last = _in_order(last, out[-1].time_us, number)
            continue
        m = _LINE.match(line)
        if m is None:
            raise EventsError(number, f"`{line}` is not `TIME NAME active|inactive` (e.g. `500ms button active`) "
                                      f"nor `TIME BYTE...` (e.g. `1.2s \"w\"`)")
        value, unit, name, level = m.groups()
        if name not in names:
            known = ", ".join(sorted(names)) or "none"
            raise EventsError(number, f"`{name}` is not an input of the program (inputs: {known})")
        if level not in ("active", "inactive"):
            raise EventsError(number, f"`{level or ''}`: say `active` or `inactive`")
        out.append(InputEvent(Fraction(value) * _SCALE[unit], name, level == "active", number))
        last = _in_order(last, out[-1].time_us, number)
    return sorted(out, key=lambda e: e.time_us)


def _in_order(last: tuple[Fraction, int] | None, time_us: Fraction, number: int) -> tuple[Fraction, int]:
    """Lines come in time order: an event before the one on the line before it is an error."""
    if last is not None and time_us < last[0]:
        raise EventsError(number, f"this event at {float(time_us) / 1000:g} ms comes before the one on line "
                                  f"{last[1]} ({float(last[0]) / 1000:g} ms): write the events in time order")
    return time_us, number


def byte_arrivals(events: list, byte_cycles: int, target: Target) -> list[tuple[float, int]]:
    """(µs from reset at which its stop bit ends, byte) of every byte the host sends, as
    `uart_windows` releases them."""
    _, windows = uart_windows(events, byte_cycles, target)
    data = b"".join(ev.data for ev in events if isinstance(ev, ByteEvent))
    return [(float((at + (k + 1) * byte_cycles) * target.cycle_us), data[i])
            for i, (at, k) in enumerate(window_starts(windows, byte_cycles))]


def window_starts(windows, byte_cycles: int) -> list[tuple[int, int]]:
    """(the window's start, the byte's place in it) of each byte the UART windows release, in order."""
    ons = [at for at, on in windows if on]
    offs = [at for at, on in windows if not on]
    return [(on, k) for on, off in zip(ons, offs) for k in range((off - on) // byte_cycles + 1)]


def uart_windows(events: list, byte_cycles: int, target: Target) -> tuple[bytes, list[tuple[int, bool]]]:
    """The bytes for ucsim's UART input file, and the (cycle, on) changes of its "check input"
    flag that release them: on as a line's first byte starts, off half a byte time after its
    last byte started (a window of n bytes lasts (n - 1) bytes and a half). A line that starts
    less than half a byte time after the bytes before it are through follows them back to back,
    in the same window (the flag is not turned off and on again as the UART finishes a byte).
    Raises EventsError when a line starts before the one before is through."""
    data = bytearray()
    windows: list[tuple[int, bool]] = []
    busy_until = 0
    for ev in events:
        if not isinstance(ev, ByteEvent):
            continue
        start = max(2, target.cycles(ev.time_us))
        if start < busy_until:
            raise EventsError(ev.line, f"the bytes at {float(ev.time_us) / 1000:g} ms start before those before them "
                                       f"are through (a byte takes {byte_cycles * float(target.cycle_us) / 1000:.3f} "
                                       "ms at the program's rate): start them later")
        data += ev.data
        if windows and start - busy_until < byte_cycles // 2:
            windows.pop()                   # back to back with the bytes before
            start = busy_until
        else:
            windows.append((start, True))
        windows.append((start + (len(ev.data) - 1) * byte_cycles + byte_cycles // 2, False))
        busy_until = start + len(ev.data) * byte_cycles
    return bytes(data), windows


def bytes_through(events: list, byte_cycles: int, target: Target) -> int:
    """The cycle by which the last byte the events send is through (0: they send none): bytes
    back to back take a byte time each from the line's start (`uart_windows`)."""
    _, windows = uart_windows(events, byte_cycles, target)
    return windows[-1][0] + byte_cycles - byte_cycles // 2 if windows else 0


def spaced(pins: list[tuple[int, int, int]], windows: list[tuple[int, bool]]) -> tuple[list, list]:
    """Pin changes and UART flag changes kept MIN_SPACING cycles apart from each other (the later of
    two that come closer moves later)."""
    merged = sorted([(at, 0, k) for k, (at, _, _) in enumerate(pins)] + [(at, 1, k) for k, (at, _) in enumerate(windows)])
    pins, windows = list(pins), list(windows)
    last = None
    for at, kind, k in merged:
        if last is not None and at < last + MIN_SPACING:
            at = last + MIN_SPACING
        if kind == 0:
            pins[k] = (at,) + pins[k][1:]
        else:
            windows[k] = (at, windows[k][1])
        last = at
    return pins, windows


def pin_changes(events: list, inputs: tuple[model.Input, ...], target: Target) -> list[tuple[int, int, int]]:
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
        if not isinstance(ev, InputEvent):
            continue
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
