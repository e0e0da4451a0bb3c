"""The speed planner: model.Program -> Plan.

The Plan is what the firmware is generated from and what `verify` checks
against. It keeps the program's control flow (repeat, loop and play are not
unrolled): each move becomes a `MoveStep` whose frame count F is fixed when
the move has a duration, and left to the run-time rule (as fast as the slowest
servo allows) when it has none. The planner also walks every context a
statement can run in (first and later passes of repeats and loops, every
place a sequence is played) and records each distinct move instance with its
start and end N, which is what the speed lint reads.

`expand(plan)` is the golden model: the exact N of every channel in every
frame, following the spec's formulas. Invariants: all N in 0..250; frame F of
a move equals the pose; after `main` ends the last frame repeats forever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Iterator, Union

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


Step = Union[MoveStep, HoldStep, RepeatStep, LoopStep, PlayStep]


@dataclass(frozen=True)
class SequencePlan:
    name: str
    body: tuple[Step, ...]
    span: Span = field(default=NO_SPAN, compare=False)


@dataclass(frozen=True)
class ServoMotion:
    channel: int
    n0: int | None        # None: the servo had no target yet (set at once)
    n1: int

    @property
    def delta(self) -> int:
        return 0 if self.n0 is None else self.n1 - self.n0


@dataclass(frozen=True)
class MoveInstance:
    """One move in one context the program can reach."""
    step: MoveStep
    frames: int
    motions: tuple[ServoMotion, ...]


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
        return n0 + sign * round_half_up(Fraction(abs(delta) * k, frames))
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
    return {t.servo for st in walk.statements([program.main, *(seq.body for seq in program.sequences)])
            if isinstance(st, model.Move) for t in st.targets}


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
    except layout.LayoutError:
        return replace(p, min_period_us=p.period_us)
    return replace(p, min_period_us=unit.min_period_us or p.period_us)


def _any_frame(acc: bool, st: Step, inner: bool | None) -> bool:
    kind = walk.kind(st)
    return acc or kind == "move" or (kind == "hold" and st.frames > 0) or bool(inner)


def takes_frames(body: tuple[Step, ...], plan: Plan, memo: dict | None = None) -> bool:
    """Whether every pass of `body` takes at least one frame (a move always does; a hold when
    it is at least half a frame; repeat, loop and play when their body does). Pass one `memo`
    to calls on the same plan so each sequence is looked at once."""
    return walk.fold(body, lambda name: plan.sequence(name).body, False, _any_frame, memo)


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

    def steps(body: tuple) -> tuple[Step, ...]:
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
                out.append(RepeatStep(st.count, steps(st.body), st.span))
            elif isinstance(st, model.Loop):
                out.append(LoopStep(steps(st.body), st.span))
            else:
                out.append(PlayStep(st.sequence, st.span))
        return tuple(out)

    speed_classes = tuple(c.speed_class for c in channels)
    main = steps(program.main)
    seq_bodies = {s.name: SequencePlan(s.name, steps(s.body), s.span) for s in program.sequences}
    walker = _Walker(seq_bodies, tables, speed_classes)
    walker.walk(main, (None,) * len(channels))
    # A move without duration whose F is the same in every context gets that F fixed;
    # only the others are left to the firmware's run-time rule.
    fixed: dict[int, int] = {}
    by_step: dict[int, set[int]] = {}
    for inst in walker.instances.values():
        by_step.setdefault(id(inst.step), set()).add(inst.frames)
    for inst in walker.instances.values():
        if inst.step.frames is None and len(by_step[id(inst.step)]) == 1:
            fixed[id(inst.step)] = inst.frames
    if fixed:
        main = _fix_frames(main, fixed)
        seq_bodies = {n: SequencePlan(sp.name, _fix_frames(sp.body, fixed), sp.span) for n, sp in seq_bodies.items()}
        walker = _Walker(seq_bodies, tables, speed_classes)
        walker.walk(main, (None,) * len(channels))
    _, total, infinite = walker.walk(main, (None,) * len(channels))
    # Every sequence main can name, also after a `loop` (code there never runs, but later
    # stages still walk it and look its sequences up).
    named = _named_sequences(main, seq_bodies)
    used = [seq_bodies[s.name] for s in program.sequences if s.name in named]
    return Plan(program, tuple(channels), ports, period, is_default, period, tables, tuple(classes),
                main, tuple(used), tuple(walker.instances.values()), None if infinite else total, depth)


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
        n0 = state[ch]
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
    state: State = (None,) * len(plan.channels)
    frames = 0
    for st in plan.main:
        if isinstance(st, LoopStep):
            state, first, _ = walker.walk(st.body, state)
            _, later, _ = walker.walk(st.body, state)
            frames += first + later
            break
        state, more, infinite = walker.walk((st,), state)
        frames += more
        if infinite:            # a loop inside a repeat or a sequence: what precedes it, and a margin
            break
    return min(VERIFY_MAX_FRAMES, max(400, frames + VERIFY_TAIL_FRAMES))


class _Walker:
    """Runs the steps over states, not frames: each body is walked once per distinct entry state."""

    def __init__(self, sequences: dict[str, SequencePlan], tables, classes):
        self.sequences = sequences
        self.tables = tables
        self.classes = classes
        self.instances: dict[tuple, MoveInstance] = {}
        self.played: set[str] = set()
        self.memo: dict[tuple, tuple[State, int, bool]] = {}

    def walk(self, body: tuple[Step, ...], state: State) -> tuple[State, int, bool]:
        key = (id(body), state)
        if key in self.memo:
            return self.memo[key]
        total, infinite = 0, False
        for st in body:
            if isinstance(st, MoveStep):
                f = move_frames_at(st, state, self.tables, self.classes)
                motions = tuple(ServoMotion(ch, state[ch], n1) for ch, n1 in st.targets)
                self.instances.setdefault((id(st), state), MoveInstance(st, f, motions))
                new = list(state)
                for ch, n1 in st.targets:
                    new[ch] = n1
                state = tuple(new)
                total += f
            elif isinstance(st, HoldStep):
                total += st.frames
            elif isinstance(st, RepeatStep):
                # Poses are absolute, so every pass after the first starts from the same state.
                state, first, inf = self.walk(st.body, state)
                if st.count > 1 and not inf:
                    state, later, inf = self.walk(st.body, state)
                    total += first + later * (st.count - 1)
                else:
                    total += first
                infinite = infinite or inf
            elif isinstance(st, LoopStep):
                # A second pass starts where the first ended, unless the first never ends
                # (a loop inside): then there is no second pass to walk.
                state, _, inf = self.walk(st.body, state)
                if not inf:
                    state, _, _ = self.walk(st.body, state)
                infinite = True
            else:
                self.played.add(st.sequence)
                state, f, inf = self.walk(self.sequences[st.sequence].body, state)
                total += f
                infinite = infinite or inf
            if infinite:
                break
        self.memo[key] = (state, total, infinite)
        return self.memo[key]


# ----------------------------------------------------------------- golden frames

@dataclass(frozen=True)
class GoldenFrame:
    n: tuple[int | None, ...]       # per channel: the N the firmware sends; None = no pulse (no target yet)
    curve: tuple[int | None, ...]   # per channel: the language's N (differs from n by at most 1, and only
                                    # on an eased move's intermediate frames, where the firmware reads its table)
    span: Span                      # the statement that produced the frame


def firmware_value(n0: int, n1: int, k: int, frames: int, ease: str, table: tuple[int, ...]) -> int:
    """The N the firmware computes at frame k (1..F): the spec's formula for linear moves and for
    frame F; on an eased move's other frames N0 +- round(|delta| x table[k - 1] / 256) (half up)."""
    if ease == "linear" or k >= frames:
        return frame_value(n0, n1, k, frames, ease)
    step = (abs(n1 - n0) * table[k - 1] + EASE_SCALE // 2) // EASE_SCALE
    return n0 + step if n1 >= n0 else n0 - step


def expand(plan: Plan) -> Iterator[GoldenFrame]:
    """Every frame of the program, from the first timer frame; after main, the last repeats forever."""
    count = len(plan.channels)
    state: list[int | None] = [None] * count
    last_span = NO_SPAN
    classes = tuple(c.speed_class for c in plan.channels)

    memo: dict = {}

    def run(body: tuple[Step, ...]) -> Iterator[GoldenFrame]:
        nonlocal last_span
        for st in body:
            if not takes_frames((st,), plan, memo):
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
                    last_span = st.span
                    yield GoldenFrame(tuple(state), tuple(curve), st.span)
            elif isinstance(st, HoldStep):
                for _ in range(st.frames):
                    last_span = st.span
                    yield GoldenFrame(tuple(state), tuple(state), st.span)
            elif isinstance(st, RepeatStep):
                for _ in range(st.count):
                    yield from run(st.body)
            elif isinstance(st, LoopStep):
                while True:
                    before = None
                    for fr in run(st.body):
                        before = fr
                        yield fr
                    if before is None:      # a loop whose body makes no frames holds the last frame
                        break
            else:
                yield from run(plan.sequence(st.sequence).body)

    yield from run(plan.main)
    while True:
        yield GoldenFrame(tuple(state), tuple(state), last_span)
