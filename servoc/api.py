"""One function per stage boundary; the CLI and the tests call only these.

    SourceFile --parse--> nodes.Program --check--> model.Program --plan--> Plan
    Plan --period (the shortest P read from the code generated for it)--> Plan, its period fixed
    Plan --lint--> diagnostics              (lint only reads)
    Plan --generate--> AsmUnit --assemble--> Firmware --simulate--> SimTrace
    Plan x SimTrace --verify--> VerifyReport

Every stage takes a Reporter for user mistakes; the driver stops after a
stage that reported errors. Internal bugs stay ordinary exceptions.
"""

from __future__ import annotations

import dataclasses
import gc
import os
from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction

from . import check as _check
from . import codegen, costs, layout, lint as _lint, syntax, toolchain
from . import plan as _plan
from . import observe as _observe
from . import sim as _sim
from . import verify as _verify
from .diagnostics import Reporter, limit_diagnostic
from .source import NO_SPAN, SourceFile, Span
from .flow import hosted, send_run
from .steps import HoldStep, MoveStep, Plan, steps
from .units import round_half_up
from .target import CHIPS, DEFAULT as DEFAULT_TARGET, Target, byte_cycles

SimError = _sim.SimError

ToolNotFound = toolchain.ToolNotFound
write_atomic = toolchain.write_atomic


class UsageError(Exception):
    """A problem with how servoc was called (exit status 2)."""


@dataclass(frozen=True)
class FrontEnd:
    source: SourceFile
    tree: object | None
    program: object | None
    plan: Plan | None


@dataclass(frozen=True)
class Firmware:
    unit: codegen.AsmUnit
    image: toolchain.HexImage
    rom_bytes: int            # code memory used (bytes the HEX defines), tables included: the sum of
    runtime_bytes: int        # the runtime routines,
    program_bytes: int        # the program's native control flow,
    data_bytes: int           # move records, curve tables, maps and frames-needed tables,
    startup_bytes: int = 0    # and the reset and interrupt vectors and the reset code before the runtime

    @property
    def hex_text(self) -> str:
        return self.image.hex_text


def read_bytes(path: str, what: str) -> bytes:
    """A file's bytes. Raises UsageError (naming `what` it should have been) when it cannot be read."""
    if os.path.isdir(path):
        raise UsageError(f"{path}: is a directory, not {what}")
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as exc:
        raise UsageError(f"{path}: {exc.strerror or exc}") from None


def load_source(path: str) -> tuple[SourceFile, Reporter]:
    """Read a .servo file. Raises UsageError when it cannot be read at all."""
    data = read_bytes(path, "a .servo file")
    source, bad = SourceFile.from_bytes(path, data)
    reporter = Reporter(source)
    if bad is not None:
        at = len(data[:bad].decode("utf-8", errors="replace"))
        reporter.error("invalid-utf8", "the file is not valid UTF-8 text", Span(at, at + 1),
                       help="save the file as UTF-8 (plain ASCII is fine)")
    return source, reporter


def parse(source: SourceFile, reporter: Reporter):
    """Text -> syntax tree (nodes.Program), or None after syntax errors."""
    return syntax.parse(source, reporter)


def check(tree, reporter: Reporter):
    """Syntax tree -> model.Program (names, units, limits resolved), or None after errors."""
    return _check.check(tree, reporter, reporter.source.path)


def plan(program, reporter: Reporter) -> Plan:
    """model.Program -> Plan (frame period, steps with frame counts, move instances), its period
    fixed by the period stage (`choose_period`)."""
    with _stage():
        return choose_period(program, _plan.plan(program, reporter))


_built: list | None = None      # the builds of the period stage under way (`_stage`): (plan as a key, code)


@contextmanager
def _stage():
    """A period stage: the code generated for a plan is kept until it ends, and an equal plan
    (but for `min_period_us` and `period_is_default`, which code generation does not read) gets
    it back (the searches meet the same periods; `_least_fitting` runs the stage again)."""
    global _built
    outer = _built
    if outer is None:
        _built = []
    try:
        yield
    finally:
        if outer is None:
            _built = None


def _generate(p: Plan) -> codegen.AsmUnit:
    """`codegen.generate(p)`, or, within a period stage, the code it generated for an equal plan."""
    if _built is None:
        return codegen.generate(p)
    key = dataclasses.replace(p, min_period_us=0, period_is_default=False)
    for k, unit in _built:
        if (k.period_us, k.compact, k.holds, k.first_step) == (key.period_us, key.compact, key.holds, key.first_step) \
                and k == key:
            return unit
    unit = codegen.generate(p)
    _built.append((key, unit))
    return unit


