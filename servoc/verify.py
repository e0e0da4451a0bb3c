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

import itertools
from dataclasses import dataclass, field

from .plan import Choice, Decider, expand, UNDECIDED

from .steps import AfterBranch, branch_text, Plan
from .sim import SimTrace
from .costs import QUEUE, rise_offsets
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

    @property
    def ok(self) -> bool:
        return not self.mismatches

    def summary(self) -> str:
        period = "n/a" if self.period_min is None else (
            f"{self.period_min}..{self.period_max} {self.unit} (mean {self.period_mean:.3f})")
        if self.period_min is not None and self.unit != "us":
            period += f" = {self.period_mean * self.cycle_us:.1f} µs"
        sent = "" if self.bytes_sent is None else f", {self.bytes_sent} byte{'s' if self.bytes_sent != 1 else ''} sent checked"
        return (f"{'OK' if self.ok else 'FAILED'}: {self.frames} frames, {self.pulses} pulses checked{sent}, "
                f"max error {self.max_error_cycles} cycles, period {period}, "
                + ("no servo lines" if self.reset_low_cycles is None
                   else f"servo lines low {self.reset_low_cycles} {self.unit} after reset"))


SEARCH_FRAMES = 1_000_000     # how far to look for the first frame that carries a pulse


def first_pulse_frame(plan: Plan, choices: tuple = ()) -> int | None:
    """0-based index of the first golden frame with a pulse, or None if there is none."""
    for i, fr in enumerate(itertools.islice(expand(plan, choices), SEARCH_FRAMES)):
        if any(n is not None for n in fr.n):
            return i
    return None


def cycles_needed(plan: Plan, frames: int) -> int:
    """Machine cycles to simulate so that `frames` frames after the first pulse are complete."""
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
    port_offset = rise_offsets(plan.ports, target)
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
                            cycle_us=float(target.cycle_us))
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
    spans = [(r[-1] - r[0], len(r) - 1) for r in rises_by_channel.values() if len(r) > 1]
    mean = (sum(s for s, _ in spans) / sum(k for _, k in spans)) if spans else None
    return VerifyReport(len(golden), checked, max_err, min(diffs) if diffs else None,
                        max(diffs) if diffs else None, mean, reset_low, tuple(mismatches), unit, sent,
                        float(target.cycle_us))


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
        if got != b:
            out.append(Mismatch(frame, "send", "TXD", None, None, f"sent {_show(got)} where {_show(b)} was due"))
        elif abs(when - at) > 2 * period:
            out.append(Mismatch(frame, "send", "TXD", None, None,
                                f"byte {_show(b)} started {when - at:+d} cycles from its frame's rise, more than 2 P"))
    for when, got in trace.sent[len(due):]:
        if when + 2 * period <= end:
            out.append(Mismatch(round((when - t1) / period) + 1, "send", "TXD", None, None,
                                f"sent {_show(got)}, which the plan does not send"))
    return out, checked


def _show(b: int) -> str:
    return f'"{chr(b)}"' if 32 < b < 127 and chr(b) not in "\\\"" else str(b)


# ---------------------------------------------------------------- runs with events

def _first_bad(report: VerifyReport) -> int:
    frames = [m.frame for m in report.mismatches if m.frame >= 1]
    return min(frames) if frames else report.frames + 1


def first_rise_us(plan: Plan, trace: SimTrace) -> float | None:
    """The first frame's rise of the first port, from reset, in µs (None: no pulse)."""
    target = plan.program.target
    offsets = rise_offsets(plan.ports, target)
    firsts = [ps[0][0] - offsets[c.port] for c in plan.channels if (ps := trace.pulses(c.port, c.bit))]
    return None if not firsts else float(min(firsts) * target.cycle_us)


def selects_reached(plan: Plan, choices: tuple, frames: int) -> tuple[int, list]:
    """(the first pulse's frame, the selects reached as (frames before it, select)) of the run
    `choices` make, up to one select past them or `frames` frames from the first pulse."""
    reached: list = []
    lead = first_pulse_frame(plan, choices) or 0
    for _ in itertools.islice(expand(plan, choices, reached), lead + frames):
        if len(reached) > len(choices):
            break
    return lead, reached


