"""The checked program: names resolved, units gone.

Input: produced by `servoc.check` from the syntax tree. Invariants: every name
refers to something declared; every target is an output N in 0..250 (limit,
then reverse, then trim already applied); times are exact Fractions in
microseconds; servos are on P0.0-P2.7, one per pin; inputs are on other pins
(P0.0-P3.7, never RXD/TXD when `serial` is declared); every event names a
declared input or a byte 0..255, and a byte is only used with `serial`; a `Host` statement only
in a program that declares `host ssc32` (which needs `serial`), and then no two servos share a
host channel (`host_channel`). Spans never take part in equality, so a program printed and
parsed back compares equal.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Union

from .source import NO_SPAN, Span
from . import target as chips
from .units import DEFAULT_T_DAV_US

EASES = ("linear", "in", "out", "in-out")
HOSTS = ("ssc32",)                  # the host protocols `host PROTOCOL` knows
MAX_HOST_CHANNEL = 31               # `channel K`: K in 0..31


def _span() -> Span:
    return field(default=NO_SPAN, compare=False, repr=False)


@dataclass(frozen=True)
class Servo:
    name: str
    port: int                       # 0..2
    bit: int                        # 0..7
    t_dav_us: Fraction = DEFAULT_T_DAV_US
    trim: int = 0
    limit: tuple[int, int] | None = None   # inclusive N bounds of positions, before reverse and trim
    reverse: bool = False
    span: Span = _span()
    channel_option: int | None = None       # `channel K` (0..31), None when not given: see `host_channel`

    @property
    def channel(self) -> int:
        """0..23: port x 8 + bit (the firmware's order of the pins; not the host channel)."""
        return self.port * 8 + self.bit

    @property
    def pin(self) -> str:
        return f"P{self.port}.{self.bit}"


def host_channel(servo: Servo) -> int:
    """The servo's channel in the host protocol: its `channel K`, else its pin's (as in `servoc
    import`): P1.b is b, P2.b 8 + b, P0.b 16 + b."""
    if servo.channel_option is not None:
        return servo.channel_option
    return {1: 0, 2: 8, 0: 16}[servo.port] + servo.bit


@dataclass(frozen=True)
class Position:
    """A position as written: its value and unit ('deg', 'us' or 'n')."""
    value: Fraction
    unit: str
    n: int                          # the position's N, before limit/reverse/trim
    span: Span = _span()


@dataclass(frozen=True)
class Target:
    servo: str
    n: int                          # output N, 0..250
    position: Position
    span: Span = _span()


@dataclass(frozen=True)
class Group:
    name: str
    servos: tuple[str, ...]         # flattened, declaration order, no repeats
    span: Span = _span()


@dataclass(frozen=True)
class Pose:
    name: str
    targets: tuple[Target, ...]     # one per servo, in declaration order of the servos
    span: Span = _span()


@dataclass(frozen=True)
class Move:
    pose: str
    targets: tuple[Target, ...]
    duration_us: Fraction | None    # None: as fast as the slowest servo allows
    ease: str = "linear"
    span: Span = _span()


@dataclass(frozen=True)
class Hold:
    duration_us: Fraction
    span: Span = _span()


@dataclass(frozen=True)
class Repeat:
    count: int
    body: tuple["Stmt", ...]
    span: Span = _span()


@dataclass(frozen=True)
class Loop:
    body: tuple["Stmt", ...]
    span: Span = _span()


@dataclass(frozen=True)
class Play:
    sequence: str
    span: Span = _span()


@dataclass(frozen=True)
class Input:
    """`input NAME = Px.b [low|high]`: a pin the program reads, never drives."""
    name: str
    port: int                       # 0..3
    bit: int                        # 0..7
    active_high: bool = False       # `low` (the default): active when the pin reads 0
    span: Span = _span()

    @property
    def pin(self) -> str:
        return f"P{self.port}.{self.bit}"


@dataclass(frozen=True)
class Serial:
    """`serial BAUD`: the UART at `baud`, made by Timer1 in mode 2 with TH1 and SMOD."""
    baud: int
    th1: int
    smod: int
    actual: Fraction                # the rate TH1 and SMOD make at the target's clock
    span: Span = _span()


EDGES = ("press", "release")


@dataclass(frozen=True)
class Event:
    """What an `on` or a `wait` waits for: an input (its name), a received byte, or (`other`) any
    byte no other `on` of the select names. `edge` ('press' or 'release') makes an input's event
    its change to active / inactive between two samples while the select waits; None: its level."""
    input: str | None               # the input's name, or None for a byte
    byte: int | None                # 0..255, or None for an input or `other`
    text: str                       # as written: `button`, `"w"`, `119`, `press button`, `other`
    span: Span = _span()
    edge: str | None = None
    other: bool = False

    @property
    def is_byte(self) -> bool:
        """A received byte: a named one or `other`."""
        return self.input is None


@dataclass(frozen=True)
class On:
    """`on EVENT { ... }`."""
    event: Event
    body: tuple["Stmt", ...]
    span: Span = _span()


@dataclass(frozen=True)
class After:
    """`after DUR { ... }`: taken when no event was taken for floor(DUR / P + 1/2) frames."""
    duration_us: Fraction
    body: tuple["Stmt", ...]
    span: Span = _span()


@dataclass(frozen=True)
class Select:
    """`select { on ... after ... meanwhile ... }`: `branches` in the order written, an `After`
    only last; `meanwhile` the body that runs while it waits (None: the targets repeat).
    `wait EVENT` is a Select with one `On` of an empty body and `wait` True; `STATEMENT until
    EVENT` one with one `On` of an empty body and the statement as its meanwhile, `until` True."""
    branches: tuple[Union[On, After], ...]
    wait: bool = False
    span: Span = _span()
    meanwhile: tuple["Stmt", ...] | None = None
    until: bool = False

    @property
    def ons(self) -> tuple[On, ...]:
        return tuple(b for b in self.branches if isinstance(b, On))

    @property
    def after(self) -> "After | None":
        return next((b for b in self.branches if isinstance(b, After)), None)


@dataclass(frozen=True)
class Send:
    """`send BYTE`."""
    byte: int
    text: str                       # as written
    span: Span = _span()


@dataclass(frozen=True)
class Host:
    """`host`: obey the host (the protocol of `Program.host`) until the program ends it, as the
    statement of an `until` or in a select's meanwhile; alone, it never ends."""
    span: Span = _span()


Stmt = Union[Move, Hold, Repeat, Loop, Play, Select, Send, Host]


@dataclass(frozen=True)
class Sequence:
    name: str
    body: tuple[Stmt, ...]
    span: Span = _span()


@dataclass(frozen=True)
class Program:
    path: str = field(compare=False)
    servos: tuple[Servo, ...]
    groups: tuple[Group, ...]
    poses: tuple[Pose, ...]
    sequences: tuple[Sequence, ...]
    main: tuple[Stmt, ...]
    frame_us: Fraction | None = None          # `frame DUR`, if given
    target: chips.Target = chips.DEFAULT       # chip, crystal and mode
    references: frozenset[str] = frozenset()  # names used after their declaration
    main_span: Span = _span()
    frame_span: Span = _span()
    inputs: tuple[Input, ...] = ()            # `input` declarations, in source order
    serial: Serial | None = None              # `serial BAUD`, if given
    home: Pose | None = None                  # `home POSE`, if given
    stagger_us: Fraction | None = None        # `stagger DUR`, if given
    home_span: Span = _span()
    host: str | None = None                   # `host ssc32`: "ssc32"; None without it
    host_span: Span = _span()

    @property
    def reacts(self) -> bool:
        """Whether the program reads inputs or the serial line (declares `input` or `serial`)."""
        return bool(self.inputs) or self.serial is not None

    def servo(self, name: str) -> Servo:
        return next(s for s in self.servos if s.name == name)

    def sequence(self, name: str) -> Sequence:
        return next(s for s in self.sequences if s.name == name)