RAM_LIMITS = frozenset({"ram-overflow", "too-deep", "host-ram"})     # a firmware the internal RAM cannot hold


def choose_period(program, first: Plan, decide: bool = True, least: bool = True) -> Plan:
    """The period stage: the plan with `min_period_us`, the shortest period the code generated for
    it holds (costs.py, read by wcet.py). Without `frame`, P is the default: the plan is made again
    at that minimum (never below 5.3 ms) until it no longer changes, since F, and with it the code,
    depends on P. It also decides the build once for every command: when the firmware built for
    speed does not fit the chip's code memory, the plan is the one built for speed without
    `first_step` (a linear move's pins set up and first stepped in two passes: a longer period,
    less code), and when that does not fit either, the one built for size (`compact`);
    where the firmware fits internal RAM or code memory only without the host's holds and reading
    on through answer lines (`layout.host_extras`), it is built without them (`Plan.holds`; where
    it fits internal RAM neither way, the build without them says how short it is).
    `decide` False: the build `first` asks for, whether it fits or not. `least` False: no search
    below the code's own shortest period for one at which the firmware still fits (eased moves)."""
    result = _periods(program, first)
    if decide and result.firmware_limit is not None and layout.host_extras(result) and \
            {limit[0] for limit in result.firmware_limit} <= RAM_LIMITS:
        smaller = _periods(program, dataclasses.replace(first, holds=False))      # the holds' bytes of
        if smaller.firmware_limit is None or \
                {limit[0] for limit in smaller.firmware_limit} <= RAM_LIMITS:    # internal RAM were short (or
            result = smaller                                                      # more: say the least short)
    fast = decide and not result.compact and result.firmware_limit is None and _overflow(result)
    if fast and _two_passes_smaller(result):
        result = _periods(program, dataclasses.replace(first, first_step=False))
    if fast and (result.firmware_limit is not None or _overflow(result)):
        result = _periods(program, dataclasses.replace(first, compact=True))
        if result.firmware_limit is None:
            over = _overflow(result)       # built for size, still too big: lint says so, as compile
            if over and layout.host_extras(result):    # without the host's holds, if that fits
                smaller = _periods(program, dataclasses.replace(first, compact=True, holds=False))
                if smaller.firmware_limit is None and not _overflow(smaller):
                    result, over = smaller, None
            if over:
                result = dataclasses.replace(result, firmware_limit=(("rom-overflow", *over, NO_SPAN, ()),))
    if least and decide and result.firmware_limit is None and result.min_period_us < result.period_us and _eased(result):
        least = _least_fitting(program, first, result)
        if least != result.min_period_us:
            result = dataclasses.replace(result, min_period_us=least)
    return result


def _plan_at(program, period: int) -> Plan:
    """The program planned at `period`, whatever its own `frame` (a candidate for the shortest)."""
    return _plan.plan(dataclasses.replace(program, frame_us=None), None, period)


def _two_passes_smaller(p: Plan) -> bool:
    """Whether the build for speed without `first_step` can have less code than the one generated
    for `p`: where that lays out both the one call and the two passes (`AsmUnit.both_passes`)."""
    try:
        return _unit(p).both_passes
    except layout.LayoutError:
        return False


def _unit(p: Plan) -> codegen.AsmUnit:
    """The code generated for `p`: the one `_budgeted` generated, where `p` is the plan it returned
    (the fields it sets are read from that code, not by code generation)."""
    last = _last_budgeted
    return last[1] if last is not None and last[0] is p else _generate(p)


def _built_as(p: Plan, like: Plan) -> Plan:
    """`p` with the build `like` has (for size, with the host's holds, with `first_step`)."""
    return dataclasses.replace(p, compact=like.compact, holds=like.holds, first_step=like.first_step)


def _eased(p: Plan) -> bool:
    """Whether the program has an eased move: its curve tables (a byte a frame) grow as P shrinks."""
    return any(isinstance(st, MoveStep) and st.ease != "linear" for st in steps(p))


def _least_fitting(program, first: Plan, at: Plan) -> int:
    """The shortest period to report where the firmware's size follows P (eased curve tables, a
    byte a frame): the least P, from `at`'s shortest on, at which `frame P` builds (for speed or
    for size) and holds P. `at` (its own P) builds; between the two, by bisection."""
    def builds(p: int) -> bool:
        asked = dataclasses.replace(_built_as(_plan_at(program, p), first), period_is_default=False)
        got = choose_period(program, asked, least=False)
        return got.firmware_limit is None and got.min_period_us <= p

    lo, hi = at.min_period_us, at.period_us
    if builds(lo):
        return lo
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if builds(mid) else (mid, hi)
    return hi