def infer_choices(plan: Plan, trace: SimTrace, frames: int, limit: int = 200,
                  events: list | None = None) -> tuple[tuple, VerifyReport]:
    """The branch the firmware took at each select, found from the trace: select by select, in
    the order reached, the choice (branch, frames waited) whose golden frames match the trace the
    furthest; between choices that match as far (two branches can make the same pulses), one
    whose input was active by then. Returns the choices and the report for them."""
    t1 = first_rise_us(plan, trace) if events else None
    arrivals = _arrivals(plan, events or [])
    if t1 is not None:
        modelled = model_choices(plan, trace, frames, events, t1)
        if modelled is not None:
            return modelled

    def plausible(select, cand, start, lead) -> bool:
        branch = select.branches[cand.branch]
        if t1 is None or isinstance(branch, AfterBranch):
            return True
        begins = t1 + (start + cand.frames - lead) * plan.period_us
        return any(at <= begins for at in _occurrences(branch, events, arrivals))

    choices: tuple = ()
    report = verify(plan, trace, frames, choices)
    for _ in range(limit):
        if report.ok:
            break
        bad = _first_bad(report)
        lead, reached = selects_reached(plan, choices, frames)
        if len(reached) <= len(choices):
            break                               # no select left to decide: a real mismatch
        start, select = reached[len(choices)]
        waited = max(0, lead + bad - 1 - start)
        cands = [Choice(k, w) for k, br in enumerate(select.branches) if not isinstance(br, AfterBranch)
                 for w in range(max(0, waited - 3), waited + 2)
                 if select.after is None or w <= max(1, select.after.frames)]
        if select.after is not None:
            cands.append(Choice(len(select.branches) - 1, max(1, select.after.frames)))
        best = None
        for cand in cands:
            r = verify(plan, trace, frames, choices + (cand,))
            key = (_first_bad(r), plausible(select, cand, start, lead), -abs(cand.frames - waited))
            if best is None or key > best[0]:
                best = (key, cand, r)
        if best is not None and not best[0][1]:
            # The best fit has no event behind it: a branch whose first frames change nothing can
            # look like waiting longer. Look further back for one that has.
            for k, br in enumerate(select.branches):
                if isinstance(br, AfterBranch) or t1 is None:
                    continue
                near: set[int] = set()          # a frame or three after each time its event came
                for at in _occurrences(br, events, arrivals):
                    first = int((at - t1) / plan.period_us) + lead - start
                    near.update(w for w in range(first - 1, first + 4) if 1 <= w < max(1, waited - 3))
                for w in sorted(near):
                    cand = Choice(k, w)
                    if not plausible(select, cand, start, lead):
                        continue
                    r = verify(plan, trace, frames, choices + (cand,))
                    key = (_first_bad(r), True, -abs(w - waited))
                    if key[0] >= best[0][0] and key > best[0]:
                        best = (key, cand, r)
        if best is None or best[0][0] < bad:
            break
        choices, report = choices + (best[1],), best[2]
    return choices, report


PHASES = 64     # where in the frame the firmware may look at its inputs: tried at P/64 apart


def _arrivals(plan: Plan, events: list) -> list[tuple[float, int]]:
    """(µs from reset its stop bit ends, byte) of each byte the host sends, in order."""
    from .events import byte_arrivals
    serial = plan.program.serial
    if serial is None:
        return []
    return byte_arrivals(events, byte_cycles(serial.th1, serial.smod), plan.program.target)


