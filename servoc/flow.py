"""The plan's control flow, folded: Plan -> facts the planner, the linter and codegen read.

Which bodies can take a frame (`takes_frames`, `fewest_frames`), which send
(`sends`), the most bytes sent with no frame between them (`send_run`) and the
fewest frames between two runs of sends (`send_gap`), the repeats whose pass
can run through without a frame (`frameless_repeats`), and what the selects
need (`watches`, `select_slots`, `edge_ports`, `select_ram`). Each is a fold
over the steps (servoc.walk): linear in the program's size, each sequence
looked at once.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterator

from . import walk
from .steps import (AfterBranch, HostStep, LoopStep, MoveStep, Plan, PlayStep, Reach, RepeatStep, SelectStep, Step,
                    host_playable, host_range, steps)


def _any_frame(acc: bool, st: Step, inner) -> bool:
    kind = walk.kind(st)
    if kind in ("select", "host"):
        return True
    return acc or kind == "move" or (kind == "hold" and st.frames > 0) or bool(inner)


def watches(plan: Plan) -> bool:
    """True when a select of the program has a meanwhile body (the firmware's frame_w looks)."""
    return any(isinstance(st, SelectStep) and st.meanwhile is not None for st in steps(plan))


def frame_wrapped(plan: Plan) -> bool:
    """Whether the program's frame call is frame_h around frame_w (host.asm.j2): `PL` can play a
    sequence, and a select has a meanwhile body (costs.WRAP_STACK more runtime stack)."""
    return plan.program.serial is not None and hosted(plan) and bool(host_playable(plan.program)) and watches(plan)


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
            elif isinstance(st, HostStep):      # `PL 0 SQ n` plays a sequence from the host's level
                work.extend((plan.sequence(p.sequence).body, depth) for p in st.plays)
    return slots


def edge_ports(plan: Plan) -> tuple[int, ...]:
    """The ports of the inputs some `on press` / `on release` watches, ascending (a look samples each)."""
    inputs = {i.name: i for i in plan.program.inputs}
    return tuple(sorted({inputs[b.event.input].port for st in steps(plan) if isinstance(st, SelectStep)
                         for b in st.branches if not isinstance(b, AfterBranch) and b.event.edge}))


def select_ram(plan: Plan, xram: bool | None = None) -> int:
    """Bytes of RAM the selects (and a `host` statement, and a transmit queue longer than the
    serial line's own) take from the stack: a look's sample of each port in `edge_ports`, per
    level of `select_slots` with a meanwhile body, the select running it and its stack pointer,
    `host_ram` (`xram`: as `host_ram`), and `tx_queue` past costs.QUEUE."""
    from . import costs
    slots = select_slots(plan)
    levels = {slots[id(st)] for st in steps(plan) if isinstance(st, SelectStep) and st.meanwhile is not None}
    return len(edge_ports(plan)) + 2 * len(levels) + host_ram(plan, xram) + tx_queue(plan) - costs.QUEUE


HOST_VARS = 17          # the host parser's variables, VER's answer's next byte, the answers waiting, HPLAY (host.asm.j2)
HOST_PER_SERVO = 5      # per servo: its pending width or offset (2), its pending S (2) and its offset
HOST_XRAM_PER_SERVO = HOST_PER_SERVO + 1    # in XRAM (host_xram) also its pending entry's generation


def host_passes(plan: Plan) -> int:
    """The bytes the host parser reads in one frame at the most, p. With b the bytes a frame brings
    (from a host 2 % fast): at least one more than b, so that bytes left queued by a late frame are
    read in the frames after. And after a group line the reading stops before a line's second
    entry (with the state in XRAM: an entry that ends once the holds are taken, `layout.host_holds`), or the end of a line
    that does not join the group (the group waits for host_step): a frame's reading may be cut
    short once a line, so for lines of L bytes back to back the frames a line takes must read it
    and that frame too, p (L / b - 1) >= L: p >= b L / (L - b),
    for L the longer of a line that sets every servo (`full_line`) and two frames' bytes (so p is
    at most 2 b). Shorter lines that cut the reading may fill the receive queue; lines of one
    entry never do (they join the group), so they keep up at any length, and in XRAM neither do
    lines whose entries for the group's servos the holds take (docs/host-protocol.md)."""
    b = frame_bytes(plan)
    line = max(Fraction(full_line(plan)), 2 * b)
    return max(math.ceil(b) + 1, math.ceil(b * line / (line - b)))


def frame_bytes(plan: Plan) -> Fraction:
    """The bytes a frame brings from a host at the declared rate (2 % fast), b."""
    return Fraction(plan.program.target.cycles(plan.period_us), _host_gap(plan))


CUT_LINE = len(b"#0P0#1P0\r")     # the shortest line that does something and that the reading may stop in
                                  # (before its second '#') while a group waits


ANSWER_LINE = len(b"#0P0\rQ\r")   # the shortest group line and answer line that stopped the reading between them


def reads_answers(plan: Plan) -> bool:
    """Whether `host` reads on through `Q`, `QP` and `VER` lines after a group line (a `Q`'s answer
    waiting for the group's commit): where a frame brings more bytes than ANSWER_LINE (else a
    frame gets through a group line and an answer line at least, as many bytes as a frame brings,
    and the code would buy nothing), and the build has the holds' code (`Plan.holds`)."""
    return hosted(plan) and plan.holds and frame_bytes(plan) > ANSWER_LINE


def full_line(plan: Plan) -> int:
    """Bytes of a group line that sets every servo of `host` to a width of 4 digits (`#c P1500`, no
    spaces) and its CR: the lines `host_passes` keeps up with back to back."""
    from .model import host_channel
    return sum(len(f"#{host_channel(c.servo)}P1500") for c in plan.channels) + 1


def host_queue(plan: Plan) -> int:
    """The bytes the receive queue holds while `host` runs: the bytes of two frames and two more
    (the parser's runs are a frame apart on average, and at most two apart); the selects' QUEUE
    without `host`."""
    from . import costs
    if plan.program.serial is None or not hosted(plan):
        return costs.QUEUE
    need = -(-2 * plan.program.target.cycles(plan.period_us) // _host_gap(plan)) + 2
    return max(costs.QUEUE, need)


def _host_gap(plan: Plan) -> int:
    from . import costs, target as target_mod
    serial = plan.program.serial
    return costs.rx_gap(target_mod.byte_cycles(serial.th1, serial.smod))


def host_vars(plan: Plan) -> int:
    """The host's variables: HOST_VARS, and where `PL` can play a sequence a byte a port in use, the
    lines `STOP c` holds where they are until it ends (HFRZ)."""
    return HOST_VARS + (len(plan.ports) if host_playable(plan.program) else 0)


def host_ram(plan: Plan, xram: bool | None = None) -> int:
    """Bytes of internal RAM a `host` statement takes from the stack: its variables, its per-servo
    state (in XRAM where `host_xram`; `xram` given: as if it were so or not) and the receive queue's
    growth (0 without `host`)."""
    if not hosted(plan):
        return 0
    from . import costs
    if xram is None:
        xram = host_xram(plan)
    if xram:        # HGEN, HGA, HHP, HHJ (layout.host_holds is 2 at least there); the rest in XRAM
        state = 2 + (2 if plan.holds else 0)
    else:           # the per-servo state, the holds and HHP, HHJ
        k = iram_holds(plan)
        state = HOST_PER_SERVO * len(plan.channels) + HOLD_BYTES_IRAM * k + (2 if k else 0)
    return host_vars(plan) + state + host_queue(plan) - costs.QUEUE


HOLDS_IRAM = 2          # the entries held in one frame where the host's state is in internal RAM
HOLD_BYTES_IRAM = 5     # a hold there: its servo, its S (2), its width or offset (2) (no generations)


def iram_holds(plan: Plan) -> int:
    """The holds where the host's state is in internal RAM (layout.host_holds): HOLDS_IRAM where a
    frame brings more bytes than CUT_LINE (without holds the reading gets through a line a frame
    at least, as many bytes as a frame brings when no line is shorter than that, so the holds'
    cycles would buy nothing), and the build has them (`Plan.holds`); else 0."""
    return HOLDS_IRAM if hosted(plan) and plan.holds and frame_bytes(plan) > CUT_LINE else 0


def host_short(plan: Plan, xram: bool | None = None) -> int:
    """Bytes of internal RAM `host` lacks (0: it fits) by the stack room other programs are promised
    (`costs.stack_room`): with no repeat or play nested, it must still hold the runtime's, the
    edge handler's and the serial handler's (`xram`: as `host_ram`); 0 where `host_xram`. It
    chooses XRAM (`host_xram`) and `host-ram`'s hint; whether a `host` program fits is decided by
    the RAM the firmware allocates (code generation: `host-ram` or `too-deep`)."""
    if not hosted(plan):
        return 0
    from . import costs
    if xram is None and host_xram(plan):
        return 0
    serial = plan.program.serial is not None
    room = costs.stack_room(serial, select_ram(plan, xram), len(plan.ports), bool(xram))
    return max(0, costs.stack_bytes(0, serial, True, frame_wrapped(plan)) - room)


def state_may_go_to_xram(plan: Plan) -> bool:
    """Whether the chip has the XRAM (the STC89's) that the motion state moves to where internal
    RAM cannot hold it beside the program's stack and buffers (codegen: `_state_where_it_fits`;
    lint's `too-deep` counts the stack that leaves)."""
    return plan.program.target.chip.xram_bytes >= XRAM_NEED


def host_xram(plan: Plan) -> bool:
    """Whether the firmware keeps `host`'s per-servo state (HPW, HPS, HOF, HTAG) and the motion state
    in the chip's XRAM (the STC89's, MOVX @DPTR in page 0): only where the chip has it and internal
    RAM alone is short (`host_short`). Internal RAM then keeps no STATE (layout.state_base)."""
    return (hosted(plan) and state_may_go_to_xram(plan)
            and host_short(dataclasses.replace(plan, holds=False), False) > 0)


def host_ram_text(plan: Plan, short: int) -> tuple[str, str]:
    """`host-ram`'s message and help: `host` is `short` bytes of internal RAM short."""
    n = len(plan.channels)
    chip = plan.program.target.chip
    xram = host_xram(plan)
    if xram:
        kept = f"its {HOST_XRAM_PER_SERVO * n} bytes of per-servo state are in the {chip.display}'s XRAM"
    else:
        kept = f"{HOST_PER_SERVO} for each of the {n} servos"
    port_ram = 8 if xram else 40        # CUR, and STATE where it is not in XRAM (costs.PORT_RAM)
    hint = (f"use fewer servos, or put them on fewer ports (each port in use takes {port_ram} bytes of internal "
            "RAM), or a shorter frame (a smaller receive queue)")
    if not chip.xram_bytes and not host_short(plan, True):
        hint += "; or an STC89 chip (`target stc89c58rd`), whose XRAM holds the per-servo state"
    ports = len(plan.ports)
    return (f"`host` needs {host_ram(plan)} bytes of internal RAM ({host_vars(plan)} for its parser, a receive "
            f"queue of {host_queue(plan)} bytes, {kept}); with {ports} port{'s' if ports != 1 else ''} of "
            f"servos and the serial line the chip is {short} byte{'s' if short != 1 else ''} short", hint)


XRAM_NEED = 256         # host_xram's XRAM: the host's arrays from 0 (HOST_XRAM_PER_SERVO bytes a servo, at
                        # most 144) and the motion state at its STATE addresses (layout.state_at, up to 0xFF)


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
    if kind == "host":
        return acc + 1          # it runs frame after frame until an event cuts it
    if kind == "hold":
        return acc + st.frames
    if kind == "repeat":
        return acc + st.count * inner
    if kind == "loop":
        return acc + max(1, inner)      # a pass that took no frame waits for one before the next
    return acc + inner


def _fewest_in_code(acc: int, st: Step, inner) -> int:
    if walk.kind(st) == "select":       # the code's own count of `after` is not read by the analysis
        return acc + min(inner, default=0)
    return _fewest(acc, st, inner)


def fewest_frames_in_code(body: tuple[Step, ...], plan: Plan, memo: dict | None = None) -> int:
    """`fewest_frames` as the analysis of the code (wcet) sees it: a select's `after` may come at
    any look, since its count is kept at run time."""
    return walk.fold(body, lambda name: plan.sequence(name).body, 0, _fewest_in_code, memo)


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
        elif kind == "host":
            one = blank.frames(1)
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


TX_MOST = 32            # the longest transmit queue: a run of sends past it is `send-overrun`


def tx_queue(plan: Plan) -> int:
    """The transmit queue's size (a power of two, for its ring's mask): costs.QUEUE, or the
    program's longest run of sends rounded up to a power of two, at most TX_MOST (RAM sized to
    the program: every byte of a run waits in it while the line sends the one before)."""
    from . import costs
    run = send_run(plan) if plan.program.serial is not None else 0
    return min(TX_MOST, max(costs.QUEUE, 1 << max(0, run - 1).bit_length()))


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


def port_motions(plan: Plan, joint: bool = False) -> dict[int, frozenset]:
    """Per port, every way its lines can go through the frames of one move instance: for each line
    of the port in channel order (the order of its sort buffer), a (start, end), or None for a line
    that has no target in those frames (its N stays 0: sorted, never falling). A line the
    move names goes from its start (an N, or a `Reach` after an interruption) to its N, one set at
    once is at its N throughout, and one the move does not name stays where it is (start = end). The
    frames of a move are every frame of the program: holds and waiting selects repeat the last one,
    and before the first move no line has a target (no frame with a fall to count). The power-up
    (`plan.power_up`) switches lines on one move at a time from none: each state it passes through
    is a frame of its own (the move instances start from the state after it). `joint`: every
    line of every port together, under the key 0 (the build whose ports' pulses overlap has one
    timeline for them all)."""
    keys = (0,) if joint else plan.ports
    out: dict[int, set] = {key: set() for key in keys}

    def add(start, ends) -> None:
        lines: dict[int, list] = {key: [] for key in keys}
        for ch in plan.channels:
            end = ends.get(ch.index, start[ch.index])
            lines[0 if joint else ch.port].append(None if end is None else (end if start[ch.index] is None else start[ch.index], end))
        for port, ls in lines.items():
            if any(ls):
                out[port].add(tuple(ls))

    for _, after, _ in _power_up(plan):
        add(after, {})
    for inst in plan.moves:
        add(inst.start, dict(inst.step.targets))
    if hosted(plan):        # the host moves any line anywhere it can go
        reach = tuple(Reach(*host_range(c.servo)) for c in plan.channels)
        add(reach, dict(enumerate(reach)))
    return {port: frozenset(ms) for port, ms in out.items()}


def port_tops(plan: Plan) -> tuple[int, ...]:
    """Per port, in port order, the highest N any of its lines can have in any frame (0: none ever
    has a target): the longest pulse its span must hold (`costs.fit_spans`). Every frame of a move
    lies between its start and its end (`port_motions`; eased curves never overshoot)."""
    return port_reach(plan)[1]


def port_reach(plan: Plan, motions: dict[int, frozenset] | None = None) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Per port, in port order: the lowest N at which any of its lines can fall in any frame (its
    earliest fall, C(bottom) after its rise: `costs.stagger_span`; a line without a target stays at
    N 0 but never falls), and the highest (`port_tops`); 0 where none ever has a target. From the
    ports' motions (`port_motions`, given or found)."""
    motions = port_motions(plan) if motions is None else motions
    low, high = [], []
    for port in plan.ports:
        values = [n for lines in motions[port] for ab in lines if ab is not None for n in ab]
        low.append(min((n if isinstance(n, int) else n.lo for n in values), default=0))
        high.append(max((n if isinstance(n, int) else n.hi for n in values), default=0))
    return tuple(low), tuple(high)


def host_watchers(plan: Plan) -> set[int]:
    """id() of each select whose meanwhile body runs a `host` statement (in it, or in a select, a
    repeat, a loop or a sequence inside it): while the host reads every byte, its look takes none."""
    return {id(st) for st in steps(plan)
            if isinstance(st, SelectStep) and st.meanwhile is not None and _runs_host(plan, st.meanwhile)}


def _runs_host(plan: Plan, body: tuple[Step, ...]) -> bool:
    """Whether `body` can run a `host` statement (in it, or in anything it plays)."""
    work, seen = [body], set()
    while work:
        for st in work.pop():
            if isinstance(st, HostStep):
                return True
            if isinstance(st, PlayStep):
                if st.sequence not in seen:
                    seen.add(st.sequence)
                    work.append(plan.sequence(st.sequence).body)
            else:
                work.extend(walk.blocks(st))
    return False


def hosted(plan: Plan) -> bool:
    """Whether the program runs a `host` statement (the host may move every servo)."""
    return any(isinstance(st, HostStep) for st in steps(plan))


def _power_up(plan: Plan) -> Iterator[tuple[tuple, tuple, MoveStep]]:
    """The power-up's moves with the states they go from and to (per channel an N, or None: no
    target yet): it switches the lines on from none, one move at a time."""
    on: tuple = (None,) * len(plan.channels)
    for st in plan.power_up:
        if isinstance(st, MoveStep):
            after = list(on)
            for ch, n in st.targets:
                after[ch] = n
            yield on, tuple(after), st
            on = tuple(after)


def _starts(plan: Plan) -> Iterator[tuple[tuple, tuple, MoveStep]]:
    """Each start of each move statement the program can reach: the state before it and the move's
    first frame (per channel an N, None: no target yet, or a Reach after an interruption), from
    its instances and the power-up's states."""
    power = {id(st) for st in plan.power_up}
    yield from _power_up(plan)
    for inst in plan.moves:
        if id(inst.step) not in power:
            yield inst.start, inst.first, inst.step


@dataclass(frozen=True)
class AtStart:
    """What holds wherever a move statement starts (`at_start`)."""
    still: frozenset[int]       # the channels already at its target N: they do not move
    on: frozenset[int]          # the channels that have a target
    off: frozenset[int]         # the channels that have none (a line's first target is set at once)


def at_start(plan: Plan) -> dict[int, AtStart]:
    """Per move statement (by id), what every start of it the program can reach has in common.
    Where a line can be anywhere (after an interruption) it is none of `still`, and of `on` only if
    it surely has a target. Nothing for a program with `host` (the host moves the servos)."""
    if hosted(plan):
        return {}
    out: dict[int, AtStart] = {}
    for before, _, step in _starts(plan):
        if len(before) == len(plan.channels):
            # an N equals the target; None (no target yet) and a Reach (after an interruption) do not
            here = AtStart(frozenset(ch for ch, n in step.targets if before[ch] == n),
                           frozenset(ch for ch, v in enumerate(before)
                                     if isinstance(v, int) or (isinstance(v, Reach) and not v.unset)),
                           frozenset(ch for ch, v in enumerate(before) if v is None))
        else:
            here = AtStart(frozenset(), frozenset(), frozenset())
        was = out.get(id(step))
        out[id(step)] = here if was is None else AtStart(was.still & here.still, was.on & here.on, was.off & here.off)
    return out


def move_starts(plan: Plan) -> dict[int, frozenset | None]:
    """Per port, each move's first frame with the frame before it (the last of whatever came before:
    its start): (N before, N in its first frame, the move is eased, its F is found at run time, the
    move statement's id), the
    N per line in channel order, None for a line without a target. None for the port when a move can
    start where one of its lines is not known (after an interruption). The power-up's moves count
    from the states it passes through (`port_motions`)."""
    out: dict[int, set | None] = {port: set() for port in plan.ports}
    lines = {port: [c.index for c in plan.channels if c.port == port] for port in plan.ports}

    def add(before: tuple, first: tuple, step: MoveStep) -> None:
        for port in plan.ports:
            if out[port] is None:
                continue
            pair = (tuple(before[i] for i in lines[port]), tuple(first[i] for i in lines[port]))
            if all(v is None or type(v) is int for half in pair for v in half):
                out[port].add(pair + (step.ease != "linear", step.frames is None, id(step)))
            else:
                out[port] = None

    for before, first, st in _starts(plan):
        add(before, first, st)
    if hosted(plan):        # host moves start wherever the servos are
        out = {port: None for port in plan.ports}
    return {port: None if pairs is None else frozenset(pairs) for port, pairs in out.items()}