def _overflow(p: Plan) -> tuple[str, str] | None:
    """The rom-overflow message and help when the firmware generated for `p` does not fit the
    chip's code memory, else None: it fits when the size read from the text says so
    (`layout.rom_end`); else the assembler lays it out for the message (without the toolchain:
    taken to fit, as nothing can be built then)."""
    try:
        unit = _unit(p)
    except layout.LayoutError:
        return None                         # a resource limit: reported as such, whatever the build
    if unit.fits_code():
        return None
    chip = unit.target.chip
    try:
        image = toolchain.assemble(unit.text, name="servo")
    except toolchain.ToolNotFound:
        return None
    room = layout.fit(image.symbols, unit.fneed_pages, chip.code_bytes)
    return None if room.fits else rom_overflow(unit, image, room)


def rom_overflow(unit: codegen.AsmUnit, image, room: layout.Fit) -> tuple[str, str]:
    """The rom-overflow diagnostic's message and help for an image that does not fit."""
    chip = unit.target.chip
    bigger = [c.display for c in CHIPS.values()       # one that also has the XRAM the firmware uses
              if c.code_bytes >= room.needed and c.xram_bytes >= unit.xram_bytes]
    message = (f"the firmware needs {room.needed} bytes of code memory"
               + (" even built for size" if unit.for_size else "")
               + f", the {chip.display} has {chip.code_bytes}: "
               f"start-up {image.symbols['runtime_start']}, runtime {room.runtime}, program {room.program}, "
               f"motion data {room.data} ("
               + ", ".join(f"{what} {size}" for what, size in unit.data_breakdown[:4]) + ")")
    eased = any(what == "eased curve tables" for what, _ in unit.data_breakdown)
    help_ = ("shorten the program: fewer distinct moves (play a sequence several times instead of "
             "writing its moves out again), shorter eased moves, or one `speed` for servos of one model"
             + ("; an eased move's curve table has a byte a frame, so a longer `frame` makes it smaller"
                if eased else "")
             + (f"; or build for a chip with more code memory: `target {bigger[0].lower().rstrip('+')}`"
                if bigger else ""))
    return message, help_


def _periods(program, first: Plan) -> Plan:
    """The period stage for one build (`first.compact`)."""
    result = _budgeted(first)
    seen = set()
    while first.period_is_default:
        want = costs.default_period_us(result.min_period_us)
        if want == result.period_us or (result.period_us in seen and want <= result.period_us):
            break
        seen.add(result.period_us)
        period = max(want, result.period_us) if len(seen) > 4 else want
        result = _budgeted(_built_as(_plan.plan(program, None, period), first))
    last = _last_budgeted
    least = _least_period(program, result)      # (which may build at other periods)
    out = result if least == result.min_period_us else dataclasses.replace(result, min_period_us=least)
    if last is not None and last[0] is result:
        _keep_unit(out, last[1])    # the same code: generation does not read min_period_us
    return out


