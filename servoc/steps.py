"""The plan's data types: what the planner makes and every later stage reads.

A `Plan` keeps the program's control flow as steps (`MoveStep`, `HoldStep`,
`RepeatStep`, `LoopStep`, `PlayStep`, `SelectStep`, `SendStep`, `HostStep`) with their
frame counts at the plan's period, the channels (servos that move) in port
order, and every distinct move instance the program reaches (`MoveInstance`,
with where each servo can start: an N, or a `Reach` after an interruption).
`servoc.plan` makes it; `servoc.flow` answers questions about its control flow.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Iterator, Union

from . import model, walk
from .source import NO_SPAN, Span


@dataclass(frozen=True)
class Channel:
    """A servo that gets pulses, as the firmware sees it."""
    servo: model.Servo
    index: int            # position in Plan.channels
    speed_class: int      # index into Plan.speed_tables

    @property
    def port(self) -> int:
        return self.servo.port

    @property
    def bit(self) -> int:
        return self.servo.bit

    @property
    def name(self) -> str:
        return self.servo.name


@dataclass(frozen=True)
class MoveStep:
    pose: str
    targets: tuple[tuple[int, int], ...]    # (channel index, N1), channel order
    frames: int | None                      # F; None = as fast as the slowest servo allows
    ease: str
    ease_table: tuple[int, ...]             # eased: round(256 e(k/F)) for k = 1..F-1, else ()
    duration_us: Fraction | None
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class HoldStep:
    frames: int
    duration_us: Fraction
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class RepeatStep:
    count: int
    body: tuple["Step", ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class LoopStep:
    body: tuple["Step", ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class PlayStep:
    sequence: str
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class OnBranch:
    """`on EVENT { ... }` of a select."""
    event: model.Event
    body: tuple["Step", ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class AfterBranch:
    """`after DUR { ... }`: taken when no event was taken for `frames` = floor(DUR / P + 1/2) frames."""
    frames: int
    duration_us: Fraction
    body: tuple["Step", ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class SelectStep:
    """`select { ... }` (or `wait EVENT`, `wait` True): its branches in the order written, an
    `AfterBranch` only last. While it waits, the current targets repeat frame after frame, or its
    `meanwhile` body runs (`until` True: it was written `STATEMENT until EVENT`)."""
    branches: tuple[Union[OnBranch, AfterBranch], ...]
    wait: bool = False
    span: Span = field(default=NO_SPAN, compare=False)
    meanwhile: tuple["Step", ...] | None = None
    until: bool = False

    @property
    def after(self) -> AfterBranch | None:
        return next((b for b in self.branches if isinstance(b, AfterBranch)), None)


@dataclass(frozen=True)
class SendStep:
    """`send BYTE`: takes no frame."""
    byte: int
    text: str                               # as written: `"w"` or `119`
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class HostStep:
    """`host`: the servos obey the host's commands (the SSC-32 protocol, docs/host-protocol.md),
    frame after frame, until an event of a select around it cuts it; it never ends by itself.
    `plays`: a `play` of each sequence of the program in declaration order (`PL 0 SQ n` plays
    sequence n from here: its block, for the folds of `servoc.walk`)."""
    plays: tuple["PlayStep", ...] = ()
    span: Span = field(default=NO_SPAN, compare=False)


def host_range(servo: model.Servo) -> tuple[int, int]:
    """The output N a host command can give the servo: its `limit` (0..250 without one), then
    `reverse` and `trim`, clamped to 0..250 (docs/host-protocol.md)."""
    lo, hi = servo.limit if servo.limit is not None else (0, 250)
    ends = [250 - n if servo.reverse else n for n in (lo, hi)]
    lo, hi = (min(250, max(0, n + servo.trim)) for n in sorted(ends))
    return lo, hi


def host_playable(program: model.Program) -> tuple[str, ...]:
    """The sequences `PL 0 SQ n` plays, in declaration order: those that run no `host` statement
    (in them or in what they play); a `PL` of another does nothing (it would play itself). A select
    in a sequence `PL` plays waits for inputs and time only: the bytes received are the host's."""
    hit = _playable.get(id(program))
    if hit is not None and hit[0] is program:       # (each plan at each P asks again)
        return hit[1]
    bodies = {q.name: q.body for q in program.sequences}

    def playable(name: str) -> bool:
        names = {name} | walk.reachable(bodies[name], bodies.__getitem__)
        return not any(isinstance(st, (model.Host,)) for st in walk.statements([bodies[n] for n in names]))
    out = tuple(q.name for q in program.sequences if playable(q.name))
    if len(_playable) >= 64:
        _playable.clear()
    _playable[id(program)] = (program, out)     # (the program held: its id names no other meanwhile)
    return out


