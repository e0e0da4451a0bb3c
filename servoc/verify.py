"""Verification: Plan x SimTrace -> VerifyReport.

The golden frames of `plan.expand` are compared with the pulses ucsim
recorded, pulse for pulse: frame 1 is the first frame that carries a pulse;
frame j of port p rises at T1 + (j - 1) P + the port's offset. Every expected
pulse must be there with exactly 500 + 8 N cycles, N the value the firmware
computes (on an eased move's intermediate frames it reads its curve table;
that N must in turn lie within one N of the language's curve), no pulse may appear where the plan has none, every rise must
be within the allowed jitter of its slot, servo lines must go low within 20
cycles of reset, and pins that are not servos (on any port, P3 included)
must never change.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass, field

from . import layout
from .observe import Observation, Visit
from .flow import hosted, host_queue, host_watchers
from .plan import Choice, HostRun, ListDecider, expand, UNDECIDED
from .steps import AfterBranch, LoopStep, OnBranch, PlayStep, RepeatStep, SelectStep, branch_text, Plan
from .sim import CLOCKS_PER_CYCLE, TICKS_WRAP, SimTrace
from .target import byte_cycles
RESET_LOW_US = 20          # servo lines low this soon after reset
MAX_JITTER_US = 2          # a rise may stand this far from its frame slot


@dataclass(frozen=True)
class Mismatch:
    frame: int
    servo: str
    pin: str
    expected_us: int | None
    measured_us: int | None
    what: str

    def __str__(self) -> str:
        exp = "none" if self.expected_us is None else f"{self.expected_us} cycles"
        got = "none" if self.measured_us is None else f"{self.measured_us} cycles"
        return f"frame {self.frame}, {self.servo} ({self.pin}): expected {exp}, measured {got}: {self.what}"


@dataclass(frozen=True)
class VerifyReport:
    frames: int
    pulses: int
    max_error_cycles: int
    period_min: int | None
    period_max: int | None
    period_mean: float | None
    reset_low_cycles: int | None        # latest first-low of a servo line after reset
    mismatches: tuple[Mismatch, ...] = field(default=())
    unit: str = "us"                    # what a machine cycle is called in the summary ("us" at 1 µs)
    bytes_sent: int | None = None       # bytes sent checked (None: the program has no serial line)
    cycle_us: float = 1.0               # one machine cycle in µs, for the summary's µs
    reactions: tuple = ()               # with events: each select reached and what it took (Reaction)
    warnings: tuple = ()                # with events: events no select took, as text
    unchecked: tuple = ()               # what the run did not check, as text
    period_cycles: int = 0              # the planned frame period, in machine cycles
    ended: str = ""                     # where the program was when the run ended

    @property
    def ok(self) -> bool:
        return not self.mismatches

    @property
    def span_s(self) -> float:
        """The time the frames checked span, in seconds."""
        return self.frames * self.period_cycles * self.cycle_us / 1e6

    def verdict(self) -> str:
        """OK, OK (partial: ...) or FAILED."""
        if not self.ok:
            return "FAILED"
        if self.unchecked:
            n = len(self.unchecked)
            return f"OK (partial: {n} thing{'s' if n != 1 else ''} not checked, listed below)"
        return "OK"

    def summary(self) -> str:
        period = "n/a" if self.period_min is None else (
            f"{self.period_min}..{self.period_max} {self.unit} (mean {self.period_mean:.3f})")
        if self.period_min is not None and self.unit != "us":
            period += f" = {self.period_mean * self.cycle_us:.1f} µs"
        sent = "" if self.bytes_sent is None else f", {self.bytes_sent} byte{'s' if self.bytes_sent != 1 else ''} sent checked"
        return (f"{self.verdict()}: {self.frames} frames ({self.span_s:.3f} s), {self.pulses} pulses checked{sent}, "
                f"max error {self.max_error_cycles} cycles, period {period}, "
                + ("no servo lines" if self.reset_low_cycles is None
                   else f"servo lines low {self.reset_low_cycles} {self.unit} after reset"))


SEARCH_FRAMES = 1_000_000     # how far to look for the first frame that carries a pulse


_FIRST_PULSE: dict = {}     # (id(plan), choices) -> (plan, the answer): the search can take seconds


HLINE_QUEUING = layout.HLINE["VERQ"].mask | layout.HLINE["ANSQ"].mask   # host.asm.j2's HLINE: the reading goes on
HLINE_WAITS = layout.HLINE["HANS"].mask      # the answers waiting for room fill their queue

class _Still(Exception):
    """A select waits forever with no meanwhile body: its frames repeat the targets as they are."""


class _UntilStill(ListDecider):
    """`choices` as `expand` takes them, until a select that will wait forever with no meanwhile
    body is reached while no select reached before has a branch to take (one could cut the wait
    from around it): before the first pulse no servo has a target, so none comes after it."""

    def __init__(self, choices) -> None:
        super().__init__(choices)
        self.taking = False         # some select reached has a branch to take

    def reach(self, select: SelectStep, frames: int):
        token = super().reach(select, frames)
        self.taking = self.taking or token is not None
        if token is None and select.meanwhile is None and not self.taking:
            raise _Still
        return token


def first_pulse_frame(plan: Plan, choices: tuple = ()) -> int | None:
    """0-based index of the first golden frame with a pulse, or None if there is none."""
    key = (id(plan), tuple(choices))
    hit = _FIRST_PULSE.get(key)
    if hit is not None and hit[0] is plan:
        return hit[1]
    found = None
    try:        # (with `host`, a line the host sends can end a sequence waiting at a select: no early end)
        decider = ListDecider(choices) if hosted(plan) else _UntilStill(choices)
        for i, fr in enumerate(itertools.islice(expand(plan, decider), SEARCH_FRAMES)):
            if any(n is not None for n in fr.n):
                found = i
                break
    except _Still:
        pass
    if len(_FIRST_PULSE) > 64:
        _FIRST_PULSE.clear()
    _FIRST_PULSE[key] = (plan, found)
    return found


def cycles_needed(plan: Plan, frames: int, choices: tuple = ()) -> int:
    """Machine cycles to simulate so that `frames` frames after the first pulse are complete (the
    selects deciding `choices`)."""
    try:
        lead = first_pulse_frame(plan, choices) or 0
    except ValueError:                      # no run of the program (verify says so)
        lead = first_pulse_frame(plan) or 0
    target = plan.program.target
    return (lead + frames + 2) * target.cycles(plan.period_us) + target.cycles(5000)


def driven_pins(plan: Plan, trace: SimTrace, driven: tuple | None) -> list[Mismatch]:
    """The firmware drives nothing but its servo lines. The trace records a port's pins as the
    firmware's writes leave them (its latch and what drives the pin from outside): a pin that is no
    servo and no input must never change; an input's pin must read at each write what `driven`
    (the (cycle, port, outside level) changes ucsim made, as `api.Stimulus.pins`) put on it: a
    latch written to 0 would hold it low (None: input pins are not checked)."""
    out: list[Mismatch] = []
    servo_pins = {(s.port, s.bit) for s in plan.program.servos}
    inputs = {(i.port, i.bit): i for i in plan.program.inputs}
    for port in range(4):           # P0-P3, ports without any servo included
        for bit in range(8):
            if (port, bit) in servo_pins:
                continue
            edges = trace.pin_edges(port, bit)
            if (port, bit) not in inputs:
                if edges:
                    out.append(Mismatch(0, "-", f"P{port}.{bit}", None, None, "a pin that is not a servo changed"))
                continue
            if driven is None:
                continue
            outside = [(at, (level >> bit) & 1) for at, p, level in driven if p == port]
            for at, level in ((w.cycle, (w.value >> bit) & 1) for w in trace.port_writes(port)):
                # what was driven on it up to this write (ucsim may make a change a few cycles late)
                could = {lv for c, lv in outside if at - DRIVE_SLACK <= c <= at}
                could.add(next((lv for c, lv in reversed(outside) if c <= at - DRIVE_SLACK), 1))
                if level not in could:
                    out.append(Mismatch(0, inputs[(port, bit)].name, f"P{port}.{bit}", None, None,
                                        f"input pin read {level} at cycle {at}, but it was driven "
                                        f"{1 - level} from outside: the firmware wrote its latch"))
                    break
    return out


DRIVE_SLACK = 8     # cycles a change of an input pin may come late in ucsim (api.simulate retries)


def verify(plan: Plan, trace: SimTrace, frames: int, choices: tuple = (), driven: tuple | None = None) -> VerifyReport:
    """Compare `frames` frames from the first pulse with what the simulation recorded (at each
    select, the branch `choices` give, in the order the selects are reached; see plan.expand).
    `driven`: the changes of the input pins' outside levels ucsim made (see `driven_pins`); None
    leaves the input pins unchecked."""
    mismatches: list[Mismatch] = []
    lead = first_pulse_frame(plan, choices)
    golden = [] if lead is None else list(itertools.islice(expand(plan, choices), lead, lead + frames))
    target = plan.program.target
    port_offset = plan_rise_offsets(plan)
    reset_limit = int(RESET_LOW_US / target.cycle_us)
    unit = "us" if target.grid else "cycles"
    max_jitter = int(MAX_JITTER_US / target.cycle_us)
    pulses = {c.index: trace.pulses(c.port, c.bit) for c in plan.channels}

    resets = [trace.first_low(s.port, s.bit) for s in plan.program.servos]
    reset_low = None if any(r is None for r in resets) or not resets else max(resets)
    for s, r in zip(plan.program.servos, resets):
        if r is None or r > reset_limit:
            mismatches.append(Mismatch(0, s.name, s.pin, None, None,
                                       f"line not driven low within {RESET_LOW_US} us of reset"))
    mismatches += driven_pins(plan, trace, driven)

    firsts = [(ps[0][0] - port_offset[plan.channels[ch].port]) for ch, ps in pulses.items() if ps]
    if not golden or not firsts:
        if golden:
            mismatches.append(Mismatch(1, "-", "-", None, None, "no pulse at all"))
        return VerifyReport(0, 0, 0, None, None, None, reset_low, tuple(mismatches), unit,
                            cycle_us=float(target.cycle_us), period_cycles=target.cycles(plan.period_us))
    t1 = min(firsts)
    period = target.cycles(plan.period_us)
    checked, max_err = 0, 0
    rises_by_channel: dict[int, list[int]] = {}
    for ch in plan.channels:
        slots: dict[int, tuple[int, int]] = {}
        for rise, width in pulses[ch.index]:
            j = round((rise - t1 - port_offset[ch.port]) / period) + 1
            if 1 <= j <= len(golden):
                if j in slots:
                    mismatches.append(Mismatch(j, ch.name, ch.servo.pin, None, width, "two pulses in one frame"))
                slots[j] = (rise, width)
        for j, fr in enumerate(golden, start=1):
            n = fr.n[ch.index]
            got = slots.get(j)
            exp_us = None if n is None else target.width_cycles(n)
            if n is None:
                if got:
                    mismatches.append(Mismatch(j, ch.name, ch.servo.pin, None, got[1], "pulse before any target"))
                continue
            if got is None:
                mismatches.append(Mismatch(j, ch.name, ch.servo.pin, exp_us, None, "pulse missing"))
                continue
            rise, width = got
            checked += 1
            err = width - exp_us
            slot_err = rise - (t1 + port_offset[ch.port] + (j - 1) * period)
            max_err = max(max_err, abs(err))
            if err:
                mismatches.append(Mismatch(j, ch.name, ch.servo.pin, exp_us, width, f"width off by {err} cycles"))
            if abs(n - fr.curve[ch.index]) > 1:
                mismatches.append(Mismatch(j, ch.name, ch.servo.pin, exp_us, width,
                                           f"the firmware's N {n} is more than one N off the curve's {fr.curve[ch.index]}"))
            if abs(slot_err) > max_jitter:
                mismatches.append(Mismatch(j, ch.name, ch.servo.pin, exp_us, width,
                                           f"rise {slot_err:+d} cycles from its frame slot"))
            rises_by_channel.setdefault(ch.index, []).append(rise)
    sent_bad, sent = _check_sent(plan, trace, choices, lead, len(golden), t1)
    mismatches += sent_bad
    diffs = [b - a for rises in rises_by_channel.values() for a, b in zip(rises, rises[1:])
             if round((b - a) / period) == 1]
    spans = [(run[-1] - run[0], len(run) - 1) for rises in rises_by_channel.values()
             for run in _runs(rises, period) if len(run) > 1]      # a line switched off (P0) splits its runs
    mean = (sum(s for s, _ in spans) / sum(k for _, k in spans)) if spans else None
    return VerifyReport(len(golden), checked, max_err, min(diffs) if diffs else None,
                        max(diffs) if diffs else None, mean, reset_low, tuple(mismatches), unit, sent,
                        float(target.cycle_us), period_cycles=period)


def _runs(rises: list[int], period: int) -> list[list[int]]:
    """A line's rises split where a frame has none (its pulses were switched off): the runs of
    rises a frame apart, over which the mean period is taken."""
    runs = [rises[:1]]
    for a, b in zip(rises, rises[1:]):
        if round((b - a) / period) == 1:
            runs[-1].append(b)
        else:
            runs.append([b])
    return runs


def _check_sent(plan: Plan, trace: SimTrace, choices: tuple, lead: int, frames: int,
                t1: int) -> tuple[list[Mismatch], int | None]:
    """The bytes sent must be the plan's, in order, each starting within 2 P of the first rise of
    the frame that follows the statements before its `send`. Bytes due in the last 2 P of the
    run may still be queued when it ends."""
    if plan.program.serial is None:
        return [], None
    period = plan.program.target.cycles(plan.period_us)
    due = [(t1 + (i - lead) * period, b) for i, fr in
           enumerate(itertools.islice(expand(plan, choices), lead + frames)) for b in fr.sent]
    end = t1 + (frames - 1) * period
    serial = plan.program.serial
    line = byte_cycles(serial.th1, serial.smod)
    out: list[Mismatch] = []
    checked = 0
    for k, (at, b) in enumerate(due):
        frame = round((at - t1) / period) + 1
        if k >= len(trace.sent):
            if at + 2 * period <= end:
                checked += 1
                out.append(Mismatch(frame, "send", "TXD", None, None, f"byte {_show(b)} was not sent"))
            continue
        checked += 1
        when, got = trace.sent[k]
        # the byte before it still going out at its frame's rise: it starts once that byte has ended
        free = max(at, trace.sent[k - 1][0] + line) if k else at
        if got != b:
            out.append(Mismatch(frame, "send", "TXD", None, None, f"sent {_show(got)} where {_show(b)} was due"))
        elif not (at - 2 * period <= when <= free + 2 * period):
            out.append(Mismatch(frame, "send", "TXD", None, None,
                                f"byte {_show(b)} started {when - at:+d} cycles from its frame's rise"
                                + ("" if free == at else f" ({when - free:+d} from the end of the byte before it)")
                                + ", more than 2 P"))
    for when, got in trace.sent[len(due):]:
        if when + 2 * period <= end:
            out.append(Mismatch(round((when - t1) / period) + 1, "send", "TXD", None, None,
                                f"sent {_show(got)}, which the plan does not send"))
    return out, checked


def _show(b: int) -> str:
    return f'"{chr(b)}"' if 32 < b < 127 and chr(b) not in "\\\"" else str(b)


# ---------------------------------------------------------------- runs with events, observed

def plan_rise_offsets(plan: Plan) -> dict[int, int]:
    """Per port, cycles from the first port's rise to its own, as the firmware generated for `plan`
    has them (`Plan.rise_offsets`; a plan the period stage did not see gets the code's again)."""
    offsets = plan.rise_offsets
    if len(offsets) != len(plan.ports):
        from . import codegen
        offsets = codegen.generate(plan).rise_offsets
    return dict(zip(plan.ports, offsets))


def first_rise(plan: Plan, trace: SimTrace) -> int | None:
    """The first frame's rise of the first port, in machine cycles from reset (None: no pulse)."""
    offsets = plan_rise_offsets(plan)
    firsts = [ps[0][0] - offsets[c.port] for c in plan.channels if (ps := trace.pulses(c.port, c.bit))]
    return min(firsts) if firsts else None


def first_rise_us(plan: Plan, trace: SimTrace) -> float | None:
    """`first_rise` in µs."""
    t1 = first_rise(plan, trace)
    return None if t1 is None else t1 * float(plan.program.target.cycle_us)


CUT = UNDECIDED + 1     # Choice.frames of a select cut short while it waited (in a meanwhile body)


def choices_of(obs: Observation) -> tuple[Choice, ...]:
    """The branch each select took, in the order reached, as `plan.expand` takes them: the look
    that took it (0: as it was reached) is the number of frames it waited; a select still waiting
    when the run ended waits for ever."""
    out = []
    for v in obs.visits:
        if v.branch is None or not v.looks:
            out.append(Choice(0, CUT if v.cut else UNDECIDED))
            continue
        waited = len(v.looks) - 1
        if v.select.after is not None:          # a firmware that waited past `after` (a look checks that):
            waited = min(waited, v.select.after.frames)     # the plan of the run waits no longer
        out.append(Choice(v.branch, waited))
    return tuple(out) + tuple(HostRun(tuple(tuple(got) for _, _, got in h.frames)) for h in obs.hosts)


@dataclass(frozen=True)
class HostByte:
    """A byte the host sent: the cycle its stop bit ends, the byte, the events file's line."""
    arrives: int
    byte: int
    line: int = 0


def host_bytes(plan: Plan, trace: SimTrace, events: list) -> list[HostByte]:
    """Every byte the host sent in the run, from the UART windows ucsim opened (`trace.uart`)."""
    serial = plan.program.serial
    if serial is None or not trace.uart:
        return []
    from .events import window_starts
    per = byte_cycles(serial.th1, serial.smod)
    sent = [(b, getattr(ev, "line", 0)) for ev in events if getattr(ev, "data", None) is not None for b in ev.data]
    return [HostByte(on + (k + 1) * per, b, line)
            for (on, k), (b, line) in zip(window_starts(trace.uart, per), sent)]


class _Levels:
    """The outside level of each input over the run, as ucsim made it (`trace.inputs`)."""

    def __init__(self, plan: Plan, trace: SimTrace) -> None:
        self.inputs = {i.name: i for i in plan.program.inputs}
        self.changes: dict[str, list[tuple[int, bool]]] = {}
        for name, inp in self.inputs.items():
            out: list[tuple[int, bool]] = []
            for at, port, level in trace.inputs:
                if port == inp.port:
                    active = bool((level >> inp.bit) & 1) == inp.active_high
                    if not out or out[-1][1] != active:
                        out.append((at, active))
            self.changes[name] = out

    def during(self, name: str, lo: int, hi: int) -> set[bool]:
        """Whether the input was active, at any cycle from `lo` to `hi`."""
        now, out = False, set()
        for at, active in self.changes.get(name, ()):
            if at <= lo:
                now = active
            elif at <= hi:
                out.add(active)
        out.add(now)
        return out

    def since(self, name: str, active: bool, at: int) -> int | None:
        """The last cycle at or before `at` the input became `active` (None: never)."""
        found = None
        for c, a in self.changes.get(name, ()):
            if c > at:
                break
            if a == active:
                found = c
        return found


def _rule(select, j: int, queue: tuple[int, ...], now, prev, depth: int) -> set[tuple[int | None, int]]:
    """What a look may decide by the rules: a set of (the branch taken or None, the bytes it takes
    from the queue). `j`: the look's number (0 as the select is reached); `queue`: the bytes
    queued (None: the look reads none, a `host` statement in its meanwhile body does);
    `now(name)` / `prev(name)`: the input's possible states at this look's sample and the one
    before; `depth`: the most bytes one look drops (the queue's size)."""
    if queue is None:
        queue, depth = (), 0
    ons = [(k, b.event) for k, b in enumerate(select.branches) if not isinstance(b, AfterBranch)]
    named = {ev.byte for _, ev in ons if ev.byte is not None}
    other = any(ev.other for _, ev in ons)
    drop = 0
    if not named and not other:
        drop = len(queue)               # no `on` names a byte: every byte is dropped
    elif not other:
        while drop < len(queue) and drop < depth and queue[drop] not in named:
            drop += 1                   # the oldest bytes no `on` names
    head = queue[drop] if drop < len(queue) and (other or queue[drop] in named) else None
    out: set[tuple[int | None, int]] = set()
    for k, ev in ons:
        if ev.input is None:
            hit = head is not None and (head not in named if ev.other else head == ev.byte)
            status = {hit}
            took = drop + 1
        else:
            want = ev.edge != "release"
            if ev.edge is None:
                status = {a == want for a in now(ev.input)}
            else:
                status = {a == want and b != want for a in now(ev.input) for b in prev(ev.input)}
            took = drop
        if True in status:
            out.add((k, took))
        if False not in status:
            return out
    after = select.after
    if after is not None and j >= after.frames:
        out.add((len(select.branches) - 1, drop))
    else:
        out.add((None, drop))
    return out


def _enqueued(obs: Observation) -> list[int]:
    """Queue position (bytes queued before it) -> index of the byte among those received."""
    return [i for i, got in enumerate(obs.received) if got.queued]


def _spoiled(obs: Observation, marks: bool) -> dict[int, int]:
    """With `host` (`marks`), a byte that finds the receive queue full is lost and the newest byte
    queued becomes 0xFF (serial_isr.asm.j2), so that the line it was in is bad, not read with
    bytes missing: received byte index -> the cycle from which its slot holds 0xFF."""
    out: dict[int, int] = {}
    newest = None
    for i, got in enumerate(obs.received):
        if got.queued:
            newest = i
        elif marks and newest is not None:
            out.setdefault(newest, got.cycle)
    return out


@dataclass(frozen=True)
class Taken:
    """A branch a select took: the visit, the first rise of the branch's first frame (None: no
    pulse in the run to time it by), the cycle of its event (None: none, as for `after`) and
    what the event was, as text."""
    visit: Visit
    rise: int | None
    event: int | None
    why: str


def branches_taken(plan: Plan, trace: SimTrace, obs: Observation, events: list) -> list[Taken]:
    """Every branch the firmware took, in the order taken, with its event: the byte it took (its
    stop bit's end) or its input's last change to the state it waits for before the look."""
    target = plan.program.target
    period = target.cycles(plan.period_us)
    t1 = first_rise(plan, trace)
    sent = host_bytes(plan, trace, events)
    enqueued = _enqueued(obs)
    levels = _Levels(plan, trace)
    out = []
    for visit in sorted((v for v in obs.visits if v.branch is not None), key=lambda v: v.taken):
        look = visit.looks[-1] if visit.looks else None
        branch = visit.select.branches[visit.branch]
        rise = None if t1 is None else t1 - ((t1 - visit.taken) // period) * period
        event, why = None, "no event came"
        if isinstance(branch, OnBranch) and look is not None:
            ev = branch.event
            if ev.input is None:
                pos = look.rxr_after - 1
                host = sent[enqueued[pos]] if 0 <= pos < len(enqueued) and enqueued[pos] < len(sent) else None
                why = "no byte taken"
                if host is not None:
                    event = host.arrives
                    why = (f"byte {_show(host.byte)} arrived at {host.arrives * target.cycle_us / 1e6:.4f} s"
                           + (f" (events line {host.line})" if host.line else ""))
            else:
                active = ev.edge != "release"
                event = levels.since(ev.input, active, look.exit or look.entry)
                why = (f"`{ev.input}` {'active' if active else 'inactive'}"
                       + ("" if event is None else f" at {event * target.cycle_us / 1e6:.4f} s"))
        out.append(Taken(visit, rise, event, why))
    return out


def event_delays(plan: Plan, trace: SimTrace, events: list) -> list[tuple[str, float, float | None]]:
    """For each `on` branch the firmware took (a run simulated with probes): (its event as written,
    its first rise from reset in µs, the µs from its event, or from the select being reached if
    the event came before, to that rise; None when there is no event to time it from)."""
    cycle = float(plan.program.target.cycle_us)
    return [(t.visit.select.branches[t.visit.branch].event.text, t.rise * cycle,
             None if t.event is None else (t.rise - max(t.event, t.visit.reached)) * cycle)
            for t in branches_taken(plan, trace, trace.observation, events)
            if isinstance(t.visit.select.branches[t.visit.branch], OnBranch) and t.rise is not None]


def _text(select, k: int | None) -> str:
    return "to wait on" if k is None else f"`{branch_text(select.branches[k])}`"


@dataclass(frozen=True)
class Reaction:
    """A select reached in the run, and what it did (times in machine cycles from reset)."""
    line: int                   # the select's line in the source (0: unknown)
    frame: int                  # the first frame of the branch, from the first pulse (1-based)
    cycle: int                  # that frame's first rise
    branch: str                 # as written: `on "w"`, `on button`, `after 2s`
    event: str                  # what chose it: `"w" arrived at 1.234 s`, `button active at ...`, `no event`
    waited: int                 # frames the select waited
    cycle_us: float = 1.0       # a machine cycle in µs

    @property
    def time_us(self) -> float:
        return self.cycle * self.cycle_us

    def __str__(self) -> str:
        at = f"line {self.line}: " if self.line else ""
        return (f"{at}select took `{self.branch}` at frame {self.frame} ({self.time_us / 1e6:.4f} s), "
                f"after {self.waited} frame{'s' if self.waited != 1 else ''} of waiting: {self.event}")


@dataclass
class RunCheck:
    """What `check_run` found: problems (the firmware's), reactions, warnings."""
    problems: list[Mismatch] = field(default_factory=list)
    reactions: list[Reaction] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def check_run(plan: Plan, trace: SimTrace, obs: Observation, frames: int, events: list,
              line_of=None) -> tuple[tuple[Choice, ...], VerifyReport]:
    """Check a run from what the firmware did (`obs`): every look decided what the rules require
    for what had come by then (a byte queued, an input's level at its sample and the sample
    before, `after` at its F-th look; where something changed during a look, either is right),
    took the bytes the rules say, and every byte the host sent was received and queued unless
    the queue was full; every `on` branch began within 2 P of its event; and the pulses and
    bytes sent are the plan of the branches taken (`verify`). `line_of(span)`: a span's line."""
    target = plan.program.target
    period = target.cycles(plan.period_us)
    choices = choices_of(obs)
    try:
        report = verify(plan, trace, frames, choices, driven=trace.inputs or None)
        lead = first_pulse_frame(plan, choices) or 0
    except ValueError as exc:               # the selects reached are not the plan's: no plan of this run
        report = VerifyReport(0, 0, 0, None, None, None, None, (Mismatch(
            0, "select", "-", None, None, f"the branches the firmware took are no run of the program: {exc}"),),
            cycle_us=float(target.cycle_us), period_cycles=target.cycles(plan.period_us))
        return choices, report
    t1 = first_rise(plan, trace)
    end = trace.cycles if t1 is None else min(trace.cycles, t1 + frames * period)
    line = (lambda span: 0) if line_of is None else line_of
    found = RunCheck([Mismatch(0, "select", "-", None, None, p) for p in obs.problems])
    levels = _Levels(plan, trace)
    sent = host_bytes(plan, trace, events)
    queue = host_queue(plan)
    watchers = host_watchers(plan)              # selects whose looks leave the bytes to `host`

    def when(c: int) -> str:
        return f"{c * target.cycle_us / 1e6:.4f} s"

    def frame_of(c: int) -> int:
        return 0 if t1 is None else (c - t1) // period + 1

    def bad(c: int, what: str) -> None:
        found.problems.append(Mismatch(max(0, frame_of(c)), "select", "-", None, None, what))

    # `host`: each frame's reading read every byte that had come before it began, unless a line
    # that stops the reading was read (docs/host-protocol.md), or an answering line (Q, QP, VER)
    # whose answer has to wait for room, in this frame or before (HLINE bits 4 and 6, until host_step
    # sends it), or it read as many as a frame's reading reads. After a group line it stops only
    # before a byte the parser stalls at (the next reading's first), or after a line dropped.
    if obs.hosts:
        from . import ssc32
        from .flow import host_passes, host_xram, reads_answers
        from .model import host_channel
        passes = host_passes(plan)
        xram = host_xram(plan)
        servos = {host_channel(c.servo): None for c in plan.channels}
        for h in obs.hosts:
            parser = ssc32.LineParser(layout.host_holds(plan), not xram, reads_answers(plan))
            waiting, held, played = False, 0, False
            readings = list(zip(h.frames, h.ends))
            for k, ((cycle, _, got), ended) in enumerate(readings):
                stopped = answered = grouped = overread = dropped = False
                named: frozenset[int] = frozenset()         # the channels the frame's group names
                parser.commit()                             # a reading starts with no group waiting
                for b in got:
                    watch = ssc32.group_waiting(named, servos, xram, parser.holds)
                    if grouped and not overread and (dropped or parser.stalls(b, watch)):
                        overread = True
                        why = ("after a line dropped after a group line in the same frame" if dropped else
                               "after a group line in the same frame, a byte the reading stops before while a group "
                               "waits")
                        bad(cycle, f"the host parser read {_show(b)} at {when(cycle)} {why}")
                    cmd = parser.feed(b, watch if grouped else None)
                    stopped = stopped or ssc32.stops_reading(cmd, servos, ended.playing)
                    if isinstance(cmd, ssc32.Group) and ssc32.stops_reading(cmd, servos):
                        grouped, named = True, named | ssc32.named(cmd, servos)
                    dropped = dropped or (grouped and parser.dropped)
                    answered = answered or isinstance(cmd, (ssc32.Query, ssc32.QueryPulse, ssc32.Version))
                after = readings[k + 1][0][2] if k + 1 < len(readings) else []
                if (grouped and not dropped and ended.left and len(got) < passes and after
                        and not ended.hline & HLINE_WAITS        # (the queue of answers full stops it too)
                        and not parser.stalls(after[0], ssc32.group_waiting(named, servos, xram, parser.holds))):
                    bad(cycle, f"the host parser stopped reading at {when(cycle)} after a group line, before "
                               f"{_show(after[0])}, a byte it reads on to")
                stops = ended.hline & ~HLINE_QUEUING
                waits = ended.hline & HLINE_WAITS
                # a line that stops the reading while a sequence `PL` started plays waits, its bit
                # set, until host_step carries it out: the frames of the sequence and the one after
                carried = (played or ended.playing) and not stops & ~held
                if stops and not stopped and not (waits and (answered or waiting)) and not carried:
                    bad(cycle, f"the host parser stopped reading at {when(cycle)} (lines pending {ended.hline:#x}) "
                               "with no line that stops it")
                waiting, held, played = bool(waits), stops, ended.playing
                if ended.left and not stops and len(got) < passes:
                    bad(cycle, f"the host parser left {ended.left} byte{'s' if ended.left != 1 else ''} unread at "
                               f"{when(cycle)} that had come before that frame's reading began")

    # The plan reaches the selects in the order the firmware did.
    reached: list = []
    for _ in itertools.islice(expand(plan, choices, reached), lead + frames):
        pass
    for (_, want), visit in zip(reached, obs.visits):
        if want.span != visit.select.span:
            bad(visit.reached, f"the firmware reached the select at line {line(visit.select.span)} where the plan "
                               f"reaches the one at line {line(want.span)}")
            break

    # Each byte the host sent, as the serial handler received it.
    spoiled = _spoiled(obs, marks=hosted(plan))     # empty with no byte dropped, or without `host`
    enqueued = _enqueued(obs)                   # queue position -> index into `sent`
    for i, got in enumerate(obs.received):
        if i >= len(sent):
            bad(got.cycle, f"the serial handler received byte {_show(got.byte)} at {when(got.cycle)}, which the "
                           "host never sent")
            break
        host = sent[i]
        if got.byte != host.byte:
            bad(got.cycle, f"the serial handler received {_show(got.byte)} where the host sent {_show(host.byte)}")
        if not got.queued and got.queued_before < queue:
            bad(got.cycle, f"byte {_show(host.byte)} (arrived at {when(host.arrives)}) was dropped with only "
                           f"{got.queued_before} queued: the queue holds {queue}")
        elif not got.queued:
            why = (f"lost: the receive queue already held {queue} bytes not yet read, so the line it was in is "
                   "dropped as a bad line (docs/host-protocol.md, Timing)" if spoiled else
                   f"dropped: the queue already held {queue} bytes no select had taken")
            found.warnings.append(f"byte {_show(host.byte)} (arrived at {when(host.arrives)}) was {why}")
    per = 0 if plan.program.serial is None else byte_cycles(plan.program.serial.th1, plan.program.serial.smod)
    for host in sent[len(obs.received):]:
        if host.arrives + per < trace.cycles:
            bad(host.arrives, f"byte {_show(host.byte)} (arrived at {when(host.arrives)}) was never received")

    def rises(a: int, b: int) -> int:           # frames that began after cycle a, up to b
        return (b - t1) // period - (a - t1) // period

    # Each look decided what the rules require, one frame after the look before it.
    for visit in obs.visits:
        sel = visit.select
        where = line(sel.span)
        for j, look in enumerate(visit.looks):
            if t1 is not None:
                n = rises(visit.reached if j == 0 else visit.looks[j - 1].entry, look.entry)
                if n != (j > 0):
                    bad(look.entry, f"the select at line {where} made look {j} at {when(look.entry)} {n} frame"
                                    f"{'s' if n != 1 else ''} after "
                                    + ("it was reached, not in the same frame" if j == 0 else "the look before, not 1"))
            if look.exit is None:
                continue                        # the run ended during it
            new = [0xFF if spoiled.get(i, look.exit) < look.exit else got.byte
                   for i, got in enumerate(obs.received) if look.entry < got.cycle < look.exit and got.queued]
            before = visit.looks[j - 1] if j else None
            lo_prev, hi_prev = (visit.reached, look.entry) if before is None else (before.entry, before.exit or before.entry)
            allowed: set = set()
            for extra in range(len(new) + 1):
                allowed |= _rule(sel, j, None if id(sel) in watchers or look.playing else look.queue + tuple(new[:extra]),
                                 lambda n: levels.during(n, look.entry, look.exit),
                                 lambda n: levels.during(n, lo_prev, hi_prev), queue)
            took = look.rxr_after - look.rxr
            if (look.outcome, took) not in allowed:
                want = sorted({_text(sel, k) for k, _ in allowed})
                what = ("" if plan.program.serial is None else
                        f", queued {' '.join(_show(b) for b in look.queue) or 'nothing'}")
                bad(look.entry, f"the select at line {where}, look {j} at {when(look.entry)}{what}: the firmware "
                                f"decided {_text(sel, look.outcome)}"
                                + (f" and took {took} byte{'s' if took != 1 else ''}" if plan.program.serial else "")
                                + f", the rules require {' or '.join(want)}")
            if look.outcome is not None:
                break
        if visit.branch is not None and visit.looks and visit.looks[-1].outcome not in (None, visit.branch):
            bad(visit.taken, f"the select at line {where} decided {_text(sel, visit.looks[-1].outcome)} but ran "
                             f"{_text(sel, visit.branch)}")

    # Each branch taken: its event, and its first frame within 2 P of it.
    for took in branches_taken(plan, trace, obs, events):
        sel, branch = took.visit.select, took.visit.select.branches[took.visit.branch]
        if took.rise is not None and took.event is not None:
            delay = took.rise - max(took.event, took.visit.reached)
            if delay > 2 * period:
                bad(took.rise, f"`{branch_text(branch)}` of the select at line {line(sel.span)} began "
                               f"{delay * target.cycle_us / 1000:.3f} ms after its event at {when(took.event)}, "
                               f"more than 2 P ({2 * period} cycles)")
        found.reactions.append(Reaction(line(sel.span), frame_of(took.rise) if took.rise is not None else 0,
                                        took.visit.taken if took.rise is None else took.rise, branch_text(branch),
                                        took.why, len(took.visit.looks) - 1, float(target.cycle_us)))

    # What the run did not use: bytes dropped or still queued, inputs no look saw.
    parsed = {r + k for h in obs.hosts for _, r, got in h.frames for k in range(len(got))}   # read by `host`
    for pos, i in enumerate(enqueued):
        host = sent[i]
        if pos in parsed:
            continue
        taker = next((v for v in obs.visits for lk in v.looks if lk.rxr <= pos < lk.rxr_after), None)
        if taker is None:
            found.warnings.append(f"byte {_show(host.byte)} (arrived at {when(host.arrives)}) was still queued when "
                                  "the run ended")
        elif not any(lk.rxr_after - 1 == pos and lk.outcome is not None
                     and isinstance(taker.select.branches[lk.outcome], OnBranch)
                     and taker.select.branches[lk.outcome].event.input is None for lk in taker.looks):
            found.warnings.append(f"byte {_show(host.byte)} (arrived at {when(host.arrives)}) was dropped by the "
                                  f"select at line {line(taker.select.span)}: none of its `on`s names it")
    def waited(v) -> int | None:
        """Until when a select waited: the branch taken, its last look where a select around it cut
        it short, or None: it waited on when the run ended."""
        if v.taken is not None:
            return v.taken
        if v.cut:
            return (v.looks[-1].exit or v.looks[-1].entry) if v.looks else v.reached
        return None

    for name in sorted(levels.changes):
        changes = levels.changes[name]
        for k, (at, active) in enumerate(changes):
            if not active or at >= end:
                continue
            off = changes[k + 1][0] if k + 1 < len(changes) else end
            waiting = [v for v in obs.visits if v.reached <= off and (waited(v) is None or waited(v) >= at)
                       and any(isinstance(b, OnBranch) and b.event.input == name for b in v.select.branches)]
            saw = any(lk.entry <= off and (lk.exit or lk.entry) >= at for v in waiting for lk in v.looks)
            def decided(v) -> bool:         # the look that took the branch saw this press
                look, br = v.looks[-1], v.select.branches[v.branch]
                return (isinstance(br, OnBranch) and br.event.input == name
                        and (look.entry <= off and (look.exit or look.entry) >= at
                             or br.event.edge == "release" and look.entry >= off))
            took = any(v.branch is not None and v.looks and decided(v) for v in waiting)
            if took:
                continue
            span = f"`{name}` active from {when(at)} to {when(off)}"
            if not waiting:
                found.warnings.append(f"{span}: no select was waiting for it then")
            elif not saw:
                found.warnings.append(f"{span}: shorter than a frame, it fell between two looks of the select at "
                                      f"line {line(waiting[0].select.span)} (presses are sampled once a frame)")
    report = dataclasses.replace(report, mismatches=report.mismatches + tuple(found.problems),
                                 reactions=tuple(sorted(found.reactions, key=lambda r: r.cycle)),
                                 warnings=tuple(found.warnings))
    return choices, report


def coverage(plan: Plan, choices: tuple, frames: int, line_of=None, text_of=None) -> tuple[list[str], str]:
    """What a run of `frames` frames from the first pulse, the selects deciding `choices`, did
    not reach: (each statement never started, each branch never taken, each loop that completed
    no pass, as text; where the program was at the end)."""
    line = (lambda span: 0) if line_of is None else line_of
    show = (lambda span: "") if text_of is None else text_of
    seen: dict = {}
    reached: list = []
    last = None
    try:
        lead = first_pulse_frame(plan, choices) or 0
        for last in itertools.islice(expand(plan, choices, reached, seen), lead + frames):
            pass
    except ValueError:                      # no run of the program (verify says so): nothing to list
        return [], ""
    out: list[str] = []
    walked: set[str] = set()

    def say(span, what: str) -> None:
        text = show(span)
        out.append(f"line {line(span)}: {what}" + (f" (`{text}`)" if text else ""))

    def walk(body) -> None:
        for st in body:
            if id(st) not in seen:
                say(st.span, "never reached")
                continue
            if isinstance(st, LoopStep):
                if seen[id(st)] == 0:
                    say(st.span, "a loop whose first pass did not end in the span checked")
                walk(st.body)
            elif isinstance(st, RepeatStep):
                walk(st.body)
            elif isinstance(st, PlayStep) and st.sequence not in walked:
                walked.add(st.sequence)
                walk(plan.sequence(st.sequence).body)
            elif isinstance(st, SelectStep):
                if st.meanwhile is not None:
                    walk(st.meanwhile)
                for br in st.branches:
                    if id(br) not in seen:
                        say(br.span, f"`{branch_text(br)}` never taken")
                    else:
                        walk(br.body)

    walk(plan.main)
    picks = [c for c in choices if isinstance(c, Choice)]
    waiting = [sel for i, (_, sel) in enumerate(reached) if i < len(picks) and picks[i].frames == UNDECIDED]
    if waiting:
        sel = waiting[-1]
        ends = ", ".join(f"`{branch_text(b)}`" for b in sel.branches)
        ended = f"waiting at the select at line {line(sel.span)} for {ends}"
    elif "main ended" in seen:
        ended = "main had ended: its last targets repeat"
    elif last is not None:
        ended = f"at line {line(last.span)}" + (f" (`{show(last.span)}`)" if show(last.span) else "")
    else:
        ended = "before its first frame"
    return out, ended


def settle_frame(plan: Plan, choices: tuple) -> int | None:
    """The frame, from the first pulse, at which the run that `choices` make waits at a select
    again after the last branch taken (the first select no choice decides, or that was still
    waiting when the run ended); None when it never gets there (a branch that loops forever, or
    main ends first)."""
    if any(isinstance(c, HostRun) for c in choices):
        return None                     # `host` runs on: the span is the events' and 2 s more
    stop = next((i for i, c in enumerate(choices) if c.frames == UNDECIDED), len(choices))
    decided = tuple(choices[:stop])
    waited = sum(c.frames for c in decided if c.frames < UNDECIDED)
    reached: list = []
    try:
        lead = first_pulse_frame(plan, decided) or 0
        for _ in itertools.islice(expand(plan, decided, reached), lead + waited + 100_000):
            if len(reached) > stop:
                return reached[stop][0] - lead + 1
    except ValueError:                      # no run of the program (verify says so)
        pass
    return None


# ---------------------------------------------------------------- how long a run is

MAX_SPAN_CYCLES = 60_000_000    # the longest run verify makes unless asked: 60 s at 12 MHz, about
                                # 16 s of ucsim on the machine the tests run on
SETTLE_MARGIN = 3               # frames after the last branch ends: its last bytes are out within 2 P


def max_frames(plan: Plan) -> int:
    """The most frames from the first pulse a run can check: its clock ticks stay below ucsim's
    32-bit counter (sim.TICKS_WRAP; ucsim's core takes sim.CLOCKS_PER_CYCLE ticks a machine cycle in
    6T mode too: about 358 s at 12 MHz, 179 s at 11.0592 MHz 6T), the frames before the first pulse
    and two more included."""
    period = plan.program.target.cycles(plan.period_us)
    return max(1, (TICKS_WRAP - 1) // CLOCKS_PER_CYCLE // period - (first_pulse_frame(plan) or 0) - 2)


@dataclass(frozen=True)
class RunSpan:
    """What one `servoc verify` run checks: `frames` from the first pulse (at most `limit`), the
    `events` applied (those inside the run), and `notes` on what it leaves out."""
    frames: int
    limit: int
    events: list
    notes: tuple = ()


def verify_span(plan: Plan, asked: int | None, events: list | None) -> RunSpan:
    """The frames a verify run checks: `asked` (--frames) if given; else the whole program and a
    tail, or up to its loop and two passes (`plan.verify_frames`), or, with events, on past the
    last event until every branch an event chose has run to its end (`settle_frame`, found after
    a run) - never more than MAX_SPAN_CYCLES of simulation, and it says what it leaves out."""
    from .events import ByteEvent, EventsError, bytes_through
    from .plan import verify_frames
    target = plan.program.target
    period = target.cycles(plan.period_us)
    lead = first_pulse_frame(plan) or 0
    notes: list[str] = []

    def secs(frames: int) -> str:
        return f"{frames * period * target.cycle_us / 1e6:.1f} s"

    if not plan.channels:
        notes.append("the program drives no servo line: with no pulse to time its frames by, verify checks "
                     "none of its timing (holds, `after`, sends, selects)")
    sending = [e for e in events or () if isinstance(e, ByteEvent)]
    serial = plan.program.serial
    through = 0 if not sending or serial is None else bytes_through(sending, byte_cycles(serial.th1, serial.smod), target)
    if asked:
        frames = limit = asked
        if plan.total_frames is not None and plan.total_frames > asked:
            notes.append(f"the program runs {plan.total_frames} frames ({secs(plan.total_frames)}); verify checked the "
                         f"first {asked} ({secs(asked)}, --frames)")
    else:
        limit = max(1, MAX_SPAN_CYCLES // period - lead - 2)
        frames = verify_frames(plan)
        if plan.total_frames is not None and plan.total_frames + 1 > limit:
            notes.append(f"the program runs {plan.total_frames} frames ({secs(plan.total_frames)}); "
                         f"verify checks the first {limit} ({secs(limit)}): use --frames N "
                         "for more (ucsim runs some 4 million machine cycles a second)")
        if events:
            last = max([target.cycles(e.time_us) for e in events] + [through])
            frames = max(frames, (last + target.cycles(2_000_000)) // period + 1)
        frames = min(frames, limit)
    if events:
        end = (lead + frames) * period
        more = ": ask for more with --frames" if asked else f": verify runs at most {secs(limit)} of the program"
        for e in events:
            if target.cycles(e.time_us) >= end:
                raise EventsError(getattr(e, "line", 0),
                                  f"this event at {float(e.time_us) / 1e6:g} s comes after the {frames} frames verify "
                                  f"runs ({end * target.cycle_us / 1e6:.3f} s){more}")
        if through >= end:
            raise EventsError(sending[-1].line,
                              f"the bytes sent go on until {through * target.cycle_us / 1e6:.3f} s, after the {frames} "
                              f"frames verify runs ({end * target.cycle_us / 1e6:.3f} s){more}")
    return RunSpan(frames, limit, list(events or []), tuple(notes))


def verify_settle(plan: Plan, choices: tuple) -> int | None:
    """`settle_frame`: the frame by which everything the events started has run."""
    return settle_frame(plan, choices)