def _least_period(program, at: Plan) -> int:
    """The shortest period to report for `at`: the least P at which the firmware built for P holds
    P, and at which the firmware built for P - 1 us does not hold P - 1 us.

    `at.min_period_us` is the shortest period the code built for `at`'s own P holds. With `host`
    the code follows P: its reading reads the bytes a frame brings (flow.host_passes), so the code
    built for a shorter P does less and may hold a shorter P still (the arm in 6T mode: 2.73 ms from
    the code for 5.3 ms, 2.56 ms from its own). From that shortest period this goes up while the
    code built for P needs more than P, and down while it needs less, until P holds and P - 1 us
    does not. Without `host` the code's cycles follow P through its moves' and holds' records: a
    hold shorter than half a frame lays out none, a record whose F fits one byte (flag F8) is read
    a byte shorter, and a linear move's DDA terms take a DIV only then (the analysis follows the
    flag). So where those are the same at the shortest period as at P, the code's own shortest
    period is the answer; where they are not (`frame 20ms`, a 1.2 s move: F 60 there, over 255 at
    2.8 ms), the search above. So does a program whose `send`s bound the period of the code built
    for `at` (`AsmUnit.unsent_us`): the frames between them also follow P (`frame 20ms`, a 30 ms
    move between runs of sends: 3.294 ms from the code for 20 ms, 0.785 ms from its own). Where they
    do not bind there, they do not at a shorter P either: the frames between them only grow. The
    code built for a shorter P can do more between frames, so that its sends no longer fit that P
    (`send-overrun`): it holds them from the period the error names (`Plan.sends_hold_us`), where
    the search goes on. Where the sends bind the code for `at`, the search starts from the period the
    rest of that code holds: the least P whose own code holds it can be far below (`frame 20ms`, a 37
    ms hold before four bytes at 1200 baud: two frames at 20 ms, seven at 5 ms)."""
    if at.firmware_limit is not None:
        return at.min_period_us
    unsent = None if program.serial is None or not send_run(at) else _unit(at).unsent_us
    by_f = program.serial is None or not (hosted(at) or unsent is not None)   # the code follows P through
    # its records only
    fs: dict[int, tuple] = {at.period_us: _one_byte_fs(at)}

    def f8(p: int) -> tuple:
        if p not in fs:
            fs[p] = _one_byte_fs(_built_as(_plan_at(program, p), at))
        return fs[p]

    if by_f and (at.min_period_us >= at.period_us or f8(at.min_period_us) == fs[at.period_us]):
        return at.min_period_us
    known = {at.period_us: at.min_period_us}

    def need(p: int) -> int:            # the shortest period of the code built for p (p + 1: none
        if p not in known:              # known, where it hits a limit other than its sends')
            got = _budgeted(_built_as(_plan_at(program, p), at))
            known[p] = (got.min_period_us if got.firmware_limit is None
                        else max(p + 1, got.sends_hold_us or 0))
        return known[p]

    def holds(p: int) -> bool:
        return need(p) <= p

    p = at.min_period_us if unsent is None else unsent     # (with the frames between the sends shorter,
    for _ in range(256):                                     # the sends may no longer bind: from below)
        if len(known) > 64:             # (every candidate a build: past 64, the least known to hold)
            break
        m = need(p)
        if m > p or (m < p and holds(m)):
            p = m                       # up while the code for p needs more, down while it needs less
            continue
        if m < p:       # the code for p holds from m on, the code for m does not hold m: the least
            lo = m      # period between that holds (each build's own), by bisection
            while p - lo > 1:
                mid = (lo + p) // 2
                lo, p = (lo, mid) if holds(mid) else (mid, p)
        if p > 1 and not (by_f and f8(p - 1) == f8(p)) and holds(p - 1):   # (the same F8: the code for
            p -= 1                      # p - 1 takes the cycles of the code for p, which does not hold p - 1)
        else:
            return p
    return min((q for q, m in known.items() if m <= q), default=at.min_period_us)


def _one_byte_fs(p: Plan) -> tuple[tuple[bool, bool], ...]:
    """For each of the plan's moves and holds: whether it takes no frame (a hold shorter than half a
    frame lays out no record), and whether its F is one byte (flag F8)."""
    return tuple((st.frames == 0, st.frames is not None and layout.one_byte_f(st.frames)) for st in steps(p)
                 if isinstance(st, (MoveStep, HoldStep)))


def _budgeted(p: Plan) -> Plan:
    """`p` with `min_period_us` read from the firmware generated for it; when no firmware can be
    generated (a resource limit, reported later), P itself and the limit."""
    try:
        unit = _generate(p)
    except layout.LayoutError as exc:
        layout.forget_frames(exc)
        return dataclasses.replace(p, min_period_us=p.period_us,
                                   firmware_limit=tuple((e.code, str(e), e.help, e.span, e.labels) for e in layout.each(exc)),
                                   sends_hold_us=exc.shortest_us if isinstance(exc, layout.SendOverrun) else None)
    result = dataclasses.replace(with_rises(p, unit), min_period_us=unit.min_period_us or p.period_us,
                                 period_holds=unit.min_period_us is None or unit.period_holds)
    _keep_unit(result, unit)
    return result


def _keep_unit(p: Plan, unit: codegen.AsmUnit) -> None:
    """`unit` is the code generated for `p` (`_unit` gives it back)."""
    global _last_budgeted
    _last_budgeted = (p, unit)


def with_rises(p: Plan, unit: codegen.AsmUnit) -> Plan:
    """`p` with where the ports of `unit`'s code rise: their offsets, and whether a rise is a step
    of the last fall's run or comes among the falls of the port before it."""
    return dataclasses.replace(p, rise_offsets=unit.rise_offsets,
                               rise_steps=unit.budget is not None and unit.budget.steps,
                               rises_among_falls=unit.budget is not None and unit.budget.stagger,
                               ports_at_once=unit.budget is not None and unit.budget.merged)


