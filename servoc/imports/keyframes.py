"""Keyframes: what every import reader produces, whatever the source format.

A reader turns the bytes of one file (Maestro settings XML, a Blender
servo-animation export, a Bottango code export, a CSV) into a `Keyframes`:
the channels it names and one `Track` per source sequence or animation.
Positions are pulse widths in microseconds (exact `Fraction`s), times are
milliseconds from the start of the track. Nothing here knows of frame periods
or N: `servoc.imports.write` makes the program from this.

A file that is not of the reader's format, or is broken, raises `ImportError_`
with a message a user can act on (it becomes a usage error, exit 2, and
nothing is written).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Callable, Optional


class ImportError_(Exception):
    """The file cannot be imported: not this format, truncated, or values out of range."""


MAX_FRAMES = 100_000    # source frames (keyframes, samples) one import takes: 55 minutes at 30 fps, far
                        # more than any 8051's code memory holds as moves; a file with more is refused
                        # as soon as they are counted, before they are read


def check_frames(count: int, where: str) -> None:
    """Refuse more than MAX_FRAMES source frames (`where`: the file or the part that has them)."""
    if count > MAX_FRAMES:
        raise ImportError_(f"{where}: {count:,} frames, more than the {MAX_FRAMES:,} servoc imports at once; "
                           "cut the animation into shorter parts")


@dataclass(frozen=True)
class Channel:
    """One source channel: it becomes one servo."""
    index: int                              # source channel number (0-7 -> P1, 8-15 -> P2, 16-23 -> P0 unless --pins)
    name: Optional[str] = None              # as the source names it (made a valid identifier later)
    min_us: Optional[Fraction] = None       # the source's range of the channel, µs (becomes `limit`)
    max_us: Optional[Fraction] = None
    home_us: Optional[Fraction] = None      # where the source parks it at power-up, if it says
    speed_us_s: Optional[Fraction] = None   # its top speed in µs of width per second, when the source says
                                            # (the servo's `speed`: always with `servo_speed`, else when it is
                                            # slower than the default servo)
    servo_speed: bool = False               # True: `speed_us_s` is the servo's own (Bottango's rSVPin), faster
                                            # than the default servo or not; False: a limit the source sets on
                                            # the channel (a Maestro's), the servo going no faster than it can


@dataclass(frozen=True)
class Key:
    """One keyframe: the channels it sets (others keep their target) at `at_ms` from the track's start."""
    at_ms: Fraction
    targets: dict                            # channel index -> width in µs (Fraction)
    source: str                              # what the source calls it, for the comment: "frame 3", "row 7", "t=1.250 s"
    speeds: Optional[dict] = None            # paced tracks: channel -> µs/s this key's move may not exceed
                                             # (0: as fast as the servo allows); None: the channels' own speeds


@dataclass(frozen=True)
class Track:
    """One source sequence or animation: it becomes one `sequence`.

    Three kinds:
    - neither (CSV): each key is one linear move that arrives at `at_ms` (from
      the previous key's time; the first from time 0).
    - `paced=True` (Maestro): each key sets its targets at `at_ms` (its start), the
      servos go there at their speeds (the key's `speeds`, else each channel's
      `speed_us_s`, never faster than the servo) and the next key starts at its
      own `at_ms`; the track lasts `length_ms`.
    - `sampled=True` (Blender): the keys are samples the motion must meet, within
      ±1 N, at their times; the writer fits as few moves as it can through them.
    A track given as a `curve` (Bottango) is sampled by the writer at every frame
    of the firmware: `curve(t_ms)` gives each channel's width at a time from
    0 to `length_ms`.
    """
    name: str
    keys: tuple = ()
    sampled: bool = False
    paced: bool = False
    curve: Optional[Callable[[Fraction], dict]] = None
    length_ms: Fraction = Fraction(0)


@dataclass(frozen=True)
class Keyframes:
    format: str                              # "maestro", "blender", "bottango", "csv"
    channels: tuple                          # Channel, in channel order
    tracks: tuple                            # Track, in file order (main plays them once, in this order)
    notes: tuple = field(default=())         # things the reader wants the user to know (plain sentences)


