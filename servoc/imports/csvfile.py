"""CSV keyframes -> Keyframes.

Input: text whose first line is the header `time_ms,NAME,...` and whose
other lines are keyframes: the time in ms from the start, then one pulse
width in µs per named servo (an empty cell keeps that servo's target).
Output: one Track (not sampled) named after the file: each row is a linear
move that arrives at its time. The servos are channels 0, 1, ... in column
order, named by the header.

Units: widths are µs, or PCA9685 counts with `--ticks HZ` (`ticks_to_us`); a
column whose header name ends in `_deg` (`pan_deg`: the servo `pan`) is in
degrees, A degrees being the width a .servo `A deg` gives (N = floor(A x
250/185 + 1/2), `deg_to_us`). A note says which unit was read. When every
width of the columns in µs is below 500 (no servo is driven below 500 µs)
they look like degrees: an error that names the `_deg` suffix and `--ticks`.
The bytes may be in any encoding `as_utf8` reads (the reader converts them
itself, so it reads the same whether or not the caller already did).
"""

from __future__ import annotations

import csv
import io
import os
import re
from fractions import Fraction

from .keyframes import (Channel, ImportError_, Key, Keyframes, ReadOptions, Track, as_utf8, check_frames, decimal,
                        deg_to_us, ticks_to_us, unit_note)

_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)$")
_DEGREES = re.compile(r"(.+?)_deg", re.I)          # `pan_deg`: the servo `pan`, its column in degrees
SMALLEST_US = 500                                  # no servo is driven below 500 µs


def sniff(data: bytes, path: str) -> bool:
    head = data[:200].lstrip(b"\xef\xbb\xbf \t\r\n").lower()
    return head.startswith(b"time_ms,") or head.startswith(b"time_ms;")


def _number(cell: str, what: str) -> Fraction:
    cell = cell.strip()
    if not _NUMBER.match(cell):
        raise ImportError_(f"{what}: `{cell}` is not a number")
    return Fraction(cell)


def read(data: bytes, path: str, options: ReadOptions) -> Keyframes:
    try:
        text = as_utf8(data, path).decode("utf-8-sig")
    except UnicodeDecodeError:
        raise ImportError_(f"{path}: not UTF-8 text") from None
    check_frames(text.count("\n") - 1, path)
    delimiter = ";" if text.lstrip().lower().startswith("time_ms;") else ","
    text = text.replace("\r\n", "\n")         # CR LF line ends read like LF
    try:
        rows = [r for r in csv.reader(io.StringIO(text, newline=""), delimiter=delimiter) if any(c.strip() for c in r)]
    except csv.Error as exc:
        raise ImportError_(f"{path}: not a readable CSV file ({exc})") from None
    if not rows or rows[0][0].strip().lower() != "time_ms":
        raise ImportError_(f"{path}: a CSV import starts with the header `time_ms,NAME,...`")
    names = [c.strip() for c in rows[0][1:]]
    if not names or any(not n for n in names):
        raise ImportError_(f"{path}:1: the header needs a name for every column after `time_ms`")
    in_degrees = {ch for ch, n in enumerate(names) if _DEGREES.fullmatch(n)}
    servo_names = [_DEGREES.fullmatch(n)[1] if ch in in_degrees else n for ch, n in enumerate(names)]
    if len(names) > 24:
        raise ImportError_(f"{path}:1: {len(names)} servos; an 8051 has pins for 24")
    keys, last, widest = [], Fraction(0), None        # widest: the largest position of a column not in degrees
    for line, row in enumerate(rows[1:], start=2):
        if len(row) > len(names) + 1:
            raise ImportError_(f"{path}:{line}: {len(row)} cells, the header has {len(names) + 1}")
        at = _number(row[0], f"{path}:{line}: the time")
        if at < last:
            raise ImportError_(f"{path}:{line}: time {row[0].strip()} ms comes before the row above it "
                               f"({decimal(last)} ms); rows are in time order")
        last = at
        targets = {}
        for ch, cell in enumerate(row[1:]):
            if cell.strip():
                value = _number(cell, f"{path}:{line}: `{names[ch]}`")
                if ch in in_degrees:
                    targets[ch] = deg_to_us(value)
                else:
                    widest = value if widest is None else max(widest, value)
                    targets[ch] = value if options.ticks_hz is None else ticks_to_us(value, options.ticks_hz)
        keys.append(Key(at, targets, f"row {line}, {_ms(at)}"))
    if not keys:
        raise ImportError_(f"{path}: the header is there but no keyframe rows follow it")
    plain = [n for ch, n in enumerate(names) if ch not in in_degrees]
    if options.ticks_hz is None and widest is not None and widest < SMALLEST_US:
        raise ImportError_(
            f"{path}: every position is below {SMALLEST_US} (the largest is {decimal(widest)}), and no servo pulse is "
            f"that short, so they are not µs: if they are degrees, end the column names with `_deg` "
            f"({', '.join(f'`{n}_deg`' for n in plain[:3])}{', ...' if len(plain) > 3 else ''}: "
            f"a `_deg` column is read in degrees, as `A deg` in a .servo); "
            f"if they are PCA9685 counts, import with --ticks HZ, the PWM rate they were made for")
    notes = []
    if plain:
        notes.append(unit_note(options.ticks_hz, "positions" if not in_degrees else ", ".join(plain)))
    if in_degrees:
        notes.append(f"{', '.join(servo_names[ch] for ch in sorted(in_degrees))} read as degrees (the header names "
                     f"end in `_deg`): A is the width of `A deg`, N = floor(A x 250/185 + 1/2)")
    name = os.path.splitext(os.path.basename(path))[0]
    return Keyframes("csv", tuple(Channel(i, n) for i, n in enumerate(servo_names)), (Track(name, tuple(keys)),),
                     tuple(notes))


def _ms(at: Fraction) -> str:
    return f"{decimal(at)} ms"