# the last plan `_budgeted` returned and the code generated for it (`_unit`)
_last_budgeted: tuple[Plan, codegen.AsmUnit] | None = None


def lint(plan_: Plan, reporter: Reporter) -> None:
    """Report every lint rule's findings on a plan."""
    _lint.lint(plan_, reporter)


@contextmanager
def _no_cycle_collection():
    """The cyclic garbage collector paused, then restored.

    The front end builds large acyclic structures (half a million to two
    million objects for 1 MB programs): reference counting frees all of it, and
    the collector's passes over the growing heap would otherwise take a quarter
    to two fifths of the time (both measured by benchmarks/lint_scale.py).
    """
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def front_end(source: SourceFile, reporter: Reporter) -> FrontEnd:
    """parse, check, plan and lint; stops after the first stage with errors."""
    with _no_cycle_collection():
        return _front_end(source, reporter)


def _front_end(source: SourceFile, reporter: Reporter) -> FrontEnd:
    if reporter.has_errors:
        return FrontEnd(source, None, None, None)
    tree = parse(source, reporter)
    if tree is None or reporter.has_errors:
        return FrontEnd(source, tree, None, None)
    program = check(tree, reporter)
    if program is None or reporter.has_errors:
        return FrontEnd(source, tree, program, None)
    p = plan(program, reporter)
    lint(p, reporter)
    return FrontEnd(source, tree, program, p)


def generate(plan_: Plan, source: SourceFile, reporter: Reporter) -> codegen.AsmUnit | None:
    """Plan -> assembly text. Resource limits become diagnostics."""
    try:
        unit = codegen.generate(plan_, source)
    except layout.LayoutError as exc:
        for e in layout.each(exc):
            reporter.report(limit_diagnostic(e.code, str(e), e.help, e.span or plan_.program.main_span, e.labels))
        return None
    if unit.min_period_us is None:
        reporter.error("period-too-short", f"the firmware's work between two frames cannot be bounded: {unit.work_from}",
                       plan_.program.main_span, help="report this program as a bug in servoc")
        return None
    if not unit.period_holds:      # lint reports it first; never write firmware that misses it
        reporter.error("period-too-short",
                       f"frame period {plan_.period_us} us is shorter than the {unit.min_period_us} us the firmware needs",
                       plan_.program.frame_span, help=f"use `frame {unit.min_period_us}us` or longer")
        return None
    return unit


def assemble(unit: codegen.AsmUnit, reporter: Reporter) -> Firmware | None:
    """Assembly -> Intel HEX via sdas8051 and sdld, with ROM/RAM checked against the target chip."""
    chip = unit.target.chip
    image = toolchain.assemble(unit.text, name="servo")
    room = layout.fit(image.symbols, unit.fneed_pages, chip.code_bytes)
    if not room.fits:
        message, help_ = rom_overflow(unit, image, room)
        reporter.error("rom-overflow", message, NO_SPAN, help=help_)
        return None
    if unit.ram_bytes > chip.ram_bytes:
        reporter.error("ram-overflow", f"the firmware needs {unit.ram_bytes} bytes of RAM, the {chip.display} has {chip.ram_bytes}",
                       help=layout.RamFull.help)
        return None
    used = toolchain.rom_used(image.hex_text)
    startup = toolchain.rom_used_in(image.hex_text, 0, image.symbols["runtime_start"])
    # code is contiguous; only the data has gaps (page alignment), so its bytes are what is left
    return Firmware(unit, image, used, room.runtime, room.program, used - startup - room.runtime - room.program,
                    startup)


def build(source: SourceFile, reporter: Reporter, for_size: bool = False) -> tuple[FrontEnd, Firmware | None]:
    """The whole compile: front end, then code generation and assembly if there were no errors.
    The firmware is built as the period stage decided (for speed, or for size when that does not
    fit the chip's code memory: `Plan.compact`), or for size when asked (`for_size`), at the
    period that code holds: the front end's plan is then that one."""
    fe = front_end(source, reporter)
    if fe.plan is None or reporter.has_errors:
        return fe, None
    if not for_size and not fe.plan.compact:
        unit = generate(fe.plan, source, reporter)
        if unit is None:
            return fe, None
        trial = Reporter(source)
        firmware = assemble(unit, trial)
        if firmware is not None or [d.code for d in trial.diagnostics] != ["rom-overflow"]:
            for d in trial.diagnostics:
                reporter.report(d)
            return fe, firmware
    with _stage():
        fe = dataclasses.replace(fe, plan=choose_period(fe.plan.program, dataclasses.replace(fe.plan, compact=True)))
    unit = generate(fe.plan, source, reporter)
    return fe, None if unit is None else assemble(unit, reporter)


