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

import functools
import math
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Iterable, Iterator, Union

from . import model, ssc32, walk
from .model import host_channel
from .diagnostics import Reporter
from .flow import sends, takes_frames
from .source import NO_SPAN, Span
from .steps import (AfterBranch, Branch, Channel, HoldStep, HostStep, LoopStep, host_playable, host_range, MoveInstance, MoveStep, OnBranch, Origin, Plan,
                    PlayStep, Reach, RepeatStep, SelectStep, SendStep, SequencePlan, ServoMotion, Step, at_statement,
                    far, far_from, join, steps)
from .units import DEFAULT_PERIOD_FLOOR_US, N_MAX, frames_for, frames_needed, move_frames, round_half_up

EASE_SCALE = 256     # eased curves are stored as e(k/F) x 256, rounded, clamped to 255
MAX_TABLE_FRAMES = 65535   # the firmware's frame counters are 16 bits; longer moves are a
                           # lint error (too-long), so their curve tables are not built




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
    if u in _COS_EXACT:
        return (1 - _COS_EXACT[u]) / 2
    return (1 - math.cos(math.pi * u)) / 2


_COS_EXACT = {Fraction(0): Fraction(1), Fraction(1, 3): Fraction(1, 2), Fraction(1, 2): Fraction(0),
              Fraction(2, 3): Fraction(-1, 2), Fraction(1): Fraction(-1)}     # cos(pi u) where rational


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
    return tuple(ease_entry(ease, k, frames) for k in range(1, frames))


def ease_entry(ease: str, k: int, frames: int) -> int:
    """The eased curve table's entry for frame k (1..F-1): e(k / F) x 256, rounded, below 256."""
    return min(EASE_SCALE - 1, math.floor(ease_value(ease, Fraction(k, frames)) * EASE_SCALE + Fraction(1, 2)))


def first_frame(st: MoveStep, state: tuple, frames: int) -> tuple:
    """Per channel the N of move `st`'s first frame in `frames` frames from `state` (a servo
    without a target jumps to its own; one the move does not name stays as it is)."""
    out = list(state)
    table = () if st.ease == "linear" or frames <= 1 else (ease_entry(st.ease, 1, frames),)
    for ch, n1 in st.targets:
        n0 = state[ch]
        out[ch] = n1 if n0 is None else firmware_value(n0, n1, 1, frames, st.ease, table) if isinstance(n0, int) else n0
    return tuple(out)


# ----------------------------------------------------------------- planning

State = tuple  # per channel: N or None


def _moved_servos(program: model.Program) -> set[str]:
    """The servos that get pulses: those a move names, and those of the `home` pose; with a `host`
    statement, every servo (the host may move any of them)."""
    if hosts(program):
        return {s.name for s in program.servos}
    home = {t.servo for t in program.home.targets} if program.home is not None else set()
    return home | {t.servo for st in walk.statements([program.main, *(seq.body for seq in program.sequences)])
                   if isinstance(st, model.Move) for t in st.targets}


def hosts(program: model.Program) -> bool:
    """Whether the program runs a `host` statement anywhere (main, or a sequence)."""
    return any(isinstance(st, model.Host)
               for st in walk.statements([program.main, *(seq.body for seq in program.sequences)]))


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


def plan(program: model.Program, reporter: Reporter | None = None, period_us: int | None = None) -> Plan:
    """Plan a checked program at one frame period: its `frame`, else `period_us` (a default P the
    period stage chose; at first the 5.3 ms floor). Checks on the result are the linter's job.

    The plan's `min_period_us` is its own P until the period stage (`servoc.api.plan`) reads the
    shortest period from the code generated for it."""
    moved = _moved_servos(program)
    servos = sorted((s for s in program.servos if s.name in moved), key=lambda s: s.channel)
    ports = tuple(sorted({s.port for s in servos}))
    depth = walk.nesting(program.main, {q.name: q.body for q in program.sequences}.__getitem__)
    if program.frame_us is not None:
        return _plan_at(program, servos, ports, max(1, round_half_up(program.frame_us)), False, depth)
    return _plan_at(program, servos, ports, period_us or DEFAULT_PERIOD_FLOOR_US, True, depth)


