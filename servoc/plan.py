"""The speed planner: model.Program -> Plan.

The Plan is what the firmware is generated from and what `verify` checks
against. It keeps the program's control flow (repeat, loop and play are not
unrolled): each move becomes a `MoveStep` whose frame count F is fixed when
the move has a duration, and left to the run-time rule (as fast as the slowest
servo allows) when it has none. The planner also walks every context a
statement can run in (first and later passes of repeats and loops, every
place a sequence is played) and records each distinct move instance with its
start and end N, which is what the speed lint reads.

A `select` becomes a `SelectStep` whose branches keep their bodies (an
`after` gets its frame count, floor(DUR / P + 1/2)); `send` a `SendStep`.
With selects, the program can be in several states at one point: the planner
walks every body once per distinct state it can be entered in, from the state
a select is reached in into each of its branches, and closes loops and
repeats over the states they can come round in (a fixpoint: the states are
tuples of N from the poses, so there are finitely many). Each move instance
keeps where its state came from (`MoveInstance.origin`) and the innermost
branch it runs in (`MoveInstance.branch`), for the speed lint's messages.

`expand(plan, choices)` is the golden model: the exact N of every channel in
every frame, following the spec's formulas. Invariants: all N in 0..250; frame
F of a move equals the pose; after `main` ends the last frame repeats forever.
At a select it follows `choices` (see `expand`); without one it waits forever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Iterable, Iterator, Union

from . import costs, model, walk
from .diagnostics import Reporter
from .source import NO_SPAN, Span
from .units import DEFAULT_PERIOD_FLOOR_US, N_MAX, frames_for, frames_needed, move_frames, round_half_up

EASE_SCALE = 256     # eased curves are stored as e(k/F) x 256, rounded, clamped to 255
MAX_TABLE_FRAMES = 65535   # the firmware's frame counters are 16 bits; longer moves are a
                           # lint error (too-long), so their curve tables are not built


# ----------------------------------------------------------------- plan types

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


Step = Union[MoveStep, HoldStep, RepeatStep, LoopStep, PlayStep, SelectStep, SendStep]
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


def join(a, b):
    """The positions of one servo in either of two states (an N, None: no target, or a Reach)."""
    if a == b and not isinstance(a, Reach):
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
    out = Reach(lo.lo, hi.hi, ra.unset or rb.unset, lo.lo_at, hi.hi_at)
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
    r = value if isinstance(value, Reach) else Reach(value, value)
    return replace(r, lo_at=r.lo_at if r.lo_at != NO_SPAN else span, hi_at=r.hi_at if r.hi_at != NO_SPAN else span)


@dataclass(frozen=True)
class ServoMotion:
    channel: int
    n0: int | None        # None: the servo had no target yet (set at once); after an interruption
    n1: int               # the position farthest from n1 it can start from
    cut: Span = field(default=NO_SPAN, compare=False)   # after an interruption: the statement whose frames
                                                        # hold n0 (NO_SPAN: not after one)

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


@dataclass(frozen=True)
class Plan:
    program: model.Program
    channels: tuple[Channel, ...]           # servos that are moved somewhere, by (port, bit)
    ports: tuple[int, ...]                  # ports with channels, ascending
    period_us: int                          # frame period P in machine cycles (1 us)
    period_is_default: bool
    min_period_us: int                      # shortest P the firmware generated for this plan holds
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
    firmware_limit: tuple | None = None     # (code, message, help) of the resource limit the code generated
                                            # for this plan hits (layout.LayoutError), found without assembling

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


# ----------------------------------------------------------------- easing

def ease_value(ease: str, u: Fraction) -> Union[Fraction, float]:
    """e(u) of the spec; exact where the value is rational."""
    if ease == "linear":
        return u
    if ease == "in":
        return u * u
    if ease == "out":
        return 1 - (1 - u) * (1 - u)
    # in-out: (1 - cos(pi u)) / 2; exact at multiples of 1/3 and 1/2, where cos is rational
    exact = {Fraction(0): Fraction(1), Fraction(1, 3): Fraction(1, 2), Fraction(1, 2): Fraction(0),
             Fraction(2, 3): Fraction(-1, 2), Fraction(1): Fraction(-1)}
    if u in exact:
        return (1 - exact[u]) / 2
    return (1 - math.cos(math.pi * u)) / 2


def frame_value(n0: int, n1: int, k: int, frames: int, ease: str) -> int:
    """The spec's commanded N at frame k (1..F) of a move from n0 to n1."""
    delta = n1 - n0
    if k >= frames:
        return n1
    if ease == "linear":
        sign = (delta > 0) - (delta < 0)
        return n0 + sign * ((2 * abs(delta) * k + frames) // (2 * frames))    # floor(|delta| k / F + 1/2)
    e = ease_value(ease, Fraction(k, frames))
    return math.floor(n0 + delta * e + Fraction(1, 2)) if isinstance(e, Fraction) else math.floor(n0 + delta * e + 0.5)


def ease_table(ease: str, frames: int) -> tuple[int, ...]:
    if ease == "linear":
        return ()
    return tuple(min(EASE_SCALE - 1, math.floor(ease_value(ease, Fraction(k, frames)) * EASE_SCALE + Fraction(1, 2)))
                 for k in range(1, frames))


# ----------------------------------------------------------------- planning

State = tuple  # per channel: N or None


def _moved_servos(program: model.Program) -> set[str]:
    """The servos that get pulses: those a move names, and those of the `home` pose."""
    home = {t.servo for t in program.home.targets} if program.home is not None else set()
    return home | {t.servo for st in walk.statements([program.main, *(seq.body for seq in program.sequences)])
                   if isinstance(st, model.Move) for t in st.targets}


def startup_steps(program: model.Program, channels, period: int) -> tuple[tuple[Step, ...], tuple]:
    """The power-up as steps run before `main`, and its schedule ((channel, frame of its first pulse)).

    With `home`, its servos get their first pulse in frame 1 (each set at once: a servo without a
    target jumps to its first one), or with `stagger` one after another in declaration order,
    S = floor(DUR / P + 1/2) frames apart: one-frame moves naming one servo each, with holds of
    S - 1 frames between them. The program's first frame follows the last servo's first pulse.
    Without `home`, `stagger` switches on the servos of the program's first move (its first
    statement, in a repeat, loop or sequence it starts with) the same way, at that move's targets,
    which it then holds for its frames; with neither, there is no power-up."""
    home, span = program.home, program.home_span
    if home is None and program.stagger_us is not None:
        home = _first_move(program.main, program)
        span = home.span if home is not None else span
    if home is None:
        return (), ()
    n_of = {t.servo: t.n for t in home.targets}
    name = home.pose if isinstance(home, model.Move) else home.name
    order = [c for c in sorted(channels, key=lambda c: [s.name for s in program.servos].index(c.servo.name))
             if c.servo.name in n_of]
    gap = frames_for(program.stagger_us, period) if program.stagger_us is not None else 0
    if gap == 0 or len(order) < 2:
        targets = tuple(sorted((c.index, n_of[c.servo.name]) for c in order))
        return (MoveStep(name, targets, 1, "linear", (), None, span),), tuple((c.index, 1) for c in order)
    out: list[Step] = []
    schedule = []
    for i, c in enumerate(order):
        if i:
            out.append(HoldStep(gap - 1, Fraction(program.stagger_us), span)) if gap > 1 else None
        out.append(MoveStep(name, ((c.index, n_of[c.servo.name]),), 1, "linear", (), None, span))
        schedule.append((c.index, 1 + i * gap))
    return tuple(out), tuple(schedule)


def _first_move(body: tuple, program: model.Program) -> model.Move | None:
    """The move the program runs first, if it starts with one (a repeat, loop or sequence it starts
    with looked into); None if it starts with anything else."""
    while body:
        st = body[0]
        if isinstance(st, model.Move):
            return st
        if isinstance(st, (model.Repeat, model.Loop)):
            body = st.body
        elif isinstance(st, model.Play):
            body = program.sequence(st.sequence).body
        else:
            return None
    return None


def home_state(program: model.Program, channels) -> State:
    """The state the program starts in: the `home` pose's N, None for the servos it does not name."""
    home = {t.servo: t.n for t in program.home.targets} if program.home is not None else {}
    return tuple(home.get(c.servo.name) for c in channels)


def plan(program: model.Program, reporter: Reporter | None = None) -> Plan:
    """Plan a checked program. Checks on the result are the linter's job.

    The shortest period the firmware holds comes from the code generated for
    the plan (`budget`); the default P is found by planning again at it until
    it no longer changes (F, and with it the code, depends on P)."""
    moved = _moved_servos(program)
    servos = sorted((s for s in program.servos if s.name in moved), key=lambda s: s.channel)
    ports = tuple(sorted({s.port for s in servos}))
    depth = walk.nesting(program.main, {q.name: q.body for q in program.sequences}.__getitem__)
    if program.frame_us is not None:
        period = max(1, round_half_up(program.frame_us))
        return budget(_plan_at(program, servos, ports, period, False, depth))
    period, seen = DEFAULT_PERIOD_FLOOR_US, set()
    while True:
        result = budget(_plan_at(program, servos, ports, period, True, depth))
        want = costs.default_period_us(result.min_period_us)
        if want == period or (period in seen and want <= period):
            return result
        seen.add(period)
        period = max(want, period) if len(seen) > 4 else want


def budget(p: Plan) -> Plan:
    """The plan with `min_period_us` read from the firmware generated for it (see costs.py).
    When no firmware can be generated (a resource limit, reported later), P itself."""
    from . import codegen, layout    # codegen builds on the plan types
    try:
        unit = codegen.generate(p)
    except layout.LayoutError as exc:
        return replace(p, min_period_us=p.period_us, firmware_limit=(exc.code, str(exc), exc.help))
    return replace(p, min_period_us=unit.min_period_us or p.period_us)


def _any_frame(acc: bool, st: Step, inner) -> bool:
    kind = walk.kind(st)
    if kind == "select":
        return True
    return acc or kind == "move" or (kind == "hold" and st.frames > 0) or bool(inner)


def watches(plan: Plan) -> bool:
    """True when a select of the program has a meanwhile body (the firmware's frame_w looks)."""
    return any(isinstance(st, SelectStep) and st.meanwhile is not None for st in steps(plan))


def select_slots(plan: Plan) -> dict[int, int]:
    """id(select) -> its level: the most meanwhile bodies around it in any context it runs in. A
    select inside another's meanwhile body has a higher level than it, so selects that wait at the
    same time (an outer one running its body, inner ones in it) never share a level."""
    slots: dict[int, int] = {}
    seen: set = set()
    work: list = [(plan.main, 0)]
    while work:
        body, depth = work.pop()
        if (id(body), depth) in seen:
            continue
        seen.add((id(body), depth))
        for st in body:
            if isinstance(st, SelectStep):
                slots[id(st)] = max(slots.get(id(st), 0), depth)
                work.extend((b.body, depth) for b in st.branches)
                if st.meanwhile is not None:
                    work.append((st.meanwhile, depth + 1))
            elif isinstance(st, (RepeatStep, LoopStep)):
                work.append((st.body, depth))
            elif isinstance(st, PlayStep):
                work.append((plan.sequence(st.sequence).body, depth))
    return slots


def edge_ports(plan: Plan) -> tuple[int, ...]:
    """The ports of the inputs some `on press` / `on release` watches, ascending (a look samples each)."""
    inputs = {i.name: i for i in plan.program.inputs}
    return tuple(sorted({inputs[b.event.input].port for st in steps(plan) if isinstance(st, SelectStep)
                         for b in st.branches if not isinstance(b, AfterBranch) and b.event.edge}))


def select_ram(plan: Plan) -> int:
    """Bytes of RAM the selects take from the stack: a look's sample of each port in `edge_ports`,
    and per level of `select_slots` with a meanwhile body, the select running it and its stack pointer."""
    slots = select_slots(plan)
    levels = {slots[id(st)] for st in steps(plan) if isinstance(st, SelectStep) and st.meanwhile is not None}
    return len(edge_ports(plan)) + 2 * len(levels)


def takes_frames(body: tuple[Step, ...], plan: Plan, memo: dict | None = None) -> bool:
    """Whether `body` has anything that can take a frame (a move; a hold of at least half a
    frame; a select, which waits while no event is there; repeat, loop and play of those): a
    body without can only send. Pass one `memo` to calls on the same plan so each sequence is
    looked at once."""
    return walk.fold(body, lambda name: plan.sequence(name).body, False, _any_frame, memo)


def _fewest(acc: int, st: Step, inner) -> int:
    kind = walk.kind(st)
    if kind == "send":
        return acc
    if kind == "select":
        # an event already there is taken at once: an `on` branch may take no frame before it,
        # `after` comes after its F
        return acc + min((v + (b.frames if isinstance(b, AfterBranch) else 0)
                          for b, v in zip(st.branches, inner)), default=0)
    if kind == "move":
        return acc + (st.frames or 1)
    if kind == "hold":
        return acc + st.frames
    if kind == "repeat":
        return acc + st.count * inner
    if kind == "loop":
        return acc + max(1, inner)      # a pass that took no frame waits for one before the next
    return acc + inner


def fewest_frames(body: tuple[Step, ...], plan: Plan, memo: dict | None = None) -> int:
    """The fewest frames one pass of `body` can take (0: it can run through without one, e.g. a
    select whose event is already there, or only sends)."""
    return walk.fold(body, lambda name: plan.sequence(name).body, 0, _fewest, memo)


def _any_send(acc: bool, st: Step, inner) -> bool:
    return acc or walk.kind(st) == "send" or (any(inner) if isinstance(inner, tuple) else bool(inner))


def sends(body: tuple[Step, ...], plan: Plan, memo: dict | None = None) -> bool:
    """Whether `body` has a `send` anywhere in it, or in a sequence it plays."""
    return walk.fold(body, lambda name: plan.sequence(name).body, False, _any_send, memo)


def frameless_repeats(plan: Plan) -> Iterator[tuple[RepeatStep, int]]:
    """Each repeat that can take frames but whose pass can run through without one (a select
    whose event is already there), with the passes the firmware writes out for it: its count
    times that of the repeats of this kind around it in the same body (codegen writes such a
    repeat out pass by pass, so that the work between two frames stays bounded)."""
    frames_memo: dict = {}
    fewest_memo: dict = {}
    work = [(body, 1) for body in [plan.main] + [q.body for q in plan.sequences]]
    while work:
        body, times = work.pop()
        for st in body:
            inner = times
            if (isinstance(st, RepeatStep) and takes_frames(st.body, plan, frames_memo)
                    and fewest_frames(st.body, plan, fewest_memo) == 0):
                inner = times * st.count
                yield st, inner
            work.extend((b, inner if isinstance(st, RepeatStep) else times) for b in walk.blocks(st))


@dataclass(frozen=True)
class SendRun:
    """The bytes `send` gives with no frame between them, over the ways one pass of a body can
    go: `zero` the most bytes of a way that takes no frame (None: every way takes a frame); of
    the ways that take frames, the most bytes before the first frame (`lead`) and after the last
    (`tail`) (None: no way takes a frame); `most` the most anywhere."""
    zero: int | None = 0
    lead: int | None = None
    tail: int | None = None
    most: int = 0

    def then(self, nxt: "SendRun") -> "SendRun":
        zero = None if self.zero is None or nxt.zero is None else self.zero + nxt.zero
        leads = ([] if self.lead is None else [self.lead]) + (
            [] if self.zero is None or nxt.lead is None else [self.zero + nxt.lead])
        tails = ([] if nxt.tail is None else [nxt.tail]) + (
            [] if nxt.zero is None or self.tail is None else [self.tail + nxt.zero])
        join = [] if self.tail is None or nxt.lead is None else [self.tail + nxt.lead]
        lead, tail = max(leads, default=None), max(tails, default=None)
        return SendRun(zero, lead, tail, max([self.most, nxt.most, zero or 0] + leads + tails + join))

    def either(self, other: "SendRun") -> "SendRun":
        def top(a, b):
            return b if a is None else a if b is None else max(a, b)
        return SendRun(top(self.zero, other.zero), top(self.lead, other.lead), top(self.tail, other.tail),
                       max(self.most, other.most))

    def frames(self, n: int) -> "SendRun":
        return SendRun(None, 0, 0, 0) if n > 0 else SendRun(0)

    def cut(self) -> "SendRun":
        """A meanwhile body cut at a frame boundary (after none or some of its frames: nothing after
        the last frame it ran), or run to its end."""
        part = SendRun(0) if self.lead is None else SendRun(0).either(SendRun(None, self.lead, 0, self.most))
        return part.either(self)

    def pad(self) -> "SendRun":
        """A loop's pass: one that took no frame waits for a frame before the next."""
        if self.zero is None:
            return self
        return SendRun(None, max(self.zero, self.lead or 0), self.tail or 0, self.most)

    def again(self, count: int | None) -> "SendRun":
        """`count` passes one after another (None: forever)."""
        if count == 0:
            return SendRun(0)
        if count is None:
            if self.zero:
                return SendRun(UNBOUNDED, UNBOUNDED, UNBOUNDED, UNBOUNDED)
            join = [] if self.tail is None or self.lead is None else [self.tail + self.lead]
            return SendRun(None, self.lead, self.tail, max([self.most] + join))
        z = self.zero
        if z is None:
            twice = [] if count < 2 or self.tail is None or self.lead is None else [self.tail + self.lead]
            return SendRun(None, self.lead, self.tail, max([self.most] + twice))
        lead = None if self.lead is None else z * (count - 1) + self.lead
        tail = None if self.tail is None else self.tail + z * (count - 1)
        span = ([] if count < 2 or self.tail is None or self.lead is None
                else [self.tail + z * (count - 2) + self.lead])
        return SendRun(z * count, lead, tail,
                       max([self.most, z * count] + [v for v in (lead, tail) if v is not None] + span))


UNBOUNDED = 1 << 30     # sends repeated forever with no frame between them


def _fold_sends(plan: Plan, blank, send):
    """The program folded into a summary of its sends: `blank` stands for nothing, `send` for one
    byte, `blank.frames(n)` for n frames; summaries combine with `then` (one after the other),
    `either` (one or the other), `again` (repeated; None: forever) and `pad` (a loop's pass, which
    waits for a frame when it took none). A select may take no frame before an `on` branch (its
    event already there) and takes its F before `after`; one with a meanwhile body runs a part of
    it (`cut`) before either."""
    def step(acc, st: Step, inner):
        kind = walk.kind(st)
        if kind == "send":
            one = send
        elif kind == "move":
            one = blank.frames(st.frames or 1)
        elif kind == "hold":
            one = blank.frames(st.frames)
        elif kind == "select":
            one = None
            body = inner[len(st.branches)].cut() if st.meanwhile is not None else None
            for br, v in zip(st.branches, inner):
                way = (body or blank.frames(br.frames if isinstance(br, AfterBranch) else 0)).then(v)
                one = way if one is None else one.either(way)
            one = one or blank
        elif kind == "repeat":
            one = inner.again(st.count)
        elif kind == "loop":
            one = inner.pad().again(None)
        else:
            one = inner
        return acc.then(one)
    return walk.fold(plan.main, lambda name: plan.sequence(name).body, blank, step, {})


def send_run(plan: Plan) -> int:
    """The most bytes the program can `send` with no frame between them."""
    return _fold_sends(plan, SendRun(0), SendRun(1, None, None, 1)).most


@dataclass(frozen=True)
class _Gaps:
    """Frames around the sends of one pass of a body, each count clipped at `cap`: the frames of
    passes that send nothing (`quiet`), before the first send and after the last of those that do
    (`head`, `tail`), the fewest frames (at least one) between two sends inside (`gap`), and
    whether a pass can send and take no frame at all (`zsend`)."""
    cap: int
    quiet: frozenset = frozenset({0})
    head: frozenset = frozenset()
    tail: frozenset = frozenset()
    gap: int | None = None
    zsend: bool = False

    def clip(self, values) -> frozenset:
        return frozenset(min(v, self.cap) for v in values)

    def then(self, nxt: "_Gaps") -> "_Gaps":
        joins = [a + b for a in self.tail for b in nxt.head if a + b > 0]
        gaps = [g for g in (self.gap, nxt.gap, min(joins, default=None)) if g is not None]
        zsend = (self.zsend and (nxt.zsend or 0 in nxt.quiet)) or (0 in self.quiet and nxt.zsend)
        return _Gaps(self.cap, self.clip(a + b for a in self.quiet for b in nxt.quiet),
                     self.head | self.clip(a + b for a in self.quiet for b in nxt.head),
                     nxt.tail | self.clip(a + b for a in self.tail for b in nxt.quiet),
                     min(gaps, default=None), zsend)

    def either(self, other: "_Gaps") -> "_Gaps":
        gaps = [g for g in (self.gap, other.gap) if g is not None]
        return _Gaps(self.cap, self.quiet | other.quiet, self.head | other.head, self.tail | other.tail,
                     min(gaps, default=None), self.zsend or other.zsend)

    def frames(self, n: int) -> "_Gaps":
        return _Gaps(self.cap, frozenset({min(n, self.cap)}))

    def cut(self) -> "_Gaps":
        """A meanwhile body cut at a frame boundary (after none or some of its frames: at least one
        frame after its last send), or run to its end."""
        return self.either(_Gaps(self.cap, frozenset({0, 1}), self.head, frozenset({1}) if self.head else frozenset(),
                                 self.gap))

    def pad(self) -> "_Gaps":
        """A loop's pass: one that took no frame waits for a frame before the next."""
        return _Gaps(self.cap, self.clip(max(q, 1) for q in self.quiet), self.head,
                     self.tail | (frozenset({1}) if self.zsend else frozenset()), self.gap)

    def again(self, count: int | None) -> "_Gaps":
        out = _Gaps(self.cap)
        for _ in range(self.cap + 2 if count is None else min(count, self.cap + 2)):
            out = out.then(self)
        return _Gaps(self.cap, frozenset(), out.head, frozenset(), out.gap) if count is None else out


def send_gap(plan: Plan, cap: int) -> int:
    """The fewest frames between two sends that are not in one run (`cap` if never fewer)."""
    found = _fold_sends(plan, _Gaps(cap), _Gaps(cap, frozenset(), frozenset({0}), frozenset({0}), zsend=True)).gap
    return cap if found is None else min(found, cap)


def _model_steps(body: tuple, index: dict[str, int], period: int) -> tuple[Step, ...]:
    """model statements -> plan steps at period P (`index`: channel of each servo by name)."""
    out: list[Step] = []
    for st in body:
        if isinstance(st, model.Move):
            targets = tuple(sorted((index[t.servo], t.n) for t in st.targets))
            frames = None if st.duration_us is None else move_frames(st.duration_us, period)
            table = ease_table(st.ease, frames) if frames is not None and frames <= MAX_TABLE_FRAMES else ()
            out.append(MoveStep(st.pose, targets, frames, st.ease, table, st.duration_us, st.span))
        elif isinstance(st, model.Hold):
            out.append(HoldStep(frames_for(st.duration_us, period), st.duration_us, st.span))
        elif isinstance(st, model.Repeat):
            out.append(RepeatStep(st.count, _model_steps(st.body, index, period), st.span))
        elif isinstance(st, model.Loop):
            out.append(LoopStep(_model_steps(st.body, index, period), st.span))
        elif isinstance(st, model.Select):
            branches = tuple(
                OnBranch(b.event, _model_steps(b.body, index, period), b.span) if isinstance(b, model.On)
                else AfterBranch(frames_for(b.duration_us, period), b.duration_us,
                                 _model_steps(b.body, index, period), b.span)
                for b in st.branches)
            meanwhile = None if st.meanwhile is None else _model_steps(st.meanwhile, index, period)
            out.append(SelectStep(branches, st.wait, st.span, meanwhile, st.until))
        elif isinstance(st, model.Send):
            out.append(SendStep(st.byte, st.text, st.span))
        else:
            out.append(PlayStep(st.sequence, st.span))
    return tuple(out)


def _plan_at(program: model.Program, servos: list, ports: tuple[int, ...], period: int,
             is_default: bool, depth: int) -> Plan:
    """The plan at one frame period P: every F, speed table and move instance uses this P."""
    classes: list[Fraction] = []
    channels = []
    for i, s in enumerate(servos):
        if s.t_dav_us not in classes:
            classes.append(s.t_dav_us)
        channels.append(Channel(s, i, classes.index(s.t_dav_us)))
    tables = tuple(tuple(frames_needed(d, t, period) for d in range(N_MAX + 1)) for t in classes)
    index = {c.servo.name: c.index for c in channels}

    speed_classes = tuple(c.speed_class for c in channels)
    startup, schedule = startup_steps(program, channels, period)
    main = startup + _model_steps(program.main, index, period)
    seq_bodies = {s.name: SequencePlan(s.name, _model_steps(s.body, index, period), s.span)
                  for s in program.sequences}
    walker = _Walker(seq_bodies, tables, speed_classes)
    walker.start(main, len(channels), home_state(program, channels))
    # A move without duration whose F is the same in every context gets that F fixed;
    # only the others are left to the firmware's run-time rule.
    fixed: dict[int, int] = {}
    by_step: dict[int, set[int]] = {}
    for inst in walker.instances.values():       # after an interruption: the firmware finds F from where it is
        cut = any(m.cut != NO_SPAN or isinstance(m.n0, Reach) for m in inst.motions) or inst.cut
        by_step.setdefault(id(inst.step), set()).add(None if cut else inst.frames)
    for inst in walker.instances.values():
        if inst.step.frames is None and len(by_step[id(inst.step)]) == 1 and None not in by_step[id(inst.step)]:
            fixed[id(inst.step)] = inst.frames
    if fixed:
        main = _fix_frames(main, fixed)
        seq_bodies = {n: SequencePlan(sp.name, _fix_frames(sp.body, fixed), sp.span) for n, sp in seq_bodies.items()}
        walker = _Walker(seq_bodies, tables, speed_classes)
    exits, total = walker.start(main, len(channels), home_state(program, channels))
    infinite = not exits
    # Every sequence main can name, also after a `loop` (code there never runs, but later
    # stages still walk it and look its sequences up).
    named = _named_sequences(main, seq_bodies)
    used = [seq_bodies[s.name] for s in program.sequences if s.name in named]
    return Plan(program, tuple(channels), ports, period, is_default, period, tables, tuple(classes),
                main, tuple(used), tuple(walker.instances.values()), None if infinite else total, depth,
                cuts=tuple(walker.cuts.values()), startup=schedule, power_up=startup)


def has_selects(plan: Plan) -> bool:
    """Whether the program waits for events anywhere (a `select` or a `wait`): then how many
    frames it runs depends on them, and `total_frames` is None."""
    return any(isinstance(st, SelectStep) for st in steps(plan))


def _named_sequences(main: tuple[Step, ...], sequences: dict[str, SequencePlan]) -> set[str]:
    return walk.reachable(main, lambda name: sequences[name].body)


def _fix_frames(body: tuple[Step, ...], fixed: dict[int, int]) -> tuple[Step, ...]:
    def fix(st: Step) -> Step:
        if isinstance(st, MoveStep) and id(st) in fixed:
            return MoveStep(st.pose, st.targets, fixed[id(st)], st.ease, st.ease_table, st.duration_us, st.span)
        return st
    return walk.rebuild(body, fix)


def move_frames_at(step: MoveStep, state: State, tables, classes) -> int:
    """F of a move entered in `state` (the run-time rule when it has no duration)."""
    if step.frames is not None:
        return step.frames
    need = 0
    for ch, n1 in step.targets:
        n0 = far(state[ch], n1)
        if n0 is not None:
            need = max(need, tables[classes[ch]][abs(n1 - n0)])
    return max(1, need)


VERIFY_TAIL_FRAMES = 20          # frames checked after main ends (the last targets repeating)
VERIFY_MAX_FRAMES = 20_000       # the default never asks for more


def verify_frames(plan: Plan) -> int:
    """How many frames `servoc verify` checks by default: the whole program and a tail; for a
    program that loops forever, everything up to its first `loop` and two passes of it."""
    if plan.total_frames is not None:
        return min(VERIFY_MAX_FRAMES, plan.total_frames + VERIFY_TAIL_FRAMES)
    walker = _Walker({s.name: s for s in plan.sequences}, plan.speed_tables,
                     tuple(c.speed_class for c in plan.channels))
    state: State = home_state(plan.program, plan.channels)
    frames = 0
    for st in plan.main:
        if isinstance(st, LoopStep):
            exits, first, _ = walker.walk(st.body, state)
            if len(exits) == 1 and first is not None:
                _, later, _ = walker.walk(st.body, next(iter(exits)))
                frames += first + (later or 0)
            break
        exits, more, _ = walker.walk((st,), state)
        if len(exits) != 1 or more is None:     # a loop inside a repeat or a sequence, or a select:
            frames += more or 0                 # what precedes it, and a margin
            break
        frames += more
        state = next(iter(exits))
    return min(VERIFY_MAX_FRAMES, max(400, frames + VERIFY_TAIL_FRAMES))


# The states a body can end in, each with where it was made (None: it is the state the body was
# entered in, made where that was), in the order found.
Exits = dict


class _Walker:
    """Runs the steps over states, not frames: each body is walked once per distinct entry state.

    `walk(body, state)` gives the states the body can end in (none: it never ends), the frames it
    takes (None when that depends on events, i.e. it meets a select) and its hull: per servo every
    position it can hold at any frame boundary inside the body (`join` of all the states it passes
    through; a move's frames lie between its start and its pose). A select walks each branch
    from the state it is reached in; one with a `meanwhile` also from where the body can be cut:
    the body's hull, each servo's positions as a `Reach` (its farthest decides a move's speed,
    so this stays one state per select and entry state, not one per frame). A repeat walks its
    body pass after pass over the set of states a pass can start in, until that set comes round
    again; a loop walks its body from every state a pass can start in until no new one appears.
    Every move instance is recorded once per entry state."""

    def __init__(self, sequences: dict[str, SequencePlan], tables, classes):
        self.sequences = sequences
        self.tables = tables
        self.classes = classes
        self.instances: dict[tuple, MoveInstance] = {}
        self.played: set[str] = set()
        self.memo: dict[tuple, tuple[Exits, int | None, State]] = {}
        self.cuts: dict[int, State] = {}      # id(select) -> the join of its cut states (for `servoc plan`)

    def start(self, main: tuple[Step, ...], channels: int, home: State | None = None) -> tuple[Exits, int | None]:
        exits, frames, _ = self.walk(main, home or (None,) * channels, ("start",), None)
        return exits, frames

    def walk(self, body: tuple[Step, ...], state: State, origin: Origin = ("start",),
             branch: Branch | None = None) -> tuple[Exits, int | None, State]:
        """(exits, frames, hull) of `body` entered in `state`; `origin` and `branch` are where `state`
        was made and the innermost select branch around `body`, for the move instances found first here."""
        key = (id(body), state)
        if key in self.memo:
            return self.memo[key]
        cur: Exits = {state: None}
        total: int | None = 0
        hull: State = state

        def made(where: Origin | None) -> Origin:
            return origin if where is None else where

        def more(h: State) -> None:
            nonlocal hull
            hull = tuple(join(a, b) for a, b in zip(hull, h))

        for st in body:
            new: Exits = {}
            if isinstance(st, MoveStep):
                for s, where in cur.items():
                    f = move_frames_at(st, s, self.tables, self.classes)
                    motions = tuple(ServoMotion(ch, far(s[ch], n1), n1, far_from(s[ch], n1)) for ch, n1 in st.targets)
                    cut = any(isinstance(s[ch], Reach) for ch, _ in st.targets)
                    self.instances.setdefault((id(st), s), MoveInstance(st, f, motions, made(where), branch, cut))
                    after = list(s)
                    for ch, n1 in st.targets:
                        after[ch] = n1
                    new.setdefault(tuple(after), ("move", st.pose, st.span))
                    ends = list(after)
                    for ch, n1 in st.targets:       # each position credited to the move that goes there
                        ends[ch] = Reach(n1, n1, False, st.span, st.span)
                    more(tuple(ends))
                    if total is not None:
                        total += f
            elif isinstance(st, HoldStep):
                new = cur
                if total is not None:
                    total += st.frames
            elif isinstance(st, SendStep):
                new = cur
            elif isinstance(st, RepeatStep):
                for s, where in cur.items():
                    exits, frames, h = self._repeat(st, s, made(where), branch)
                    more(h)
                    for s2, w2 in exits.items():
                        new.setdefault(s2, where if w2 is None else w2)
                    total = None if total is None or frames is None else total + frames
            elif isinstance(st, LoopStep):
                for s, where in cur.items():
                    more(self._loop(st, s, made(where), branch))
            elif isinstance(st, SelectStep):
                for s, where in cur.items():
                    starts = {s: where}
                    if st.meanwhile is not None:
                        cut = self._meanwhile(st, s, made(where), branch)
                        more(cut)
                        starts[cut] = ("cut", st.span, st.branches[0].event.text if st.until else None)
                    for b in st.branches:
                        for s1, w1 in starts.items():
                            exits, _, h = self.walk(b.body, s1, made(w1), b)
                            more(h)
                            for s2, w2 in exits.items():
                                new.setdefault(s2, w1 if w2 is None else w2)
                total = None
            else:
                self.played.add(st.sequence)
                for s, where in cur.items():
                    exits, frames, h = self.walk(self.sequences[st.sequence].body, s, made(where), branch)
                    more(h)
                    for s2 in exits:
                        new.setdefault(s2, ("play", st.sequence, st.span))
                    total = None if total is None or frames is None else total + frames
            cur = new
            for s in cur:
                more(s)
            if not cur:
                break
        self.memo[key] = (cur, total, hull)
        return self.memo[key]

    def _meanwhile(self, st: SelectStep, state: State, origin: Origin, branch: Branch | None) -> State:
        """Where the servos can be when an event cuts `st`'s meanwhile body (entered in `state`): at
        any frame boundary of the body, where it ends (the select then waits on), or where the select
        was reached (an event already there). Each position is credited to the body's statement
        whose frames hold it."""
        hull = tuple(at_statement(v, st.span) if v is not None else None for v in state)
        cur: Exits = {state: None}
        for part in st.meanwhile:
            new: Exits = {}
            for s, where in cur.items():
                exits, _, h = self.walk((part,), s, origin if where is None else where, branch)
                hull = tuple(join(a, at_statement(b, part.span)) for a, b in zip(hull, h))
                for s2, w2 in exits.items():
                    new.setdefault(s2, where if w2 is None else w2)
            cur = new
            if not cur:
                break
        before = self.cuts.get(id(st))
        self.cuts[id(st)] = (st, hull if before is None else tuple(join(a, b) for a, b in zip(before[1], hull)))
        return hull

    def _repeat(self, st: RepeatStep, state: State, origin: Origin,
                branch: Branch | None) -> tuple[Exits, int | None, State]:
        """The states `st` ends in: layer k holds the states after k passes; the layers repeat with
        some period, from which layer `count` follows."""
        layers: list[Exits] = [{state: None}]
        seen = {frozenset(layers[0]): 0}
        totals: list[int | None] = []
        hull: State = state
        while len(layers) <= st.count:
            nxt: Exits = {}
            frames: int | None = 0
            for s, where in layers[-1].items():
                exits, f, h = self.walk(st.body, s, origin if where is None else where, branch)
                hull = tuple(join(a, b) for a, b in zip(hull, h))
                for s2, w2 in exits.items():
                    nxt.setdefault(s2, where if w2 is None else w2)
                frames = None if frames is None or f is None or len(layers[-1]) > 1 else f
            totals.append(frames)
            if not nxt:             # the first pass never ends: the frames until it stops
                return {}, totals[0] if len(totals) == 1 else None, hull
            k = len(layers)
            j = seen.get(frozenset(nxt))
            if j is not None:
                final = layers[j + (st.count - j) % (k - j)]
                break
            seen[frozenset(nxt)] = k
            layers.append(nxt)
        else:
            final = layers[st.count]
        # Without selects every pass after the first takes what the second does.
        first = totals[0]
        later = totals[1] if len(totals) > 1 else (first if st.count > 1 else 0)
        if first is None or later is None:
            return final, None, hull
        return final, first + later * (st.count - 1), hull

    def _loop(self, st: LoopStep, state: State, origin: Origin, branch: Branch | None) -> State:
        """Walk the body from every state a pass can start in (a fixpoint); returns the hull."""
        todo: list[tuple[State, Origin]] = [(state, origin)]
        seen = {state}
        hull: State = state
        while todo:
            s, where = todo.pop(0)
            exits, _, h = self.walk(st.body, s, where, branch)
            hull = tuple(join(a, b) for a, b in zip(hull, h))
            for s2, w2 in exits.items():
                if s2 not in seen:
                    seen.add(s2)
                    todo.append((s2, where if w2 is None else w2))
        return hull


# ----------------------------------------------------------------- golden frames

@dataclass(frozen=True)
class GoldenFrame:
    n: tuple[int | None, ...]       # per channel: the N the firmware sends; None = no pulse (no target yet)
    curve: tuple[int | None, ...]   # per channel: the language's N (differs from n by at most 1, and only
                                    # on an eased move's intermediate frames, where the firmware reads its table)
    span: Span                      # the statement that produced the frame
    sent: tuple[int, ...] = ()      # the bytes `send` gave since the frame before, in order


def firmware_value(n0: int, n1: int, k: int, frames: int, ease: str, table: tuple[int, ...]) -> int:
    """The N the firmware computes at frame k (1..F): the spec's formula for linear moves and for
    frame F; on an eased move's other frames N0 +- round(|delta| x table[k - 1] / 256) (half up)."""
    if ease == "linear" or k >= frames:
        return frame_value(n0, n1, k, frames, ease)
    step = (abs(n1 - n0) * table[k - 1] + EASE_SCALE // 2) // EASE_SCALE
    return n0 + step if n1 >= n0 else n0 - step


@dataclass(frozen=True)
class Choice:
    """What happens at one select `expand` reaches: it waits `frames` frames (the current targets
    repeating), then runs branch `branch` (an index into `SelectStep.branches`). A select looks at
    its events as soon as it is reached and again after each frame it waits, so `frames` = 0 is an
    event that was already there (the branch's first frame is the very next one). For an `after`
    branch the wait is always its own F; an `on` branch of a select with an `after` is taken at the
    latest at the F-th look, where its events come before `after` (`frames` <= F)."""
    branch: int
    frames: int = 0


UNDECIDED = 1 << 60     # Choice.frames of a select that takes no branch within the frames looked at


class Decider:
    """Decides at each select what the firmware does: `reach(select, frames)` when it is reached
    (`frames`: frames made so far) gives a token; `look(token, j, frames)` at its j-th look (0: as
    it is reached, then after each frame it waits, meanwhile frames included) gives the index of
    the branch taken there, or None to wait on. Raises ValueError for a decision a select cannot make."""

    def reach(self, select: SelectStep, frames: int):
        raise NotImplementedError

    def look(self, token, j: int, frames: int) -> int | None:
        raise NotImplementedError


class ListDecider(Decider):
    """`choices` in the order the selects are reached; when they run out, what the firmware does
    when no event comes: the select's `after` after its F frames, or waiting forever."""

    def __init__(self, choices: Iterable[Choice]) -> None:
        self.picks = iter(choices)

    def reach(self, select: SelectStep, frames: int):
        pick = next(self.picks, None)
        if pick is not None and pick.frames >= UNDECIDED:
            return None
        if pick is None and select.after is not None:
            pick = Choice(len(select.branches) - 1, select.after.frames)
        if pick is None:
            return None
        if not 0 <= pick.branch < len(select.branches):
            raise ValueError(f"choice {pick}: the select has {len(select.branches)} branches")
        branch = select.branches[pick.branch]
        wait = pick.frames
        if isinstance(branch, AfterBranch):
            wait = branch.frames
        elif wait < 0:
            raise ValueError(f"choice {pick}: a select waits a whole number of frames")
        elif select.after is not None and wait > select.after.frames:
            raise ValueError(f"choice {pick}: its `after` is taken after {select.after.frames} frames")
        return pick.branch, wait

    def look(self, token, j: int, frames: int) -> int | None:
        if token is None or j < token[1]:
            return None
        return token[0]


def expand(plan: Plan, choices: Iterable[Choice] | Decider = (), reached: list | None = None) -> Iterator[GoldenFrame]:
    """Every frame of the program, from the first timer frame; after main, the last repeats forever.

    A select cannot know which event comes: `expand` takes the next of `choices` at each select it
    reaches, in the order reached (or asks a `Decider`); when they run out it does what the firmware
    does when no event comes: it takes the select's `after` after its F frames, or waits there
    forever, repeating the current targets or running its meanwhile body. A meanwhile body is cut
    right after the frame of the look that takes a branch, where the servos are; selects inside
    it are reached (and take their choices) as the body runs, and the outer select looks first
    after each frame. A `send` adds its byte to the next frame's `sent`. Raises ValueError for a
    choice the select cannot make. `reached`, if given, gets (frames yielded so far, the select)
    each time a select is reached."""
    decider = choices if isinstance(choices, Decider) else ListDecider(choices)
    count = len(plan.channels)
    state: list[int | None] = [None] * count
    last_span = NO_SPAN
    classes = tuple(c.speed_class for c in plan.channels)
    pending: list[int] = []

    memo: dict = {}
    send_memo: dict = {}

    made = 0

    def frame(span: Span, curve: tuple | None = None) -> GoldenFrame:
        nonlocal last_span, made
        last_span = span
        made += 1
        sent = tuple(pending)
        pending.clear()
        now = tuple(state)
        return GoldenFrame(now, now if curve is None else curve, span, sent)

    def select(st: SelectStep) -> Iterator[GoldenFrame]:
        if reached is not None:
            reached.append((made, st))
        token = decider.reach(st, made)
        j = 0
        taken = decider.look(token, 0, made)
        if taken is None and st.meanwhile is not None:
            body = run(st.meanwhile)
            for fr in body:
                yield fr
                j += 1
                taken = decider.look(token, j, made)
                if taken is not None:
                    body.close()
                    break
        while taken is None:
            yield frame(st.span)
            j += 1
            taken = decider.look(token, j, made)
        yield from run(st.branches[taken].body)

    def run(body: tuple[Step, ...]) -> Iterator[GoldenFrame]:
        for st in body:
            if isinstance(st, SendStep):
                pending.append(st.byte)
                continue
            if isinstance(st, SelectStep):
                yield from select(st)
                continue
            if not isinstance(st, LoopStep) and not takes_frames((st,), plan, memo) and not sends((st,), plan, send_memo):
                continue        # e.g. `repeat 65535 { hold 1ms }`: nothing to run through
            if isinstance(st, MoveStep):
                f = move_frames_at(st, tuple(state), plan.speed_tables, classes)
                start = list(state)
                for k in range(1, f + 1):
                    curve = list(state)
                    for ch, n1 in st.targets:
                        n0 = start[ch]
                        state[ch] = n1 if n0 is None else firmware_value(n0, n1, k, f, st.ease, st.ease_table)
                        curve[ch] = n1 if n0 is None else frame_value(n0, n1, k, f, st.ease)
                    yield frame(st.span, tuple(curve))
            elif isinstance(st, HoldStep):
                for _ in range(st.frames):
                    yield frame(st.span)
            elif isinstance(st, RepeatStep):
                for _ in range(st.count):
                    yield from run(st.body)
            elif isinstance(st, LoopStep):
                while True:
                    before = None
                    for fr in run(st.body):
                        before = fr
                        yield fr
                    if before is None:      # a pass that took no frame waits for the next frame
                        yield frame(last_span)
            else:
                yield from run(plan.sequence(st.sequence).body)

    yield from run(plan.main)
    while True:
        yield frame(last_span)