@dataclass(frozen=True)
class Stimulus:
    """What ucsim drives: the pins the firmware reads and, with `serial`, the bytes the host sends."""
    pins: tuple = ()                 # (cycle, port, outside level of its pins)
    uart: tuple | None = None        # (cycle, on) of the UART's "check input" flag; None: no serial line
    rx: bytes = b""                  # the bytes it releases, in order

    def last(self) -> int:
        return max([at for at, *_ in self.pins] + [at for at, _ in self.uart or ()], default=0)


def stimulus(plan_: Plan, events: list = ()) -> Stimulus:
    """The run `events` (of servoc.events) describe: every input inactive from the first cycle (an
    active-high input's pin held low), then each change; each line of bytes sent to the UART."""
    from . import events as _events
    target = plan_.program.target
    pins = _events.pin_changes(list(events), plan_.program.inputs, target)
    if plan_.program.serial is None:
        return Stimulus(tuple(pins))
    rx, windows = _events.uart_windows(list(events), byte_cycles(plan_.program.serial.th1, plan_.program.serial.smod), target)
    pins, windows = _events.spaced(pins, windows)
    return Stimulus(tuple(pins), tuple(windows), rx)


def simulate(hex_text: str, cycles: int, target: Target = DEFAULT_TARGET,
             stim: Stimulus = Stimulus(), probes: _observe.Probes | None = None) -> _sim.SimTrace:
    """Run an Intel HEX image in ucsim for `cycles` machine cycles of `target`, recording every port
    write and every byte sent (a 6T chip runs as ucsim's 12-clock core at twice its crystal: the
    same machine cycle), and, with `probes` (`probes(firmware)`), every time the firmware reached a
    probed address. Should ucsim make a change of `stim` late (it can, when a port write falls
    in the same instruction, or on a probe), the run is made again with the changes up to 23 cycles
    later. The trace keeps the changes as made (`inputs`, `uart`): verify checks against those."""
    shifts = (0, 1, 2, 5, 11, 23)          # a few cycles later: where no breakpoint stands in the way
    for shift in shifts:
        pins = tuple((at + shift * (at > 1), port, level) for at, port, level in stim.pins)
        uart = None if stim.uart is None else tuple((at + shift, on) for at, on in stim.uart)
        try:
            trace = _sim.run(hex_text, cycles + 4, xtal_hz=target.sim_hz, inputs=pins, uart=uart, rx=stim.rx,
                             timeout=120 + cycles / 1_000_000,    # ucsim runs some 4 million cycles a second
                             probes=() if probes is None else probes.points)
            trace = dataclasses.replace(trace, inputs=pins, uart=uart)
            if probes is not None:
                trace = dataclasses.replace(trace, observation=_observe.observe(probes, trace))
            return trace
        except _sim.MissedInput:
            if shift == shifts[-1]:
                raise
    raise AssertionError("unreachable")


def probes(firmware: Firmware) -> _observe.Probes:
    """Where `servoc verify` watches this firmware run (`observe.probes_for`)."""
    return _observe.probes_for(firmware.image.listing, firmware.unit.text, firmware.unit.selects)


def check_events(plan_: Plan, trace: _sim.SimTrace, frames: int, events: list,
                 line_of=None) -> _verify.VerifyReport:
    """Compare a run driven by `events` with the plan, from what the firmware was seen to do (the
    trace of a `simulate` with `probes`): see `verify.check_run`."""
    return events_report(plan_, trace, frames, events, line_of)[1]


def events_report(plan_: Plan, trace: _sim.SimTrace, frames: int, events: list,
                  line_of=None) -> tuple[tuple, _verify.VerifyReport]:
    """(the branches the selects took, in the order reached; the report) of `check_events`."""
    if trace.observation is None:
        raise ValueError("a run with events is checked from the firmware's probes: simulate it with probes")
    return _verify.check_run(plan_, trace, trace.observation, frames, list(events), line_of)


def cycles_needed(plan_: Plan, frames: int, choices: tuple = ()) -> int:
    """Machine cycles to simulate so that `frames` frames from the first pulse are complete (the
    selects deciding `choices`, as a run with events found them)."""
    return _verify.cycles_needed(plan_, frames, choices)