class _EventDecider(Decider):
    """What the firmware decides at each select when it looks at its events at a fixed phase of
    the frame: right after each frame_io returns (the select's own wait, or frame_w during a
    meanwhile body: the outer select first), and once as it is reached. Bytes queue up as they
    arrive (QUEUE at the most) whether a select waits or not; a look drops the oldest bytes no
    `on` names (none with `on other`), then takes the first `on` whose event is there: an input
    active, an edge between the sample before and this one, the oldest byte if an `on` names it,
    or (`on other`) any other byte; `after` at its F-th frame. Records the choices in the order
    the selects are reached."""

    def __init__(self, plan: Plan, events: list, arrivals: list, t1: float, phase: float, lead: int) -> None:
        self.plan, self.t1, self.phase, self.lead = plan, t1, phase, lead
        self.arrivals = arrivals
        self.came = 0
        self.queue: list[int] = []
        self.by_input: dict[str, list] = {}
        for e in events:
            if e.input is not None:
                self.by_input.setdefault(e.input, []).append(e)
        self.choices: list = []

    def at(self, frames: int) -> float:
        return self.t1 + (frames - 1 - self.lead) * self.plan.period_us + self.phase

    def active(self, name: str, t: float) -> bool:
        state = False
        for e in self.by_input.get(name, ()):
            if float(e.time_us) > t:
                break
            state = e.active
        return state

    def reach(self, select, frames: int):
        self.choices.append(None)
        inputs = {b.event.input for b in select.branches if not isinstance(b, AfterBranch) and b.event.edge}
        return {"select": select, "index": len(self.choices) - 1,
                "prev": {name: self.active(name, self.at(frames)) for name in inputs}}

    def look(self, token, j: int, frames: int) -> int | None:
        select, t = token["select"], self.at(frames)
        while self.came < len(self.arrivals) and self.arrivals[self.came][0] <= t:
            if len(self.queue) < QUEUE:
                self.queue.append(self.arrivals[self.came][1])
            self.came += 1
        ons = [(k, br.event) for k, br in enumerate(select.branches) if not isinstance(br, AfterBranch)]
        named = {ev.byte for _, ev in ons if ev.byte is not None}
        other = any(ev.other for _, ev in ons)
        while self.queue and not other and self.queue[0] not in named:
            self.queue.pop(0)                   # no `on` waits for it: dropped
        now = {name: self.active(name, t) for name in token["prev"]}
        pick = None
        for k, ev in ons:
            if ev.input is not None and ev.edge is None:
                hit = self.active(ev.input, t)
            elif ev.input is not None:
                want = ev.edge == "press"
                hit = now[ev.input] == want and token["prev"][ev.input] != want
            elif ev.other:
                hit = bool(self.queue) and self.queue[0] not in named
            else:
                hit = bool(self.queue) and self.queue[0] == ev.byte
            if hit:
                if ev.input is None:
                    self.queue.pop(0)
                pick = k
                break
        if pick is None and select.after is not None and j == select.after.frames:
            pick = len(select.branches) - 1
        token["prev"] = now
        if pick is not None:
            self.choices[token["index"]] = Choice(pick, j)
        return pick

    def decided(self) -> tuple:
        out = [c if c is not None else Choice(0, UNDECIDED) for c in self.choices]
        while out and out[-1].frames >= UNDECIDED:
            out.pop()
        return tuple(out)


def model_choices(plan: Plan, trace: SimTrace, frames: int, events: list, t1: float) -> tuple | None:
    """The choices the firmware makes if it looks at its events once a frame at a fixed phase
    (`_EventDecider`), found in one run of the golden model per phase. The phase is not known
    here, so each of PHASES phases is tried; the first whose run matches the trace exactly is
    returned (None: none does)."""
    arrivals = _arrivals(plan, events)
    tried: set = set()
    lead = first_pulse_frame(plan) or 0
    for step in range(PHASES):
        phase = plan.period_us * step / PHASES
        for _ in range(2):          # once more if the choices move the first pulse
            decider = _EventDecider(plan, events, arrivals, t1, phase, lead)
            for _ in itertools.islice(expand(plan, decider), lead + frames + 2):
                pass
            choices = decider.decided()
            now = first_pulse_frame(plan, choices) or 0
            if now == lead:
                break
            lead = now
        if choices in tried:
            continue
        tried.add(choices)
        report = verify(plan, trace, frames, choices)
        if report.ok:
            return choices, report
    return None


def _waited(choices: tuple) -> int:
    """The frames the decided choices wait, in all."""
    return sum(c.frames for c in choices if c.frames < UNDECIDED)


@dataclass(frozen=True)
class _Take:
    """A select the run reached and the branch it took (times in µs from reset)."""
    select: object
    branch: object
    waits: float                # the select began to wait (the first rise of the frame it was reached in)
    begins: float               # the branch's first rise
    frame: int                  # that frame, from the first pulse (1-based)
    waited: int                 # frames of waiting


def _takes(plan: Plan, choices: tuple, t1_us: float) -> list[_Take]:
    lead, reached = selects_reached(plan, choices, _waited(choices) + 100_000)
    return [_Take(select, select.branches[choice.branch], t1_us + (start - lead) * plan.period_us,
                  t1_us + (start + choice.frames - lead) * plan.period_us, start + choice.frames - lead + 1, choice.frames)
            for (start, select), choice in zip(reached, choices) if choice.frames < UNDECIDED]


def _occurrences(branch, events: list, arrivals: list) -> list[float]:
    """Each time the event of an `on` branch happened: its input becoming active, or its byte arriving."""
    ev = branch.event
    if ev.input is not None:
        active = ev.edge != "release"
        return [float(e.time_us) for e in events if e.input == ev.input and e.active == active]
    return [at for at, b in arrivals if ev.other or b == ev.byte]


