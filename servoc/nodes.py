"""The syntax tree of a .servo program, as written.

Input: produced by `servoc.syntax.parse` from a `SourceFile`. Output: read by
`servoc.check` (names, units, limits) and by `servoc.printer` (canonical text).

Invariants:
- every node is a frozen dataclass with a `span: Span` field: character
  offsets into `SourceFile.text`, covering the construct as written (a
  statement from its keyword to its last token, a block statement through
  its closing brace, a pose entry from its target name through its value);
- nothing is resolved or checked yet: names are plain text, numbers keep the
  unit written after them (`Quantity.unit` is "" for a bare number), pins are
  the text as written (`P1.0`), and a servo's options keep their order and
  may repeat;
- numbers are exact `Fraction`s taken from their decimal text, never floats;
- `Program.items` keeps the declarations in source order (the checker needs
  the order for "setting after use" errors).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Union

from .source import Span


@dataclass(frozen=True)
class Name:
    """An identifier as written: a declaration's name or a reference."""
    text: str
    span: Span


@dataclass(frozen=True)
class Quantity:
    """A number and the unit written right after it ("" when none).

    `value` is exact; it is negative only for a `trim` written with `-`.
    """
    value: Fraction
    unit: str
    span: Span


@dataclass(frozen=True)
class Pin:
    """A pin as written, e.g. `P1.0`; the checker validates it."""
    text: str
    span: Span


# ---- servo options ---------------------------------------------------------

@dataclass(frozen=True)
class SpeedOption:
    """`speed DUR/ANGLE`."""
    duration: Quantity
    angle: Quantity
    span: Span


@dataclass(frozen=True)
class TrimOption:
    """`trim INT` (the sign, if any, is folded into `value.value`)."""
    value: Quantity
    span: Span


@dataclass(frozen=True)
class LimitOption:
    """`limit LOW..HIGH`."""
    low: Quantity
    high: Quantity
    span: Span


@dataclass(frozen=True)
class ReverseOption:
    """`reverse`."""
    span: Span


@dataclass(frozen=True)
class ChannelOption:
    """`channel K`: the servo's channel in the host protocol (K not checked yet)."""
    channel: Quantity
    span: Span


ServoOption = Union[SpeedOption, TrimOption, LimitOption, ReverseOption, ChannelOption]


# ---- declarations ----------------------------------------------------------

@dataclass(frozen=True)
class FrameDecl:
    """`frame DUR`."""
    period: Quantity
    span: Span


@dataclass(frozen=True)
class TargetDecl:
    """`target CHIP [clock FREQ] [mode 12T|6T]`."""
    chip: Name
    clock: Quantity | None
    span: Span
    mode: tuple[Name, Quantity] | None = None     # the word (must be `mode`) and `12T` or `6T`


@dataclass(frozen=True)
class InputDecl:
    """`input NAME = PIN [low|high]`; `level` is the word as written (must be `low` or `high`)."""
    name: Name
    pin: Pin
    level: Name | None
    span: Span


@dataclass(frozen=True)
class SerialDecl:
    """`serial BAUD`."""
    baud: Quantity
    span: Span


@dataclass(frozen=True)
class ServoDecl:
    """`servo NAME = PIN OPTION*`."""
    name: Name
    pin: Pin
    options: tuple[ServoOption, ...]
    span: Span


@dataclass(frozen=True)
class GroupDecl:
    """`group NAME = NAME, NAME, ...`."""
    name: Name
    members: tuple[Name, ...]
    span: Span


@dataclass(frozen=True)
class Entry:
    """One pose entry `TARGET: POSITION`; TARGET is a servo, group or port."""
    target: Name
    position: Quantity
    span: Span


@dataclass(frozen=True)
class PoseDecl:
    """`pose NAME { ENTRY, ... }` or, with `base`, `pose NAME = BASE with { ... }`."""
    name: Name
    base: Name | None
    entries: tuple[Entry, ...]
    span: Span


# ---- statements ------------------------------------------------------------

@dataclass(frozen=True)
class MoveStmt:
    """`move POSE [in DUR [ease KIND]]`; `ease` is the word as written or None."""
    pose: Name
    duration: Quantity | None
    ease: str | None
    span: Span