def _model_steps(body: tuple, index: dict[str, int], period: int, sequences: tuple[str, ...] = ()) -> tuple[Step, ...]:
    """model statements -> plan steps at period P (`index`: channel of each servo by name;
    `sequences`: every sequence's name in declaration order, those a `host` can play)."""
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
            out.append(RepeatStep(st.count, _model_steps(st.body, index, period, sequences), st.span))
        elif isinstance(st, model.Loop):
            out.append(LoopStep(_model_steps(st.body, index, period, sequences), st.span))
        elif isinstance(st, model.Select):
            branches = tuple(
                OnBranch(b.event, _model_steps(b.body, index, period, sequences), b.span) if isinstance(b, model.On)
                else AfterBranch(frames_for(b.duration_us, period), b.duration_us,
                                 _model_steps(b.body, index, period, sequences), b.span)
                for b in st.branches)
            meanwhile = None if st.meanwhile is None else _model_steps(st.meanwhile, index, period, sequences)
            out.append(SelectStep(branches, st.wait, st.span, meanwhile, st.until))
        elif isinstance(st, model.Send):
            out.append(SendStep(st.byte, st.text, st.span))
        elif isinstance(st, model.Host):
            out.append(HostStep(tuple(PlayStep(name, st.span) for name in sequences), st.span))
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
    names = host_playable(program)
    main = startup + _model_steps(program.main, index, period, names)
    seq_bodies = {s.name: SequencePlan(s.name, _model_steps(s.body, index, period, names), s.span)
                  for s in program.sequences}
    if hosts(program):      # a `host` plays any sequence from its own level
        depth = max(depth, walk.nesting(main, lambda name: seq_bodies[name].body))
    hosted = tuple(Reach(*host_range(c.servo), True) for c in channels) if hosts(program) else None
    order = host_playable(program)
    walker = _Walker(seq_bodies, tables, speed_classes, hosted, order)
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
        walker = _Walker(seq_bodies, tables, speed_classes, hosted, order)
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
    hosted = tuple(Reach(*host_range(c.servo), True) for c in plan.channels) if hosts(plan.program) else None
    walker = _Walker({s.name: s for s in plan.sequences}, plan.speed_tables,
                     tuple(c.speed_class for c in plan.channels), hosted, tuple(s.name for s in plan.sequences))
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

MAX_STATES = 64     # states kept apart at one point of a body (`_Walker._widen`)


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

    def __init__(self, sequences: dict[str, SequencePlan], tables, classes, hosted: State | None = None,
                 order: tuple[str, ...] = ()):
        self.sequences = sequences
        self.hosted = hosted        # where a `host` statement can leave each servo (a Reach per channel)
        self.order = order          # the sequences a host can play (`PL 0 SQ n`), in declaration order
        self.tables = tables
        self.classes = classes
        self.instances: dict[tuple, MoveInstance] = {}
        self.played: set[str] = set()
        self.memo: dict[tuple, tuple[Exits, int | None, State]] = {}
        self.alive: dict[int, tuple] = {}     # the bodies `memo` has seen, by id: kept, so that no id is reused
        self.cuts: dict[int, State] = {}      # id(select) -> the join of its cut states (for `servoc plan`)
        self.hosting: set[tuple] = set()      # (sequence, state) the host's plays are being walked from

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
                    motions = tuple(ServoMotion(ch, far(s[ch], n1), n1, far_from(s[ch], n1),
                                                isinstance(s[ch], Reach) and s[ch].merged) for ch, n1 in st.targets)
                    cut = any(isinstance(s[ch], Reach) for ch, _ in st.targets)
                    if (id(st), s) not in self.instances:
                        self.instances[(id(st), s)] = MoveInstance(st, f, motions, made(where), branch, cut, s,
                                                                   first_frame(st, s, f))
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
            elif isinstance(st, HostStep):
                # the host moves any servo anywhere it can go, switches any off, and plays any
                # sequence from there: those are walked from that state; it never ends by itself
                held = tuple(at_statement(v, st.span) for v in self.hosted)
                more(held)
                for name in self.order:
                    self.played.add(name)
                    if (name, held) in self.hosting:    # a sequence with `host` in it, played by the host:
                        continue                        # it is being walked from there already
                    self.hosting.add((name, held))
                    _, _, h = self.walk(self.sequences[name].body, held, ("host", st.span), branch)
                    self.hosting.discard((name, held))
                    more(h)
                total = None
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
                        starts[cut] = ("cut", st.span, st.branches[0].event.text if st.until else None,
                                       st.meanwhile[0].span if st.until and st.meanwhile else None)
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
            cur = self._widen(new, st.span)
            for s in cur:
                more(s)
            if not cur:
                break
        self.memo[key] = (cur, total, hull)
        self.alive[id(body)] = body     # a body made for one call, `(st,)`, must not lend its id to another
        return self.memo[key]

    def _widen(self, states: Exits, span: Span) -> Exits:
        """`states` where they are at most MAX_STATES; else one state, each servo anywhere between the
        positions it has in them (a Reach credited to the statement at `span`, after which they are
        merged). Independent choices (selects one after another, each setting other
        servos) multiply the states a program can be in; past the bound the walk keeps their hull, as
        it does for an interruption, so that it stays linear in the program. Each move from there is
        checked from the farthest position of each servo it names, the same verdict as from every
        state apart; a move without a duration gets its F at run time."""
        if len(states) <= MAX_STATES:
            return states
        hull = tuple(values[0] if len(set(values)) == 1
                     else replace(at_statement(functools.reduce(join, values), span), merged=True)
                     for values in zip(*states))
        return {hull: ("merged", span, len(states))}

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
            cur = self._widen(new, part.span)
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
            nxt = self._widen(nxt, st.span)
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