def check_trace(plan_: Plan, trace: _sim.SimTrace, frames: int) -> _verify.VerifyReport:
    """Compare `frames` frames of a simulation (run with `stimulus(plan_)`: every input inactive),
    from the first pulse, with the plan's golden frames."""
    return _verify.verify(plan_, trace, frames, driven=stimulus(plan_).pins)


def verify(plan_: Plan, firmware: Firmware, frames: int) -> _verify.VerifyReport:
    """Simulate and compare `frames` frames, from the first pulse, with the plan's golden frames."""
    return verify_hex(plan_, firmware.hex_text, frames)


def verify_hex(plan_: Plan, hex_text: str, frames: int) -> _verify.VerifyReport:
    """Simulate a HEX image (built from this plan, or given) and compare `frames` frames with the plan."""
    trace = simulate(hex_text, cycles_needed(plan_, frames), plan_.program.target, stimulus(plan_))
    return check_trace(plan_, trace, frames)


# ---- import: motion from other tools -> .servo text ---------------------------------------

IMPORT_FORMATS = ("maestro", "blender", "bottango", "csv")


_READERS = {"maestro": "maestro", "blender": "blender", "bottango": "bottango", "csv": "csvfile"}


def _reader(fmt: str):
    """The reader module of a format (servoc.imports.<module>)."""
    import importlib
    return importlib.import_module(f".imports.{_READERS[fmt]}", __package__)


def read_motion(path: str, fmt: str | None = None, options=None):
    """A file made by another tool -> (its format, Keyframes). The format is recognised from the
    content unless `fmt` names it. Raises UsageError for a file that cannot be read, is no known
    format, or is broken."""
    from .imports.keyframes import ImportError_, ReadOptions, as_utf8
    data = as_utf8(read_bytes(path, "a file to import"), path)
    if fmt is None:
        fmt = next((name for name in IMPORT_FORMATS if _reader(name).sniff(data, path)), None)
        if fmt is None:
            raise UsageError(f"{path}: not a format servoc imports (a Pololu Maestro settings file, a Blender "
                             "servo-animation .json/.h/.bin, a Bottango code export, or a CSV whose header is "
                             "`time_ms,NAME,...`); if it is one of them, name it with --from")
    try:
        return fmt, _reader(fmt).read(data, path, options or ReadOptions())
    except ImportError_ as exc:
        message = str(exc)
        raise UsageError(message if message.startswith(path) else f"{path}: {message}") from None
    except RecursionError:
        raise UsageError(f"{path}: nested too deeply to be a {fmt} file") from None


def import_pins(kf, given: dict, path: str | None = None) -> tuple[dict, tuple]:
    """Each channel's pin: `given` (--pins CH=PIN) first, then the spec's rule (0-7 on P1, 8-15 on
    P2, 16-23 on P0); a channel past 23 takes the first free pin in that order (a note says so).
    Returns (channel -> pin text, notes). Raises UsageError, naming `path` (the file imported) when
    given, when no pin is left or two channels would share one."""
    from .imports.write import default_pin
    where = f"{path}: " if path else ""
    channels = [c.index for c in kf.channels]
    unknown = sorted(set(given) - set(channels))
    if unknown:
        raise UsageError(f"{where}--pins names channel {unknown[0]}, which the file does not have "
                         f"(it has {', '.join(map(str, channels)) or 'none'})")
    pins, notes = {}, []
    for ch in channels:
        pins[ch] = given.get(ch) or default_pin(ch)
    used = [p for p in pins.values() if p is not None]
    for pin in set(used):
        if used.count(pin) > 1:
            both = [str(ch) for ch, p in pins.items() if p == pin]
            raise UsageError(f"{where}channels {' and '.join(both[:2])} would both be on {pin}: map one elsewhere with "
                             f"--pins {both[-1]}=PIN")
    free = [default_pin(i) for i in range(24) if default_pin(i) not in used]
    for ch in channels:
        if pins[ch] is None:
            if not free:
                raise UsageError(f"{where}channel {ch}: all 24 pins are taken; an 8051 has pins for 24 servos "
                                 f"and the file has {len(channels)} channels")
            pins[ch] = free.pop(0)
            notes.append(f"channel {ch} is past 23: it is on {pins[ch]} (map it with --pins {ch}=PIN)")
    return pins, tuple(notes)