def _event_times(take: _Take, events: list, arrivals: list, bytes_taken: dict) -> list[float]:
    """When the event of an `on` branch taken happened before it began: its input becoming active,
    or the byte it took arriving."""
    if take.branch.event.input is not None:
        return [at for at in _occurrences(take.branch, events, arrivals) if at <= take.begins]
    return [arrivals[bytes_taken[id(take)]][0]] if id(take) in bytes_taken else []


def _bytes_taken(takes: list[_Take], arrivals: list) -> dict[int, int]:
    """id(take) -> index in `arrivals` of the byte each `on "x"` or `on other` taken took. The queue
    is first in, first out, and a byte a select looked at and did not take is gone: each take took
    the first byte after the one taken before it that it names (`on other`: that its select's other
    `on`s do not name)."""
    out: dict[int, int] = {}
    first = 0
    for take in takes:
        ev = getattr(take.branch, "event", None)
        if ev is None or ev.input is not None:
            continue
        named = {b.event.byte for b in take.select.branches if not isinstance(b, AfterBranch) and not b.event.other}
        k = next((k for k in range(first, len(arrivals)) if arrivals[k][0] <= take.begins
                  and (arrivals[k][1] not in named if ev.other else arrivals[k][1] == ev.byte)), None)
        if k is not None:
            out[id(take)] = k
            first = k + 1
    return out


def event_delays(plan: Plan, choices: tuple, events: list, t1_us: float) -> list[tuple[str, float, float | None]]:
    """For each `on` branch taken: (its event as written, its first rise from reset in µs, the µs
    from its event (its input becoming active, its byte's stop bit), or from the select beginning
    to wait if the event came before, to that rise; None when no event came before it).
    `t1_us`: the first frame's rise."""
    out = []
    arrivals = _arrivals(plan, events)
    takes = _takes(plan, choices, t1_us)
    bytes_taken = _bytes_taken(takes, arrivals)
    for take in takes:
        if isinstance(take.branch, AfterBranch):
            continue
        came = _event_times(take, events, arrivals, bytes_taken)
        out.append((take.branch.event.text, take.begins, take.begins - max(came[-1], take.waits) if came else None))
    return out


def check_event_delays(plan: Plan, choices: tuple, events: list, t1_us: float | None) -> list[str]:
    """Each `on` branch taken must start within 2 P of its input becoming active, or of the select
    beginning to wait if the input was active already (the spec's sampling rule): the problems
    found, as text. `t1_us`: the first frame's rise, from reset."""
    if t1_us is None:
        return []
    problems: list[str] = []
    for text, begins, delay in event_delays(plan, choices, events, t1_us):
        if delay is None:
            problems.append(f"`on {text}` taken at {begins / 1000:.3f} ms with no event before it")
        elif delay > 2 * plan.period_us:
            problems.append(f"`on {text}` started {delay / 1000:.3f} ms after its event, more than 2 P")
    return problems


# ---------------------------------------------------------------- what happened in a run with events

@dataclass(frozen=True)
class Reaction:
    """A select reached in the run, and what it did."""
    line: int                   # the select's line in the source (0: unknown)
    frame: int                  # the first frame of the branch, from the first pulse (1-based)
    time_us: float              # that frame's first rise, from reset
    branch: str                 # as written: `on "w"`, `on button`, `after 2s`
    event: str                  # what chose it: `"w" arrived at 1.234 s`, `button active at ...`, `no event`
    waited: int                 # frames the select waited

    def __str__(self) -> str:
        at = f"line {self.line}: " if self.line else ""
        return (f"{at}select took `{self.branch}` at frame {self.frame} ({self.time_us / 1e6:.4f} s), "
                f"after {self.waited} frame{'s' if self.waited != 1 else ''} of waiting: {self.event}")