@dataclass(frozen=True)
class HostRun:
    """What happens in one run of a `host` statement `expand` reaches: per frame's reading, the
    bytes the firmware's parser read (docs/host-protocol.md); after the last, it reads none."""
    reads: tuple[tuple[int, ...], ...] = ()


class Decider:
    """Decides at each select what the firmware does: `reach(select, frames)` when it is reached
    (`frames`: frames made so far) gives a token; `look(token, j, frames)` at its j-th look (0: as
    it is reached, then after each frame it waits, meanwhile frames included) gives the index of
    the branch taken there, or None to wait on. Raises ValueError for a decision a select cannot make."""

    def reach(self, select: SelectStep, frames: int):
        raise NotImplementedError

    def look(self, token, j: int, frames: int) -> int | None:
        raise NotImplementedError

    def host(self, st: HostStep) -> HostRun | None:
        """The bytes a run of `st` reads (None: none at all)."""
        return None


class ListDecider(Decider):
    """`choices` in the order the selects are reached; when they run out, what the firmware does
    when no event comes: the select's `after` after its F frames, or waiting forever."""

    def __init__(self, choices: Iterable[Choice | HostRun]) -> None:
        choices = tuple(choices)
        self.picks = iter(c for c in choices if not isinstance(c, HostRun))
        self.hosts = iter(c for c in choices if isinstance(c, HostRun))

    def host(self, st: HostStep) -> HostRun | None:
        return next(self.hosts, None)

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