@dataclass(frozen=True)
class HoldStmt:
    """`hold DUR`."""
    duration: Quantity
    span: Span


@dataclass(frozen=True)
class RepeatStmt:
    """`repeat N { STATEMENTS }`."""
    count: Quantity
    body: tuple["Stmt", ...]
    span: Span


@dataclass(frozen=True)
class LoopStmt:
    """`loop { STATEMENTS }`."""
    body: tuple["Stmt", ...]
    span: Span


@dataclass(frozen=True)
class PlayStmt:
    """`play SEQUENCE`."""
    name: Name
    span: Span


@dataclass(frozen=True)
class StringLit:
    """A string as written, `"w"`: `text` is what is between the quotes."""
    text: str
    span: Span


@dataclass(frozen=True)
class EdgeEvent:
    """`press NAME` / `release NAME` after `on` or `wait`: `word` must be `press` or `release`
    (no keywords: the checker says so otherwise)."""
    word: Name
    input: Name
    span: Span
    literal: bool = False           # `input` is a byte as written (`press "g"`): the checker says so


@dataclass(frozen=True)
class OtherEvent:
    """`other` after `on`: any byte no other `on` of the select names."""
    span: Span


# An event or a byte as written: an input's name, a string, a number, an edge or `other`.
Event = Union[Name, StringLit, Quantity, EdgeEvent, OtherEvent]


@dataclass(frozen=True)
class OnBranch:
    """`on EVENT { STATEMENTS }` inside a select."""
    event: Event
    body: tuple["Stmt", ...]
    span: Span


@dataclass(frozen=True)
class AfterBranch:
    """`after DUR { STATEMENTS }` inside a select."""
    duration: Quantity
    body: tuple["Stmt", ...]
    span: Span


@dataclass(frozen=True)
class MeanwhileBranch:
    """`meanwhile { STATEMENTS }` inside a select: what runs while it waits."""
    body: tuple["Stmt", ...]
    span: Span


@dataclass(frozen=True)
class SelectStmt:
    """`select { BRANCH ... }`: the branches in the order written (not checked yet)."""
    branches: tuple[Union[OnBranch, AfterBranch, MeanwhileBranch], ...]
    span: Span


@dataclass(frozen=True)
class UntilStmt:
    """`STATEMENT until EVENT`: `select { on EVENT { } meanwhile { STATEMENT } }`."""
    stmt: "Stmt"
    event: Event
    span: Span


@dataclass(frozen=True)
class WaitStmt:
    """`wait EVENT`."""
    event: Event
    span: Span


@dataclass(frozen=True)
class SendStmt:
    """`send BYTE` (an Event as written; the checker wants a byte)."""
    byte: Event
    span: Span


@dataclass(frozen=True)
class HostStmt:
    """`host`: obey the host until the program ends it."""
    span: Span


Stmt = Union[MoveStmt, HoldStmt, RepeatStmt, LoopStmt, PlayStmt, SelectStmt, WaitStmt, SendStmt, UntilStmt, HostStmt]


@dataclass(frozen=True)
class SequenceDecl:
    """`sequence NAME { STATEMENTS }`."""
    name: Name
    body: tuple[Stmt, ...]
    span: Span


@dataclass(frozen=True)
class MainDecl:
    """`main { STATEMENTS }`; `keyword` is the span of the word `main`."""
    body: tuple[Stmt, ...]
    keyword: Span
    span: Span


@dataclass(frozen=True)
class SettingDecl:
    """`home POSE`, `stagger DUR` or `host PROTOCOL`: `word` must be `home`, `stagger` or `host`
    (no keywords)."""
    word: Name
    value: Union[Name, Quantity]
    span: Span


Item = Union[SettingDecl, FrameDecl, TargetDecl, InputDecl, SerialDecl, ServoDecl, GroupDecl, PoseDecl, SequenceDecl, MainDecl]


@dataclass(frozen=True)
class Program:
    """A whole file: its declarations in source order."""
    items: tuple[Item, ...]
    span: Span
