"""What several lint rules share: how they write durations, and what a plan's moves and bodies do."""

from __future__ import annotations

import math
from fractions import Fraction

from ..steps import Plan


def fmt_duration(us: int) -> str:
    """A duration as the user would write it: `306ms` or `270.3ms`."""
    ms = Fraction(us, 1000)
    text = f"{float(ms):.3f}".rstrip("0").rstrip(".")
    return f"{text}ms"


def whole_ms_for(frames: int, period_us: int, at_least_us: Fraction = Fraction(0)) -> str:
    """The shortest whole-ms `in` duration D >= at_least_us with floor(D/P + 1/2) >= frames, e.g. `306ms`."""
    low = max(Fraction(at_least_us), (frames - Fraction(1, 2)) * period_us)
    return f"{math.ceil(low / 1000)}ms"


def body_of(plan: Plan):
    """The plan's sequences by name, for the folds of `servoc.walk`."""
    return lambda name: plan.sequence(name).body


def positions(plan: Plan):
    """Every (pose, target) of the program."""
    for pose in plan.program.poses:
        for t in pose.targets:
            yield pose, t


def num(x) -> str:
    """A Fraction as written, exactly: `7`, `7.5`, `500.0000001` (a terminating decimal; else to 6
    significant digits and a `~`, which a value written in decimal never needs)."""
    if x.denominator == 1:
        return str(x.numerator)
    d, twos, fives = x.denominator, 0, 0
    while d % 2 == 0:
        d, twos = d // 2, twos + 1
    while d % 5 == 0:
        d, fives = d // 5, fives + 1
    if d != 1:
        return f"~{float(x):g}"
    places = max(twos, fives)
    whole = abs(x.numerator) * 10 ** places // x.denominator
    text = f"{whole // 10 ** places}.{whole % 10 ** places:0{places}d}"
    return ("-" if x < 0 else "") + text


def origin_text(origin: tuple, source) -> str:
    """Where a state comes from (`MoveInstance.origin`), in words: `the start of `main``, `the end
    of `walk``, `the end of `move stand` (line 12)`, where a meanwhile body or an `until` statement is cut,
    wherever a `host` statement leaves the servos."""
    if origin[0] == "play":
        return f"the end of `{origin[1]}`"
    if origin[0] == "move":
        return f"the end of `move {origin[1]}` (line {source.line_col(origin[2].start)[0]})"
    if origin[0] == "cut":
        line = source.line_col(origin[1].start)[0]
        if origin[2] is not None:
            cut = origin[3]
            what = ("the statement" if cut is None
                    else f"`{source.text[cut.start:cut.end].split(chr(10))[0].strip()}`")
            return f"where `until {origin[2]}` (line {line}) cuts {what} short"
        return f"where an event cuts the meanwhile body of the select at line {line}"
    if origin[0] == "merged":
        return (f"any of the {origin[2]} states the servos can be in after line "
                f"{source.line_col(origin[1].start)[0]} (each servo between the positions it has in them)")
    if origin[0] == "home":
        return "the `home` pose"
    if origin[0] == "host":
        return f"wherever the host leaves the servos (`host`, line {source.line_col(origin[1].start)[0]}: `PL 0 SQ n` plays any sequence)"
    return "the start of `main`"


def context_text(inst, source) -> str:
    """The branch a move instance runs in and where its state comes from: `after `on "w"` from the
    end of `walk``; without a branch, `from the end of `walk``."""
    from ..steps import branch_text
    where = f"from {origin_text(inst.origin, source)}"
    return where if inst.branch is None else f"after `{branch_text(inst.branch)}` {where}"