def reactions(plan: Plan, choices: tuple, events: list, t1_us: float | None, line_of=None) -> list[Reaction]:
    """Each select the run reached, in order, with the branch it took and the event behind it."""
    if t1_us is None:
        return []
    arrivals = _arrivals(plan, events)
    takes = _takes(plan, choices, t1_us)
    bytes_taken = _bytes_taken(takes, arrivals)
    out = []
    for take in takes:
        branch = take.branch
        if isinstance(branch, AfterBranch):
            why = "no event came"
        else:
            came = _event_times(take, events, arrivals, bytes_taken)
            ev = branch.event
            what = ("a byte no other `on` names arrived" if ev.other else f"byte {ev.text} arrived"
                    if ev.input is None else f"`{ev.input}` {'inactive' if ev.edge == 'release' else 'active'}")
            why = f"{what} at {came[-1] / 1e6:.4f} s" if came else "no event before it"
        line = 0 if line_of is None else line_of(take.select.span)
        out.append(Reaction(line, take.frame, take.begins, branch_text(branch), why, take.waited))
    return out


def unseen(plan: Plan, choices: tuple, events: list, t1_us: float | None, end_us: float) -> list[str]:
    """Events of the run no select took: an input's activation while no select waited for it, a
    byte no `on` took (dropped, or still queued at the end). Events after `end_us` are not counted."""
    if t1_us is None:
        return []
    takes = [t for t in _takes(plan, choices, t1_us) if not isinstance(t.branch, AfterBranch)]
    out: list[str] = []
    window = 2 * plan.period_us
    for name in sorted({e.input for e in events if e.input is not None}):
        changes = [e for e in events if e.input == name]
        for k, e in enumerate(changes):
            if not e.active or float(e.time_us) > end_us:
                continue
            off = next((float(x.time_us) for x in changes[k + 1:] if not x.active), end_us)
            if not any(t.branch.event.input == name and float(e.time_us) <= t.begins <= off + window for t in takes):
                out.append(f"`{name}` active from {float(e.time_us) / 1e6:.4f} s to {off / 1e6:.4f} s: "
                           "no select took it (none was waiting for it then)")
    arrivals = _arrivals(plan, events)
    used = set(_bytes_taken(takes, arrivals).values())
    for k, (t, b) in enumerate(arrivals):
        if k not in used and t <= end_us:
            out.append(f"byte {_show(b)} (arrived at {t / 1e6:.4f} s) was taken by no select: dropped (no `on` of the "
                       "select that looked at it named it, or the queue was full) or still queued when the run ended")
    return out


def settle_frame(plan: Plan, choices: tuple) -> int | None:
    """The frame, from the first pulse, at which the run that `choices` make is waiting at a select
    no choice decides (every branch taken has run to its end); None when it never gets there (a
    branch that loops forever, or main ends first: then its last frame)."""
    lead, reached = selects_reached(plan, choices, _waited(choices) + 100_000)
    if len(reached) > len(choices):
        return reached[len(choices)][0] - lead + 1
    return None


# ---------------------------------------------------------------- how long a run is

MAX_SPAN_CYCLES = 60_000_000    # the longest run verify makes unless asked: 60 s at 12 MHz, about
                                # 16 s of ucsim on the machine the tests run on
SETTLE_MARGIN = 3               # frames after the last branch ends: its last bytes are out within 2 P


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
    from .plan import verify_frames
    target = plan.program.target
    period = target.cycles(plan.period_us)
    lead = first_pulse_frame(plan) or 0
    notes: list[str] = []
    if asked:
        frames = limit = asked
    else:
        limit = max(1, MAX_SPAN_CYCLES // period - lead - 2)
        frames = verify_frames(plan)
        if plan.total_frames is not None and plan.total_frames + 1 > limit:
            notes.append(f"the program runs {plan.total_frames} frames ({plan.total_frames * plan.period_us / 1e6:.1f} s); "
                         f"verify checks the first {limit} ({limit * plan.period_us / 1e6:.1f} s): use --frames N "
                         "for more (ucsim runs some 4 million machine cycles a second)")
        if events:
            last = max(float(e.time_us) for e in events)
            frames = max(frames, int((last + 2_000_000) / plan.period_us) + 1)
        frames = min(frames, limit)
    applied = list(events or [])
    if events:
        end_us = (lead + frames) * plan.period_us
        applied = [e for e in events if float(e.time_us) < end_us]
        if len(applied) < len(events):
            later = len(events) - len(applied)
            notes.append(f"{later} event{'s' if later != 1 else ''} at or after {end_us / 1e6:.3f} s, the end of the "
                         f"{frames} frames checked: not applied" + ("" if asked else " (use --frames N for a longer run)"))
    return RunSpan(frames, limit, applied, tuple(notes))


def verify_settle(plan: Plan, choices: tuple) -> int | None:
    """`settle_frame`: the frame by which everything the events started has run."""
    return settle_frame(plan, choices)
