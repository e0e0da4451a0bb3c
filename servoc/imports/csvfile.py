"""CSV keyframes -> Keyframes.

Input: text whose first line is the header `time_ms,NAME,...` and whose
other lines are keyframes: the time in ms from the start, then one pulse
width in µs per named servo (an empty cell keeps that servo's target).
Output: one Track (not sampled) named after the file: each row is a linear
move that arrives at its time. The servos are channels 0, 1, ... in column
order, named by the header.
"""

from __future__ import annotations

import csv
import io
import os
import re
from fractions import Fraction

from .keyframes import Channel, ImportError_, Key, Keyframes, ReadOptions, Track, check_frames, ticks_to_us

_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)$")


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
        text = data.decode("utf-8-sig")
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
    if len(names) > 24:
        raise ImportError_(f"{path}:1: {len(names)} servos; an 8051 has pins for 24")
    keys, last = [], Fraction(0)
    for line, row in enumerate(rows[1:], start=2):
        if len(row) > len(names) + 1:
            raise ImportError_(f"{path}:{line}: {len(row)} cells, the header has {len(names) + 1}")
        at = _number(row[0], f"{path}:{line}: the time")
        if at < last:
            raise ImportError_(f"{path}:{line}: time {row[0].strip()} ms comes before the row above it "
                               f"({last} ms); rows are in time order")
        last = at
        targets = {}
        for ch, cell in enumerate(row[1:]):
            if cell.strip():
                width = _number(cell, f"{path}:{line}: `{names[ch]}`")
                targets[ch] = width if options.ticks_hz is None else ticks_to_us(width, options.ticks_hz)
        keys.append(Key(at, targets, f"row {line}, {_ms(at)}"))
    if not keys:
        raise ImportError_(f"{path}: the header is there but no keyframe rows follow it")
    name = os.path.splitext(os.path.basename(path))[0]
    return Keyframes("csv", tuple(Channel(i, n) for i, n in enumerate(names)), (Track(name, tuple(keys)),))


def _ms(at: Fraction) -> str:
    return f"{float(at):g} ms"