def expand(plan: Plan, choices: Iterable[Choice] | Decider = (), reached: list | None = None,
           seen: dict | None = None) -> Iterator[GoldenFrame]:
    """Every frame of the program, from the first timer frame; after main, the last repeats forever.

    A select cannot know which event comes: `expand` takes the next of `choices` at each select it
    reaches, in the order reached (or asks a `Decider`), and at each run of a `host` statement the
    next `HostRun` of them (the firmware's model, `servoc.ssc32`, turns its bytes into frames and
    replies; a `PL 0 SQ n` plays the sequence and the statement runs again); when they run out it does what the firmware
    does when no event comes: it takes the select's `after` after its F frames, or waits there
    forever, repeating the current targets or running its meanwhile body. A meanwhile body is cut
    right after the frame of the look that takes a branch, where the servos are; selects inside
    it are reached (and take their choices) as the body runs, and the outer select looks first
    after each frame. A `send` adds its byte to the next frame's `sent`. Raises ValueError for a
    choice the select cannot make. `reached`, if given, gets (frames yielded so far, the select)
    each time a select is reached. `seen`, if given, gets id(statement) of each statement started
    and id(branch) of each branch taken; a loop's value counts the passes it completed."""
    decider = choices if isinstance(choices, Decider) else ListDecider(choices)
    count = len(plan.channels)
    state: list[int | None] = [None] * count
    last_span = NO_SPAN
    classes = tuple(c.speed_class for c in plan.channels)
    pending: list[int] = []
    held: set[int] = set()      # channels `STOP c` holds while a sequence `PL` started plays

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
        if seen is not None:
            seen[id(st.branches[taken])] = 0
        yield from run(st.branches[taken].body)

    host_servos = [ssc32.Servo(host_channel(c.servo), *(c.servo.limit or (0, N_MAX)), c.servo.reverse,
                               c.servo.trim, c.servo.t_dav_us) for c in plan.channels]
    offsets: dict[int, int] = {}        # the firmware's offsets outlive a run of `host`

    def host(st: HostStep) -> Iterator[GoldenFrame]:
        """A run of `st`: each frame the bytes its reading read go to the model, then the frame; a
        `PL 0 SQ n` plays sequence n, its frames each followed by a reading (`Q` answers `+`), then
        a frame repeating its end, and the run goes on with the lines read meanwhile; a group or
        `PL` line read while it plays ends it, and the run goes on with that line, with no frame
        repeating the sequence's end."""
        names = [q.name for q in plan.program.sequences]
        run_ = decider.host(st)
        session = ssc32.Session(host_servos, plan.period_us, {names.index(p.sequence) for p in st.plays},
                                {s.channel: state[i] for i, s in enumerate(host_servos)})
        session.offsets.update(offsets)
        parser = ssc32.LineParser()
        reads = iter(run_.reads if run_ is not None else ())
        played = 0

        def read() -> None:
            pending.extend(session.answers())      # those that waited for a group's commit first
            for b in next(reads, ()):
                cmd = parser.feed(b)
                if cmd is not None:
                    pending.extend(session.line(cmd))
            offsets.update(session.offsets)

        carry = False               # a line that ended a sequence is carried out with no reading first
        while True:
            if not carry:
                read()
            carry = False
            now = session.frame()
            for i, s in enumerate(host_servos):
                state[i] = now[s.channel]
            yield frame(st.span)
            if len(session.plays) > played:
                sequence = plan.sequence(names[session.plays[played]])
                played += 1
                session.sequence_running = True
                frames_ = run(sequence.body)
                try:
                    for fr in frames_:
                        yield fr
                        session.now = {s.channel: state[i] for i, s in enumerate(host_servos)}
                        read()
                        if session.pending_offsets is not None:     # an offset line: its offsets now, and
                            session.set_offsets()                   # the reading goes on in the next frame
                            offsets.update(session.offsets)
                            session.reading_stopped = False
                        held.update(i for i, s in enumerate(host_servos) if s.channel in session.held)
                        if session.stop_play:       # `STOP` read: the sequence ends in this frame
                            frames_.close()
                            session.reading_stopped = False
                            break
                        if session.replace_play:    # a group or PL line: it ends here, and the line is
                            frames_.close()         # carried out in the next frame
                            break
                finally:                            # its end (or a cut of `host`) lets them go
                    held.clear()
                    session.held.clear()
                replaced = session.replace_play
                session.sequence_running = session.stop_play = session.replace_play = False
                session.move = None
                carry = replaced
                if not replaced:
                    yield frame(st.span)            # the frame that repeats the sequence's end
                    session.now = {s.channel: state[i] for i, s in enumerate(host_servos)}

    def passed(st: Step) -> None:
        """`st`, which takes no frame and sends nothing, has run: so has each statement in it."""
        todo, done = [st], set()
        while todo:
            inner = todo.pop()
            seen.setdefault(id(inner), 0)
            if isinstance(inner, RepeatStep):
                todo.extend(inner.body)
            elif isinstance(inner, PlayStep) and inner.sequence not in done:
                done.add(inner.sequence)
                todo.extend(plan.sequence(inner.sequence).body)

    def run(body: tuple[Step, ...]) -> Iterator[GoldenFrame]:
        for st in body:
            if seen is not None:
                seen.setdefault(id(st), 0)
            if isinstance(st, SendStep):
                pending.append(st.byte)
                continue
            if isinstance(st, HostStep):
                yield from host(st)
                continue
            if isinstance(st, SelectStep):
                yield from select(st)
                continue
            if not isinstance(st, LoopStep) and not takes_frames((st,), plan, memo) and not sends((st,), plan, send_memo):
                if seen is not None:        # e.g. `repeat 65535 { hold 1ms }`: nothing to run through, but run
                    passed(st)
                continue
            if isinstance(st, MoveStep):
                f = move_frames_at(st, tuple(state), plan.speed_tables, classes)
                start = list(state)
                for k in range(1, f + 1):
                    curve = list(state)
                    for ch, n1 in st.targets:
                        n0 = start[ch]
                        if ch in held and n0 is not None:
                            continue            # `STOP c` holds it where it is (one with no pulse yet is set)
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
                    if before is None:      # a pass that took no frame waits for the next frame, in the loop
                        yield frame(st.span)
                    if seen is not None:
                        seen[id(st)] += 1
            else:
                yield from run(plan.sequence(st.sequence).body)

    yield from run(plan.main)
    if seen is not None:
        seen["main ended"] = made
    while True:
        yield frame(last_span)