def identifier(text: str, fallback: str, taken: set) -> str:
    """`text` made a valid .servo name that is not in `taken` (which it joins).

    Letters, digits and `_` stay, anything else becomes `_`, a leading digit gets
    `fallback` before it; a name already taken gets `_2`, `_3`, ...
    """
    from ..syntax import keywords
    name = re.sub(r"[^A-Za-z0-9_]+", "_", text.strip()).strip("_") if text else ""
    if not name:
        name = fallback
    elif name[0].isdigit():
        name = f"{fallback}_{name}"
    if name in keywords() or re.fullmatch(r"[Pp][0-3]", name):     # reserved, or a port's name
        name += "_"
    base, n = name, 2
    while name in taken:
        name, n = f"{base}_{n}", n + 1
    taken.add(name)
    return name


@dataclass(frozen=True)
class ReadOptions:
    """What the user told `servoc import` that a reader may need."""
    fps: Optional[Fraction] = None           # `--fps`: frames per second (Blender `.bin` has no header)
    ticks_hz: Optional[Fraction] = None      # `--ticks HZ`: positions are PCA9685 ticks (0..4095) at HZ, not µs


def ticks_to_us(ticks: Fraction, hz: Fraction) -> Fraction:
    """A PCA9685 count (4096 per period) as a width in µs at a PWM rate of `hz`."""
    return Fraction(ticks) * 1_000_000 / (4096 * Fraction(hz))


def deg_to_us(angle: Fraction) -> Fraction:
    """The width (µs) that `A deg` stands for in a .servo program: 500 µs + 8 µs x A x 250/185, whose N
    by the Positions rule (rounded half up) is floor(A x 250/185 + 1/2), the N of `A deg`."""
    from ..units import BASE_US, DIV_US, FULL_DEG, N_MAX
    return BASE_US + DIV_US * Fraction(angle) * N_MAX / FULL_DEG


def decimal(value, places: int = 3) -> str:
    """A number for a message or a comment: a decimal, never a raw fraction (1860033/1000 is
    1860.033): exact when it has at most `places` decimals, else rounded half up to `places`."""
    value = Fraction(value)
    scaled = (2 * abs(value.numerator) * 10 ** places + value.denominator) // (2 * value.denominator)
    whole, part = divmod(scaled, 10 ** places)
    text = f"{whole}.{part:0{places}d}".rstrip("0").rstrip(".") if places else str(whole)
    return ("-" if value < 0 and scaled else "") + text


def unit_note(hz, what: str = "positions") -> str:
    """The note that says which unit the positions of a CSV or a Blender export were read in: µs, or
    PCA9685 counts at `hz` (`--ticks HZ`)."""
    if hz is None:
        return f"{what} read as µs (PCA9685 counts need --ticks HZ, the PWM rate they were made for)"
    return (f"{what} read as PCA9685 counts at {decimal(hz)} Hz (--ticks {decimal(hz)}), 4096 a period: "
            f"count 307 is {decimal(ticks_to_us(307, hz), 1)} µs")


_XML_ENCODING = re.compile(rb"""^(\s*<\?xml[^>]*?encoding\s*=\s*)(["'])[^"']*\2""")


def as_utf8(data: bytes, path: str) -> bytes:
    """A text file's bytes as UTF-8, whatever it was written in: UTF-8 (with or without BOM) as it
    is, UTF-16 with a BOM and Windows-1252 (any bytes that are not UTF-8) decoded; an XML
    declaration's encoding then says UTF-8. A Blender `.bin` (by its name or its bytes) is binary:
    as it is."""
    from .blender import is_records         # here: blender imports this module
    if path.lower().endswith(".bin"):
        return data
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        text = data.decode("utf-16", errors="replace")
    else:
        try:
            data.decode("utf-8")
            return data
        except UnicodeDecodeError:
            if is_records(data):
                return data
            text = data.decode("cp1252", errors="replace")
    out = text.lstrip("\ufeff").encode("utf-8")
    return _XML_ENCODING.sub(rb"\1\2utf-8\2", out, count=1)