def import_motion(path: str, fmt: str | None = None, pins: dict | None = None, options=None):
    """A file made by another tool -> servoc.imports.write.Imported (the .servo text and figures).
    Sampled motion is fitted at the longest frame period that puts every source frame on a frame
    and is no shorter than the default period of a program on the same pins; when 1/fps is shorter
    than that default, at P = 1/fps if the firmware written for it holds that P, else at a multiple
    of 1/fps (every `step`-th source frame met, with a note). Maestro frames and CSV keys start on
    the frames of that default. Where the motion written needs a longer period than that program
    (more comparators of a sort swap in its frames, say), it is written again from the period it
    needs."""
    from .imports import write as _write
    from .imports.keyframes import ImportError_
    fmt, kf = read_motion(path, fmt, options)
    if not kf.channels:
        raise UsageError(f"{path}: the file has no servo channels to import")
    pin_of, notes = import_pins(kf, pins or {}, path)
    if options is not None and options.ticks_hz is not None and fmt in ("maestro", "bottango"):
        notes += (f"--ticks ignored: a {'Maestro settings file' if fmt == 'maestro' else 'Bottango export'} "
                  f"gives its widths in {'quarter µs' if fmt == 'maestro' else 'µs'}",)
    floor_us = _default_period_on(sorted(set(pin_of.values()))) if kf.tracks else None
    try:
        for _ in range(FIT_ROUNDS):
            timing, exact = _import_timing(kf, floor_us, path)
            imported = _write.write(kf, pin_of, exact or timing, os.path.basename(path))
            fell_back = exact is not None and not _holds(imported.text, exact.period_us)
            if fell_back:
                imported = _write.write(kf, pin_of, timing, os.path.basename(path))
            need = None if timing is None else _shortest(imported.text)
            if need is None or need <= timing.period_us:
                break
            floor_us = need     # the motion written needs more than the program on its pins: again from there
        if fell_back:
            notes += (f"1/fps ({exact.period_us} us) is shorter than the shortest frame the firmware holds on "
                      f"these pins: one source frame in {timing.step} is met, those between are passed on the way",)
    except ImportError_ as exc:
        raise UsageError(f"{path}: {exc}") from None
    return dataclasses.replace(imported, notes=notes + imported.notes)


FIT_ROUNDS = 4      # imports written again at the period the motion written needs (each needs it longer)


def _import_timing(kf, floor_us: int | None, path: str):
    """(timing, exact) of an import whose frames are no shorter than `floor_us`: sampled motion at
    the longest P that puts every source frame on a frame (exact: at P = 1/fps where 1/fps is shorter
    than the floor, for `_holds` to try); Maestro frames and CSV keys start on the frames of P =
    the floor; (None, None) with no tracks."""
    from .imports import write as _write
    if not kf.tracks:
        return None, None
    if not any(t.sampled for t in kf.tracks):
        return _write.Timing(floor_us), None
    keyed = [t for t in kf.tracks if t.curve is None and len(t.keys) > 1]
    if not keyed:
        return _write.Timing(floor_us), None
    intervals = {t.keys[1].at_ms - t.keys[0].at_ms for t in keyed}
    if len(intervals) > 1:
        raise UsageError(f"{path}: its animations run at different frame rates; import them one at a time")
    interval = intervals.pop()
    if interval <= 0:
        raise UsageError(f"{path}: the frames are not 1/fps apart")
    timing = _write.sampled_timing(Fraction(1000) / interval, floor_us)
    return timing, (_write.Timing(round_half_up(interval * 1000)) if timing.step > 1 else None)


def _shortest(text: str) -> int | None:
    """The shortest frame period reported for the program `text` (None where it does not plan)."""
    source = SourceFile("<import>", text)
    fe = front_end(source, Reporter(source))
    return None if fe.plan is None else fe.plan.min_period_us


def _holds(text: str, period_us: int) -> bool:
    """Whether the program `text` plans without errors and its firmware holds `period_us`."""
    source = SourceFile("<import>", text)
    reporter = Reporter(source)
    fe = front_end(source, reporter)
    return fe.plan is not None and fe.plan.min_period_us <= period_us and not any(
        d.code == "period-too-short" for d in reporter.diagnostics)


def _default_period_on(pins: list) -> int:
    """The default frame period (µs at the default target) of a program with servos on `pins` that
    may go anywhere (the longest pulse, N 250, on each port)."""
    text = "".join(f"servo s{i} = {pin}\n" for i, pin in enumerate(pins))
    text += "pose p { " + ", ".join(f"s{i}: 2500us" for i in range(len(pins))) + " }\nmain { move p }\n"
    source = SourceFile("<pins>", text)
    fe = front_end(source, Reporter(source))
    assert fe.plan is not None, "a program of servos and one pose always plans"
    return fe.plan.period_us