_playable: dict[int, tuple[model.Program, tuple[str, ...]]] = {}


Step = Union[MoveStep, HoldStep, RepeatStep, LoopStep, PlayStep, SelectStep, SendStep, HostStep]
Branch = Union[OnBranch, AfterBranch]


def branch_head(branch: Branch) -> Span:
    """The span of a branch's head: `on "w"` or `after` (not its body)."""
    if isinstance(branch, OnBranch):
        return Span(branch.span.start, branch.event.span.end)
    return Span(branch.span.start, branch.span.start + len("after"))


def branch_text(branch: Branch) -> str:
    """A branch as written at its head: `on "w"`, `on button`, `after 2s`."""
    if isinstance(branch, OnBranch):
        return f"on {branch.event.text}"
    from .units import fmt_ms
    return f"after {fmt_ms(branch.duration_us)}"


@dataclass(frozen=True)
class SequencePlan:
    name: str
    body: tuple[Step, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class Reach:
    """Where a servo can be after an interruption: any N in lo..hi (and, if `unset`, still without a
    target). `lo_at` / `hi_at`: the statement in whose frames it can be at lo / hi (for messages)."""
    lo: int
    hi: int
    unset: bool = False
    lo_at: Span = field(default=NO_SPAN, compare=False)
    hi_at: Span = field(default=NO_SPAN, compare=False)
    merged: bool = field(default=False, compare=False)  # the hull of states too many to keep apart
                                                        # (plan._Walker._widen), not an interruption


def join(a, b):
    """The positions of one servo in either of two states (an N, None: no target, or a Reach)."""
    if a is b:
        return a
    if type(a) is Reach and (a.lo < a.hi or a.unset):     # the most common case, a hull that
        if b is None:                                       # already holds b: a itself
            if a.unset:
                return a
        elif type(b) is int:
            if a.lo <= b <= a.hi:
                return a
        elif a.lo <= b.lo and b.hi <= a.hi and (a.unset or not b.unset) and (a.merged or not b.merged):
            return a
    elif a == b and type(a) is not Reach:
        return a
    if a is None or b is None:
        other = b if a is None else a
        if isinstance(other, Reach):
            return replace(other, unset=True)
        return Reach(other, other, True)
    ra = a if isinstance(a, Reach) else Reach(a, a)
    rb = b if isinstance(b, Reach) else Reach(b, b)
    lo = ra if ra.lo <= rb.lo else rb
    hi = ra if ra.hi >= rb.hi else rb
    out = Reach(lo.lo, hi.hi, ra.unset or rb.unset, lo.lo_at, hi.hi_at, ra.merged or rb.merged)
    return out.lo if out.lo == out.hi and not out.unset else out


def far(value, n1: int) -> int | None:
    """The position farthest from n1 a servo can be at (None: it has no target yet)."""
    if isinstance(value, Reach):
        return value.lo if n1 - value.lo >= value.hi - n1 else value.hi
    return value


def far_from(value, n1: int) -> Span:
    """The statement in whose frames a servo can be at its position farthest from n1 (NO_SPAN: none)."""
    if not isinstance(value, Reach):
        return NO_SPAN
    return value.lo_at if n1 - value.lo >= value.hi - n1 else value.hi_at


def at_statement(value, span: Span):
    """`value` with the extremes not credited yet credited to the statement at `span` (for messages)."""
    if value is None:
        return None
    if type(value) is Reach and value.lo_at != NO_SPAN and value.hi_at != NO_SPAN:
        return value                # credited already
    r = value if isinstance(value, Reach) else Reach(value, value)
    return replace(r, lo_at=r.lo_at if r.lo_at != NO_SPAN else span, hi_at=r.hi_at if r.hi_at != NO_SPAN else span)


@dataclass(frozen=True)
class ServoMotion:
    channel: int
    n0: int | None        # None: the servo had no target yet (set at once); after an interruption
    n1: int               # the position farthest from n1 it can start from
    cut: Span = field(default=NO_SPAN, compare=False)   # after an interruption: the statement whose frames
                                                        # hold n0 (NO_SPAN: not after one)
    merged: bool = field(default=False, compare=False)  # n0 is the farthest of a hull of states (Reach.merged)

    @property
    def delta(self) -> int:
        return 0 if self.n0 is None else self.n1 - self.n0


# Where a state comes from, for messages: ("start",) the start of `main`; ("move", POSE, span) the
# end of a move; ("play", SEQUENCE, span) the end of a sequence.
Origin = tuple


@dataclass(frozen=True)
class MoveInstance:
    """One move in one context the program can reach. `origin` and `branch` say (for messages) where
    the state it starts from was made and the innermost select branch it runs in (None: none);
    the first context found of those that give the same instance."""
    step: MoveStep
    frames: int
    motions: tuple[ServoMotion, ...]
    origin: Origin = field(default=("start",), compare=False)
    branch: Branch | None = field(default=None, compare=False)
    cut: bool = field(default=False, compare=False)     # it can start after an interruption
    start: tuple = field(default=(), compare=False)     # per channel where it starts: an N, None (no
                                                        # target yet) or a Reach (after an interruption)
    first: tuple = field(default=(), compare=False)     # per channel its N in the move's first frame (as
                                                        # `start`; an N wherever the start is known)


@dataclass(frozen=True)
class Plan:
    program: model.Program
    channels: tuple[Channel, ...]           # servos that are moved somewhere, by (port, bit)
    ports: tuple[int, ...]                  # ports with channels, ascending
    period_us: int                          # frame period P in machine cycles (1 us)
    period_is_default: bool
    min_period_us: int                      # shortest P from which on every P holds, for the code generated
    speed_tables: tuple[tuple[int, ...], ...]   # per speed class: frames needed for |delta| = 0..250
    class_t_dav_us: tuple[Fraction, ...]    # per speed class: t_DAV
    main: tuple[Step, ...]
    sequences: tuple[SequencePlan, ...]     # those main can play (directly or not), in declaration order
    moves: tuple[MoveInstance, ...]         # every distinct move instance the program reaches
    total_frames: int | None                # frames until main ends; None if it loops forever
    nesting: int = 0                        # deepest stack of repeats and plays around a statement
    cuts: tuple = ()                        # (select, per channel where an event can cut its meanwhile body)
    startup: tuple = ()                     # (channel, frame of its first pulse) of the power-up, in order
    power_up: tuple = ()                    # the steps that make the power-up (the first of `main`)
    firmware_limit: tuple | None = None     # (code, message, help, span, labels) of each resource limit the code generated
                                            # for this plan hits (layout.LayoutError), found without assembling
    sends_hold_us: int | None = None        # where that limit is send-overrun alone: the period from which on
                                            # the code generated for this plan holds its sends and its frame
    compact: bool = False                   # its firmware built for size (`api.build`: when the fast build
                                            # does not fit the code memory): loops where the fast one is unrolled
    first_step: bool = True                 # a move of known F sets each pin up and steps its first frame
                                            # in one call (setup_step); False: in two passes, where only the
                                            # fast build without it fits the code memory (api.choose_period)
    period_holds: bool = True               # the code generated holds P itself (below min_period_us it may not)
    holds: bool = True                      # `host` holds entries (layout.host_holds) and reads on through answer
                                            # lines (flow.reads_answers) where they buy something; False: built
                                            # without that code, when only that fits the chip (api.choose_period)
    rise_offsets: tuple[int, ...] = ()      # per port, cycles from the first port's rise to its own, as the code
                                            # generated has them (costs.fit_spans; empty: not generated yet)
    rise_steps: bool = False                # the code makes a rise less than SPLIT cycles after the last fall
                                            # before it a step of that fall's handler run (costs.RISE_STEP)
    rises_among_falls: bool = False         # the code makes each port's rise but the first come among the falls
                                            # of the port before it: the ports' pulses overlap (costs.stagger_span)
    ports_at_once: bool = False             # the code makes every port rise at once (3 cycles apart) and puts
                                            # out their falls as one timeline (codegen.can_merge)

    def rises_us(self) -> tuple[float, ...]:
        """Each port's rise, in µs from the first port's (to the ns), in port order."""
        cycle = self.program.target.cycle_us
        return tuple(round(float(r * cycle), 3) for r in self.rise_offsets)

    def channel_of(self, servo: str) -> Channel:
        return next(c for c in self.channels if c.servo.name == servo)

    def sequence(self, name: str) -> SequencePlan:
        return next(s for s in self.sequences if s.name == name)


def bodies(plan: Plan) -> Iterator[tuple[Step, ...]]:
    """Every statement list of the program: main, each sequence, and every nested body."""
    return walk.bodies([plan.main, *(seq.body for seq in plan.sequences)])


def steps(plan: Plan) -> Iterator[Step]:
    """Every statement of the program, nested ones included."""
    return walk.statements([plan.main, *(seq.body for seq in plan.sequences)])
