"""Printing: `nodes.Program` -> canonical .servo text.

Input: a syntax tree (from `servoc.syntax.parse` or built by hand). Output:
text in the canonical layout: one declaration per line, two-space indented
blocks, `name: value` pose entries separated by `, `, and a blank line
between declarations of different kinds and around every `sequence` and
`main`. Comments are not kept; a caller that makes a program (`servoc
import`) may give a trailing comment for any statement. Parsing the output gives back the same tree
apart from spans, so checking it gives an equal `model.Program`.
"""

from __future__ import annotations

from fractions import Fraction

from . import nodes

INDENT = "  "


def format_number(value: Fraction) -> str:
    """A number as a decimal: `0.25`, `-2`, `1500`.

    Exact when the fraction has a finite decimal expansion (every number
    parsed from text has one); otherwise rounded to 12 decimals.
    """
    value = Fraction(value)
    sign = "-" if value < 0 else ""
    value = abs(value)
    whole, rest = divmod(value.numerator, value.denominator)
    if rest == 0:
        return f"{sign}{whole}"
    den = value.denominator
    twos = fives = 0
    while den % 2 == 0:
        den //= 2
        twos += 1
    while den % 5 == 0:
        den //= 5
        fives += 1
    places = max(twos, fives) if den == 1 else 12
    scaled = value * 10 ** places
    digits = int(scaled) if den == 1 else int(scaled + Fraction(1, 2))
    whole, frac = divmod(digits, 10 ** places)
    frac_text = f"{frac:0{places}d}".rstrip("0")
    return f"{sign}{whole}" + (f".{frac_text}" if frac_text else "")


def format_quantity(q: nodes.Quantity) -> str:
    """A number with its unit, as written: `90deg`, `1500us`, `122`."""
    return format_number(q.value) + q.unit


def format_event(ev: nodes.Event) -> str:
    """An event or a byte as written: `button`, `"w"`, `119`, `press button`, `other`."""
    if isinstance(ev, nodes.Name):
        return ev.text
    if isinstance(ev, nodes.EdgeEvent):
        return f"{ev.word.text} {ev.input.text}"
    if isinstance(ev, nodes.OtherEvent):
        return "other"
    if isinstance(ev, nodes.StringLit):
        return f'"{ev.text}"'
    return format_quantity(ev)


def format_program(tree: nodes.Program, comments: dict | None = None) -> str:
    """The canonical text of a program (ends with one newline). `comments`: `id(statement)` ->
    a comment written at the end of that statement's (last) line."""
    chunks: list[list[str]] = []
    last_kind: str | None = None
    for item in tree.items:
        lines = _item(item, comments or {})
        kind = _KIND.get(type(item), "block")
        if chunks and (kind == "block" or kind != last_kind):
            chunks.append([])
        chunks.append(lines)
        last_kind = kind
    out: list[str] = []
    for chunk in chunks:
        out.extend(chunk if chunk else [""])
    return "\n".join(out) + "\n" if out else ""


# Consecutive declarations of one kind share a paragraph; blocks stand alone.
_KIND = {nodes.SettingDecl: "setting", nodes.FrameDecl: "setting", nodes.TargetDecl: "setting", nodes.SerialDecl: "setting",
         nodes.InputDecl: "input", nodes.ServoDecl: "servo",
         nodes.GroupDecl: "group", nodes.PoseDecl: "pose"}


