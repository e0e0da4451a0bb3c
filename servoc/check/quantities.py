"""Quantities as written -> values: pure conversions, no reporting.

Each function returns the value, or a `Problem` (the message and help of a
`bad-unit` error) when the quantity has the wrong unit or none; the passes
report it where the quantity was written.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from fractions import Fraction

from .. import model, nodes, units
from ..printer import format_number, format_quantity

ANGLE_UNITS = ("deg",)
KNOWN_UNITS = ("deg", *units.TIME_UNITS_US, *units.FREQ_UNITS_HZ)
POSITION_NEED = "a position (an angle such as `90deg`, a pulse width such as `1500us`, or a raw N such as `122`)"
DURATION_NEED = "a duration such as `300ms`"


@dataclass(frozen=True)
class Problem:
    """Why a quantity is not what is needed: a `bad-unit` error's message and help."""
    message: str
    help: str = ""


def wrong_unit(q: nodes.Quantity, need: str, context: str = "") -> Problem:
    """`q` has a unit (or none) where `need` is needed, e.g. in `context`."""
    text = format_quantity(q)
    unit = q.unit
    where = f" in {context}" if context else ""
    if unit in ANGLE_UNITS:
        msg = f"`{text}` is an angle where {need} is needed{where}"
    elif unit in units.TIME_UNITS_US:
        msg = f"`{text}` is a duration where {need} is needed{where}"
    elif unit in units.FREQ_UNITS_HZ:
        msg = f"`{text}` is a frequency where {need} is needed{where}"
    elif unit == "":
        msg = f"`{text}` has no unit where {need} is needed{where}"
    else:
        close = difflib.get_close_matches(unit, KNOWN_UNITS, n=1, cutoff=0.5)
        lower = [u for u in KNOWN_UNITS if u.lower() == unit.lower()]
        hint = f"did you mean `{format_number(q.value)}{(lower or close)[0]}`?" if (lower or close) else ""
        return Problem(f"unknown unit `{unit}` in `{text}`; {need} is needed{where}",
                       hint or "the units are deg, us, ms, s, Hz, kHz and MHz")
    help_ = ""
    example = "" if "position" in need else next(
        (u for word, u in (("duration", "ms"), ("period", "ms"), ("angle", "deg"), ("clock", "MHz"))
         if word in need), "")
    if unit == "" and example:
        help_ = f"write the unit right after the number, e.g. `{format_number(q.value)}{example}`"
    elif example == "ms":
        help_ = "durations are written in `us`, `ms` or `s`, e.g. `300ms`"
    elif example == "deg":
        help_ = "angles are written in `deg`, e.g. `60deg`"
    elif example == "MHz":
        help_ = "the clock is written `12MHz`"
    elif "count" in need:
        help_ = "a count is a bare whole number, e.g. `repeat 3`"
    elif "position" in need:
        help_ = "positions are angles (`90deg`), pulse widths (`1500us`) or raw N (`122`)"
    return Problem(msg, help_)


def _scaled(q: nodes.Quantity, factors: dict[str, Fraction], context: str, need: str) -> Fraction | Problem:
    if q.unit in factors:
        return q.value * factors[q.unit]
    return wrong_unit(q, need, context)


def duration_us(q: nodes.Quantity, context: str, need: str = DURATION_NEED) -> Fraction | Problem:
    return _scaled(q, units.TIME_UNITS_US, context, need)


def frequency_hz(q: nodes.Quantity, context: str, need: str) -> Fraction | Problem:
    return _scaled(q, units.FREQ_UNITS_HZ, context, need)


def angle_deg(q: nodes.Quantity, context: str, need: str) -> Fraction | Problem:
    return _scaled(q, {unit: Fraction(1) for unit in ANGLE_UNITS}, context, need)


def position(q: nodes.Quantity, context: str = "") -> model.Position | Problem:
    if q.unit == "":
        if q.value.denominator != 1:
            return Problem(f"`{format_quantity(q)}` has no unit, and a bare number is a raw N, which must be whole",
                           "write an angle (`90deg`) or a pulse width (`1500us`) for positions between steps")
        return model.Position(q.value, "n", int(q.value), q.span)
    if q.unit == "deg":
        return model.Position(q.value, "deg", units.deg_to_n(q.value), q.span)
    width = _scaled(q, units.TIME_UNITS_US, context, POSITION_NEED)
    return width if isinstance(width, Problem) else model.Position(width, "us", units.width_to_n(width), q.span)


def trim(q: nodes.Quantity) -> int | Problem:
    if q.unit != "" or q.value.denominator != 1:
        return Problem(f"trim is a whole number of N steps, not `{format_quantity(q)}`",
                       "one N step is 8 µs (0.74°); e.g. `trim -2`")
    return int(q.value)


def channel(q: nodes.Quantity) -> Fraction | Problem:
    """A `channel K`'s number (whether it is a whole number 0..31 is the caller's)."""
    if q.unit != "":
        return wrong_unit(q, "a channel number such as `3`", "`channel`")
    return q.value


def count(q: nodes.Quantity) -> Fraction | Problem:
    """A repeat count's number (whether it is a whole number of at least 1 is the caller's)."""
    if q.unit != "":
        return wrong_unit(q, "a repeat count such as `3`", "`repeat`")
    return q.value