def _item(item: nodes.Item, comments: dict) -> list[str]:
    if isinstance(item, nodes.FrameDecl):
        return [f"frame {format_quantity(item.period)}"]
    if isinstance(item, nodes.TargetDecl):
        clock = f" clock {format_quantity(item.clock)}" if item.clock is not None else ""
        mode = f" {item.mode[0].text} {format_quantity(item.mode[1])}" if item.mode is not None else ""
        return [f"target {item.chip.text}{clock}{mode}"]
    if isinstance(item, nodes.SettingDecl):
        value = item.value.text if isinstance(item.value, nodes.Name) else format_quantity(item.value)
        return [f"{item.word.text} {value}"]
    if isinstance(item, nodes.InputDecl):
        level = f" {item.level.text}" if item.level is not None else ""
        return [f"input {item.name.text} = {item.pin.text}{level}"]
    if isinstance(item, nodes.SerialDecl):
        return [f"serial {format_quantity(item.baud)}"]
    if isinstance(item, nodes.ServoDecl):
        options = "".join(" " + _option(o) for o in item.options)
        return [f"servo {item.name.text} = {item.pin.text}{options}"]
    if isinstance(item, nodes.GroupDecl):
        return [f"group {item.name.text} = " + ", ".join(m.text for m in item.members)]
    if isinstance(item, nodes.PoseDecl):
        head = f"pose {item.name.text}" + (f" = {item.base.text} with" if item.base is not None else "")
        entries = ", ".join(f"{e.target.text}: {format_quantity(e.position)}" for e in item.entries)
        return [f"{head} {{ {entries} }}" if entries else f"{head} {{}}"]
    if isinstance(item, nodes.SequenceDecl):
        return _block(f"sequence {item.name.text}", item.body, 0, comments)
    if isinstance(item, nodes.MainDecl):
        return _block("main", item.body, 0, comments)
    raise TypeError(f"not a declaration: {item!r}")


def _option(opt: nodes.ServoOption) -> str:
    if isinstance(opt, nodes.SpeedOption):
        return f"speed {format_quantity(opt.duration)}/{format_quantity(opt.angle)}"
    if isinstance(opt, nodes.TrimOption):
        return f"trim {format_quantity(opt.value)}"
    if isinstance(opt, nodes.LimitOption):
        return f"limit {format_quantity(opt.low)}..{format_quantity(opt.high)}"
    if isinstance(opt, nodes.ReverseOption):
        return "reverse"
    if isinstance(opt, nodes.ChannelOption):
        return f"channel {format_quantity(opt.channel)}"
    raise TypeError(f"not a servo option: {opt!r}")


def _block(head: str, body: tuple[nodes.Stmt, ...], depth: int, comments: dict) -> list[str]:
    pad = INDENT * depth
    if not body:
        return [f"{pad}{head} {{}}"]
    lines = [f"{pad}{head} {{"]
    for stmt in body:
        lines.extend(_stmt(stmt, depth + 1, comments))
        if id(stmt) in comments:
            lines[-1] += "  # " + comments[id(stmt)].replace("\n", " ")
    lines.append(f"{pad}}}")
    return lines


def _stmt(stmt: nodes.Stmt, depth: int, comments: dict) -> list[str]:
    pad = INDENT * depth
    if isinstance(stmt, nodes.MoveStmt):
        text = f"move {stmt.pose.text}"
        if stmt.duration is not None:
            text += f" in {format_quantity(stmt.duration)}"
            if stmt.ease is not None:
                text += f" ease {stmt.ease}"
        return [pad + text]
    if isinstance(stmt, nodes.HoldStmt):
        return [f"{pad}hold {format_quantity(stmt.duration)}"]
    if isinstance(stmt, nodes.RepeatStmt):
        return _block(f"repeat {format_quantity(stmt.count)}", stmt.body, depth, comments)
    if isinstance(stmt, nodes.LoopStmt):
        return _block("loop", stmt.body, depth, comments)
    if isinstance(stmt, nodes.PlayStmt):
        return [f"{pad}play {stmt.name.text}"]
    if isinstance(stmt, nodes.SelectStmt):
        lines = [f"{pad}select {{"]
        for b in stmt.branches:
            head = f"on {format_event(b.event)}" if isinstance(b, nodes.OnBranch) else \
                "meanwhile" if isinstance(b, nodes.MeanwhileBranch) else f"after {format_quantity(b.duration)}"
            lines.extend(_block(head, b.body, depth + 1, comments))
        lines.append(f"{pad}}}")
        return lines
    if isinstance(stmt, nodes.WaitStmt):
        return [f"{pad}wait {format_event(stmt.event)}"]
    if isinstance(stmt, nodes.UntilStmt):
        lines = _stmt(stmt.stmt, depth, comments)
        lines[-1] += f" until {format_event(stmt.event)}"
        return lines
    if isinstance(stmt, nodes.SendStmt):
        return [f"{pad}send {format_event(stmt.byte)}"]
    if isinstance(stmt, nodes.HostStmt):
        return [f"{pad}host"]
    raise TypeError(f"not a statement: {stmt!r}")
