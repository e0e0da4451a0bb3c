"""Code generation: Plan -> AsmUnit (sdas8051 assembly text).

The generator computes every number the firmware needs (RAM addresses,
records, sorting networks, delay loop counts, jump offsets) and hands them to
the jinja2 templates in `firmware_templates/`, which only lay out text.

Firmware shape (AT89C52, 12 MHz, 1 us per machine cycle):
- reset drives every servo line low and runs the program code;
- the program is native code: a move is `MOV DPTR,#record / LCALL do_move`,
  a hold `LCALL do_hold`, `repeat` keeps its counter on the stack, `loop` is a
  jump, `play` an LCALL of the sequence's code; each frame's N are handed to
  the edge handler by `LCALL frame_io`;
- frame_io sorts each port's N with their lines by an unrolled sorting
  network and merges equal N (frame_irq.asm.j2), one port at a time, into the
  buffer the Timer0 handler reads at that port's rise;
- the handler (irq.asm.j2) makes every edge: the rise of a port, then each
  line's fall C(N) = round_half_up((500 + 8 N) us / t_c) cycles later (500 +
  8 N at 12 MHz), chaining Timer0 overflows by exact intervals (costs.py).
"""

from __future__ import annotations

import dataclasses
import functools
from collections import OrderedDict
from dataclasses import dataclass, field

import jinja2

from . import layout, resources
from . import costs
from . import flow as flow_mod, walk, wcet
from . import target as target_mod
from .target import DEFAULT as DEFAULT_TARGET, Target, fmt_us
from .flow import (UNBOUNDED, edge_ports, frame_wrapped, fewest_frames, fewest_frames_in_code, host_passes, host_queue, host_watchers,
                   host_xram, hosted, move_starts, at_start,
                   port_motions, port_reach, select_ram, select_slots, send_gap, send_run, sends, takes_frames, tx_queue, watches)
from .source import SourceFile
from .steps import (AfterBranch, HoldStep, HostStep, LoopStep, MoveStep, Plan, PlayStep, RepeatStep, SelectStep, SendStep,
                    host_playable,
                    Step, steps)
from .units import N_MAX, fmt_ms


@dataclass(frozen=True)
class AsmUnit:
    text: str
    period_us: int
    ports: tuple[int, ...]
    rise_offsets: tuple[int, ...]   # cycles from the first port's rise to each port's rise
    ram_bytes: int                  # direct RAM used, plus the motion state and the stack
    stack_bytes: int                # deepest stack use of program and runtime
    fneed_pages: tuple[int, ...]    # the top pages the frames-needed tables may reach down to (empty if none):
                                    # the tables follow the motion data page-aligned, so it must end below these
    data_breakdown: tuple[tuple[str, int], ...] = ()   # motion data bytes by what they serve, largest first
    budget: costs.Budget | None = None   # the cycles the text takes per frame (None: unbounded)
    work_from: str = ""             # where the longest work between frames starts, or why it is unbounded
    min_period_us: int | None = None   # the shortest frame period this code holds (None: unbounded)
    target: Target = DEFAULT_TARGET    # the chip it is built for
    for_size: bool = False          # built for size (Plan.compact)
    selects: tuple = ()             # (label, SelectStep) of each select laid out, for verify's probes
    period_holds: bool = True       # the code holds the plan's own period (the model evaluated there)
    xram_bytes: int = 0             # XRAM in use (flow.host_xram: the host's arrays, the motion state)
    both_passes: bool = False       # some moves take the one call (Plan.first_step), others the two passes:
                                    # both are laid out, so the build without first_step has less code
    unsent_us: int | None = None    # where the runs of `send` need a longer period than the rest of the
                                    # code (`_send_floor`): the shortest period the rest holds (the frames
                                    # between the runs follow P); None: they do not

    def fits_code(self) -> bool:
        """Whether the code memory surely holds it, by the size read from the text
        (`layout.rom_end`) and a page for each frames-needed table."""
        return layout.rom_end(self.text) + 512 * len(self.fneed_pages) <= self.target.chip.code_bytes


_hex8 = layout.hex8


def _hex16(v: int) -> str:
    return f"0x{v & 0xFFFF:04X}"


_ENV: jinja2.Environment | None = None


def environment() -> jinja2.Environment:
    """The one jinja2 environment for the firmware templates."""
    global _ENV
    if _ENV is None:
        _ENV = jinja2.Environment(
            loader=jinja2.FunctionLoader(lambda name: resources.template_text(name)),
            undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
            keep_trailing_newline=True, autoescape=False)
        _ENV.filters["hex8"] = _hex8
        _ENV.filters["hex16"] = _hex16
        _ENV.filters["hi8"] = lambda v: _hex8(v >> 8)
        _ENV.filters["lo8"] = lambda v: _hex8(v)
        _ENV.filters["byte"] = lambda v, b: _hex8(v >> 8 * b)
    return _ENV


def render(template: str, **context) -> str:
    """A template rendered with `context` (jinja's low-level API: `new_context`, `root_render_func`).

    A macro that calls itself (program.asm.j2's `ops`) keeps the render's context in a reference
    cycle; its variables are dropped after rendering, so the program's records are freed at once
    rather than pinned until a collection."""
    env = environment()
    try:
        tpl = env.get_template(template)
        ctx = tpl.new_context(context)
        try:
            return env.concat(tpl.root_render_func(ctx))
        finally:
            ctx.parent.clear()
            ctx.vars.clear()
    except jinja2.TemplateError as exc:
        raise RuntimeError(f"firmware template {template}: {exc}") from exc


# ----------------------------------------------------------------- layout

@dataclass
class _Ctx:
    plan: Plan
    source: SourceFile | None
    records: list[dict]
    ease_tables: dict[tuple, str]
    lists: list[dict] = field(default_factory=list)
    labels: int = 0
    owner: str = "main"              # whose statements are being laid out, for the ROM breakdown
    frames_memo: dict = field(default_factory=dict)   # plan.takes_frames of each sequence
    sends_memo: dict = field(default_factory=dict)    # plan.sends of each sequence
    port_channels: tuple = ()        # (port, its channels) for each port of the plan
    fewest_memo: dict = field(default_factory=dict)   # plan.fewest_frames of each sequence
    coded_memo: dict = field(default_factory=dict)    # flow.fewest_frames_in_code of each sequence
    flagged: bool = False            # a loop tests FRAMED (frame_io sets it)
    written: int = 1                 # passes written out by the repeats around (plan.frameless_repeats)
    byte_maps: dict = field(default_factory=dict)     # the bytes selects' `on`s name -> their map
    slots: dict = field(default_factory=dict)         # id(select) -> its level (select_slots)
    edge_ports: tuple = ()           # ports with an input some `on press`/`on release` watches
    looks: list = field(default_factory=list)         # every select's op, for its look routine
    selects: list = field(default_factory=list)       # (label, SelectStep) of every select laid out
    watches: int = 0                 # selects with a meanwhile body so far (their ids: 1, 2, ...)
    repeats: bool = False            # a `repeat` is laid out (it counts its passes with rep_next)
    host_watchers: set = field(default_factory=set)   # selects whose meanwhile body runs `host` (flow.host_watchers)
    fbase: str = "frame_io"          # the frame routine: frame_w with a meanwhile body (flow.watches)
    at_start: dict = field(default_factory=dict)      # per move statement (id), what holds wherever it starts

    def __post_init__(self) -> None:
        self.port_channels = tuple((port, tuple(c for c in self.plan.channels if c.port == port))
                                   for port in self.plan.ports)

    def label(self, prefix: str) -> str:
        self.labels += 1
        return f"{prefix}{self.labels}"

    def where(self, span) -> str:
        if self.source is None:
            return ""
        line, _ = self.source.line_col(span.start)
        text = self.source.line_text(line).split("#")[0].strip()
        return f"{self.source.path.rsplit('/', 1)[-1]}:{line}  {text}"


def _move_record(ctx: _Ctx, step: MoveStep, known: dict[int, int]) -> dict:
    """The record of a move. `known` holds the targets set by the records before it in its list:
    a servo whose target is already the pose's is left out of the record (it does not move), and
    so is one at the pose's N at every start of the move (`flow.at_start`); `known` takes the
    move's targets."""
    plan = ctx.plan
    frames = step.frames        # None: the plan found different F in different contexts
    notes: list[str] = [f"move {step.pose}", "F found at run time" if frames is None else f"F = {frames}"]
    label = None
    if step.ease != "linear":
        key = (step.ease, step.frames)
        label = ctx.ease_tables.setdefault(key, f"etab{len(ctx.ease_tables) + 1}")
        notes.append(f"ease {step.ease} table {label}")
    start = ctx.at_start.get(id(step), flow_mod.AtStart(frozenset(), frozenset(), frozenset()))
    targets = {ch: n for ch, n in step.targets if known.get(ch) != n and ch not in start.still}
    if len(step.targets) == len(plan.channels) and len(plan.ports) + len(targets) >= len(plan.channels):
        targets = dict(step.targets)    # naming every servo needs no masks: not longer than masks and the changed
    known.update(step.targets)
    masks = None
    named = tuple(sum(1 << c.bit for c in on_port) for _, on_port in ctx.port_channels)
    if len(targets) == len(plan.channels):
        notes.append("every servo")
    else:
        masks = []
        for port, on_port in ctx.port_channels:
            chans = [c for c in on_port if c.index in targets]
            masks.append(sum(1 << c.bit for c in chans))
            notes.append(f"P{port}: " + (", ".join(c.name for c in chans) or "none"))
        named = tuple(masks)
    notes += [f"{plan.channels[ch].name} N {n}" for ch, n in sorted(targets.items())]
    if len(targets) < len(step.targets):
        notes.append(f"{len(step.targets) - len(targets)} already there")
    flags, data = layout.move_record(frames, label, targets, masks)
    act = tuple((sum(1 << c.bit for c in chans if c.index in start.on), sum(1 << c.bit for c in chans if c.index in start.off))
                for _, chans in ctx.port_channels)
    return {"flags": flags, "data": data, "notes": notes, "where": ctx.where(step.span), "owner": ctx.owner,
            "names": named, "act": act, "step": id(step)}


def _hold_record(ctx: _Ctx, step: HoldStep) -> dict:
    flags, data = layout.hold_record(step.frames)
    return {"flags": flags, "data": data, "notes": [f"hold F = {step.frames}"],
            "where": ctx.where(step.span), "owner": ctx.owner}


def _ops(ctx: _Ctx, body: tuple[Step, ...], out: list[dict]) -> None:
    """Flatten statements into template ops; runs of moves and holds become one record list."""
    run: list[dict] = []
    known: dict[int, int] = {}          # targets set by the records of the current list so far

    def flush() -> None:
        known.clear()
        if run:
            if ctx.plan.compact:
                run[:] = layout.share_headers(run)
            label = f"list{len(ctx.lists) + 1}"
            ctx.lists.append({"label": label, "records": list(run), "where": run[0]["where"]})
            ctx.records.extend(run)
            out.append({"op": "list", "label": label, "wheres": [r["where"] for r in run]})
            run.clear()

    for st in body:
        if isinstance(st, SelectStep):
            flush()
            out.append(_select_op(ctx, st))
            continue
        if isinstance(st, SendStep):
            flush()
            out.append({"op": "send", "byte": st.byte, "text": st.text, "where": ctx.where(st.span)})
            continue
        if isinstance(st, HostStep):
            flush()
            out.append({"op": "host", "label": ctx.label("host"), "where": ctx.where(st.span), "fbase": ctx.fbase,
                        "plays": [{"label": _seq_label(ctx.plan, p.sequence), "name": p.sequence,
                                   "n": [q.name for q in ctx.plan.program.sequences].index(p.sequence)}
                                  for p in st.plays]})
            continue
        where = ctx.where(st.span)
        if isinstance(st, LoopStep):
            flush()
            lab = ctx.label("loop")
            # a pass that took no frame waits for the next one: always, or when FRAMED says so
            pad = ("frame" if not takes_frames(st.body, ctx.plan, ctx.frames_memo) else
                   "flag" if fewest_frames_in_code(st.body, ctx.plan, ctx.coded_memo) == 0 else "")
            ctx.flagged = ctx.flagged or pad == "flag"
            out.append({"op": "loop", "label": lab, "where": where, "pad": pad})
            _ops(ctx, st.body, out)
            out.append({"op": "loop_end", "label": lab, "where": where, "pad": pad})
            continue
        framed = takes_frames((st,), ctx.plan, ctx.frames_memo)
        if not framed and not sends((st,), ctx.plan, ctx.sends_memo):
            continue            # takes no frame and sends nothing: no code, so it cannot delay a frame
        if isinstance(st, RepeatStep) and fewest_frames(st.body, ctx.plan, ctx.fewest_memo) == 0:
            # a pass can run through without a frame (only sends, or a select whose event is there):
            # written out pass by pass, so that the work between two frames stays bounded (lint
            # limits the passes: `too-long`, and the sends: at most flow.TX_MOST bytes in all)
            if framed and ctx.written * st.count > layout.MAX_FRAMELESS_PASSES:    # lint's `too-long` first
                raise layout.FramelessRepeat(
                    f"this repeat's passes can take no frame, and the firmware writes such a repeat out "
                    f"pass by pass: at most {layout.MAX_FRAMELESS_PASSES}, not {ctx.written * st.count}")
            flush()
            ctx.written *= st.count if framed else 1
            for _ in range(st.count):
                _ops(ctx, st.body, out)
            ctx.written //= st.count if framed else 1
            continue
        if isinstance(st, MoveStep):
            run.append(_move_record(ctx, st, known))
            continue
        if isinstance(st, HoldStep):
            run.append(_hold_record(ctx, st))
            continue
        flush()
        if isinstance(st, RepeatStep):
            lab = ctx.label("rep")
            ctx.repeats = True
            # every pass takes a frame, but one whose frames come from an `after` the analysis
            # cannot count (it is counted at run time): a pass without a frame, which never
            # happens, would wait for one, so that every path the code has reaches a frame
            pad = "flag" if fewest_frames_in_code(st.body, ctx.plan, ctx.coded_memo) == 0 else ""
            ctx.flagged = ctx.flagged or pad == "flag"
            out.append({"op": "repeat", "label": lab, "count": st.count, "where": where, "pad": pad})
            _ops(ctx, st.body, out)
            out.append({"op": "repeat_end", "label": lab, "where": where, "pad": pad})
        elif isinstance(st, PlayStep):
            out.append({"op": "play", "label": _seq_label(ctx.plan, st.sequence), "name": st.sequence, "where": where})
    flush()


def _select_op(ctx: _Ctx, st: SelectStep) -> dict:
    """A select: as soon as it is reached, and after each frame it waits, its look routine tries
    its events in the order written and says which branch to run: an input active (or, for an
    edge, changed since the sample before), the oldest byte received if an `on` names it (`on
    other`: any byte no other `on` names); bytes that no `on` names are dropped first. With
    `after`, the look made after F frames with none takes it. While it waits, frame_io repeats
    the current targets, or its meanwhile body runs and frame_w looks after each of its frames.
    Its counters and samples are at its level (`select_slots`): selects waiting at once never
    share one."""
    inputs = {i.name: i for i in ctx.plan.program.inputs}
    lab = ctx.label("sel")
    slot = ctx.slots[id(st)]
    ons, after, branches, edge_inputs = [], None, [], []
    for k, br in enumerate(st.branches):
        ops: list[dict] = []
        _ops(ctx, br.body, ops)
        branches.append({"k": k, "ops": ops, "where": ctx.where(br.span)})
        if isinstance(br, AfterBranch):
            if br.frames > layout.MAX_AFTER_FRAMES:      # lint's `too-long` reports this first
                raise layout.AfterTooLong(f"this `after` waits {br.frames} frames; the firmware counts at most "
                                          f"{layout.MAX_AFTER_FRAMES}")
            after = {"k": k, "frames": br.frames, "looks": br.frames + 1, "where": ctx.where(br.span)}
            continue
        ev = br.event
        on = {"k": k, "byte": ev.byte, "text": ev.text, "other": ev.other, "edge": ev.edge, "input": ev.input}
        if ev.input is not None:
            pin = inputs[ev.input]
            on.update(port=pin.port, bit=pin.bit, active_high=pin.active_high)
            if ev.edge is not None:
                on.update(pi=ctx.edge_ports.index(pin.port), now_high=(ev.edge == "press") == pin.active_high)
                if ev.input not in edge_inputs:
                    edge_inputs.append(ev.input)
        ons.append(on)
    named = sorted({on["byte"] for on in ons if on["byte"] is not None})
    other = any(on["other"] for on in ons)
    serial = ctx.plan.program.serial is not None and id(st) not in ctx.host_watchers   # `host` reads the bytes
    byte_map = _byte_map(ctx, named, st) if serial and named else None
    meanwhile = None
    wid = 0
    if st.meanwhile is not None:
        ctx.watches += 1
        wid = ctx.watches
        meanwhile = []
        _ops(ctx, st.meanwhile, meanwhile)
    # Its frame on the stack (walk.select_frame bytes, R1 -> the top in its look): the `after`
    # count, low byte first, then the sample before of each input an edge event watches.
    size = walk.select_frame(st)
    base = 2 if after else 0
    if after:
        after["off"] = -(size - 1)
    prev = [{"off": base + j - (size - 1), "port": inputs[name].port, "name": name,
             "smp": ctx.edge_ports.index(inputs[name].port)} for j, name in enumerate(edge_inputs)]
    for on in ons:
        if on["edge"]:
            on["poff"] = next(p["off"] for p in prev if p["name"] == on["input"])
    ports = sorted({p["port"] for p in prev})
    op = {"op": "select", "label": lab, "ons": ons, "after": after, "branches": branches, "frame": size,
          "prev": prev,
          "where": ctx.where(st.span), "serial": serial, "byte_map": None if other else byte_map,
          "named_map": byte_map if other else None, "other": other, "slot": slot, "id": wid,
          "meanwhile": meanwhile,
          "samples": [{"i": ctx.edge_ports.index(p), "port": p} for p in ports]}
    ctx.looks.append(op)
    ctx.selects.append((lab, st))
    return op


def _byte_map(ctx: _Ctx, named: list[int], st: SelectStep) -> dict:
    """The map of the bytes a select's `on`s name (selects that name the same bytes share one)."""
    byte_map = ctx.byte_maps.get(tuple(named))
    if byte_map is None:
        byte_map = {"label": f"bmap{len(ctx.byte_maps) + 1}", "where": ctx.where(st.span),
                    "bytes": [sum(1 << (b & 7) for b in named if b >> 3 == i) for i in range(32)],
                    "names": ", ".join(_hex8(b) for b in named)}
        ctx.byte_maps[tuple(named)] = byte_map
    return byte_map


def _seq_label(plan: Plan, name: str) -> str:
    return f"seq{[s.name for s in plan.sequences].index(name) + 1}"


def generate(plan: Plan, source: SourceFile | None = None, hold_off: int = 0, stepping: bool | None = None,
             stagger: bool | None = None, merged: bool | None = None) -> AsmUnit:
    """Lay out the firmware for a plan (which must have passed lint without errors).
    `hold_off` > 0 makes a test build that holds interrupts off for that many cycles (NOPs
    between CLR EA and SETB EA) at several points of the background: the edges must not move.
    With `host`, HAQ holds HOST_ANSWERS answers waiting where the RAM allows it, else one (the
    RAM `flow.host_vars` counts): a program that fits with one is never refused for the others.
    The next port's rise comes as a step of its last fall's entry (`costs.RISE_STEP`), or where
    the clock allows it among that port's falls (`costs.stagger_span`), in the build of these
    whose code holds the shortest period (without either where they tie, or where their code does
    not fit the chip's code memory, `layout.rom_end`); a build for size has neither. `stepping` or `stagger` given:
    that build (True only where a build can have it). Then, where `can_merge`, the build with the ports
    at once, kept where its period is shorter still (`merged` True: that build, where `can_merge`;
    False: never). Each build keeps its motion state in internal RAM, or where that is full and the
    chip has XRAM, there (`_state_where_it_fits`). Where the build without either cannot hold the
    program's sends at P (`layout.SendOverrun`), the others are built all the same."""
    can = costs.rise_steps(plan.compact) and bool(plan.ports)
    can_stagger = can and _can_stagger(plan)
    if merged and can_merge(plan):
        return _merged(plan, source, hold_off)
    if stepping is not None or stagger is not None:
        staggered = bool(stagger) and can_stagger
        return _generate_answers(plan, source, hold_off, bool(stepping) and can and not staggered, staggered)
    facts = at_start(plan)
    reason = first = None   # a build that holds a shorter period than `best` but not this one: why

    def dropped(exc: layout.LayoutError) -> None:
        nonlocal reason
        layout.forget_frames(exc)
        if isinstance(exc, layout.SendOverrun) and exc.shortest_us is not None and (
                reason is None or exc.shortest_us < reason.shortest_us):
            reason = exc

    try:
        best = without = _generate_answers(plan, source, hold_off, False, facts=facts)
    except layout.SendOverrun as exc:   # its sends need a longer P than this one: another build's may not
        if not can:
            raise
        dropped(exc)
        first, best, without = exc, None, None
    if not can:
        return without
    for kind in ("stagger", "steps"):
        if kind == "stagger":
            pays = can_stagger and (without is None or _stagger_may_pay(without))
        else:
            pays = without is None or _steps_may_pay(without, best)
        if not pays:
            continue
        try:
            other = _generate_answers(plan, source, hold_off, kind == "steps", kind == "stagger", facts)
        except layout.LayoutError as exc:
            dropped(exc)
            continue
        if best is None or (other.min_period_us is not None and best.min_period_us is not None
                            and other.min_period_us < best.min_period_us and other.fits_code()):
            best = other
    if best is None:
        raise reason or first       # every build's sends need a longer P (or it has another limit)
    if (reason is not None and not best.period_holds and best.min_period_us is not None
            and reason.shortest_us < best.min_period_us):
        raise reason        # the program's shortest period is that build's: its limit is the reason
    if merged is None and can_merge(plan) and best.min_period_us is not None and _merged_may_pay(best):
        try:
            other = _merged(plan, source, hold_off, facts)
        except layout.LayoutError as exc:
            layout.forget_frames(exc)
            return best
        if (other.min_period_us is not None and other.min_period_us < best.min_period_us
                and other.fits_code()):
            best = other
    return best


def can_merge(plan: Plan) -> bool:
    """Whether a build can pulse the ports at once, their falls one timeline (frame_merged.asm.j2,
    irq_merged.asm.j2): two ports or more, at a clock where a group of every port's writes fits
    between the falls of two consecutive N (`costs.merged_step`), built for speed, without `host`
    (whose reading and answers are not in this build's budget; a serial line's handler is: its runs
    in each window of the frame, and the edge handler's longest stretch, `costs.busy_stretch`)."""
    target = plan.program.target
    m = len(plan.ports)
    return (m >= 2 and not plan.compact and not (plan.program.serial is not None and hosted(plan))
            and min(target.width_cycles(n + 1) - target.width_cycles(n) for n in range(N_MAX)) >= costs.merged_step(m))


def _merged_may_pay(best: AsmUnit) -> bool:
    """Whether the build with the ports at once can hold a shorter period than `best`: its pulses'
    term is at least the longest pulse and the last group's entry (costs.ENTRY)."""
    b = best.budget
    if b is None or not b.tops:
        return True
    return best.target.us_at_least(best.target.width_cycles(max(b.tops)) + costs.ENTRY) < best.min_period_us


def _merged(plan: Plan, source: SourceFile | None, hold_off: int, facts: dict | None = None) -> AsmUnit:
    """The build whose ports' pulses overlap whole (`_state_where_it_fits`)."""
    facts = at_start(plan) if facts is None else facts
    return _state_where_it_fits(plan, lambda xstate: _generate(plan, source, hold_off, 1, False, False, facts,
                                                               merged=True, xstate=xstate))


def _state_where_it_fits(plan: Plan, build) -> AsmUnit:
    """`build(xstate)` with the motion state in internal RAM, or where that is full (or leaves the
    stack too little: lint's `too-deep` counts the room the XRAM leaves) and the chip has XRAM,
    there (`xstate`: a longer W, read from its code like any other)."""
    try:
        return build(False)
    except (layout.RamFull, layout.StackTooDeep) as exc:
        if not flow_mod.state_may_go_to_xram(plan):
            raise
        layout.forget_frames(exc)
    return build(True)


def _can_stagger(plan: Plan) -> bool:
    """Whether a build can have each port's rise among the falls of the port before it: two ports
    or more (at a clock whose DIV is less than 2 STEP cycles, the rise beside a fall:
    `costs.beside`)."""
    return len(plan.ports) >= 2


def _stagger_may_pay(without: AsmUnit) -> bool:
    """Whether the build with staggered rises can hold a shorter period than `without`: its spans
    are at least `costs.stagger_span` with no handover (a span only grows with it)."""
    b = without.budget
    if b is None or without.min_period_us is None or not b.tops:
        return True
    m, low = len(b.tops), b.bottoms or (0,) * len(b.tops)
    least = sum(costs.stagger_span(without.target, top, 0, k == m - 1, low[k], low[(k + 1) % m]) for k, top in enumerate(b.tops))
    return without.target.us_at_least(least) < without.min_period_us


def _steps_may_pay(without: AsmUnit, best: AsmUnit) -> bool:
    """Whether the build with rises as steps can hold a shorter period than `best` (`without`, or
    the build with rises among falls where that is shorter): its spans are at least each port's
    longest pulse and RISE_STEP, each rise at least RISE_HEAD - ENTRY - 2 cycles longer than
    `without`'s (the same emit, reached later) and its other cycles at least `without`'s, so the
    frame that budget needs bounds its period from below."""
    b = without.budget
    if b is None or without.min_period_us is None or best.min_period_us is None or not b.tops:
        return True
    tight = tuple(costs.port_span(without.target, top, True) for top in b.tops)
    rises = tuple(r + costs.RISE_HEAD - costs.ENTRY - 2 for r in b.rises)
    try:
        least = costs.frame_cycles(without.target, dataclasses.replace(b, spans=tight, rises=rises, steps=True))
    except costs.TooSlow:
        return False
    return without.target.us_at_least(least) < best.min_period_us


def _generate_answers(plan: Plan, source: SourceFile | None, hold_off: int, stepping: bool,
                      stagger: bool = False, facts: dict | None = None) -> AsmUnit:
    """`generate`, with or without rises as steps (or among the falls before them: `stagger`);
    `facts`: `flow.at_start` of the plan, where already found."""
    facts = at_start(plan) if facts is None else facts
    if not (plan.program.serial is not None and hosted(plan)):
        return _state_where_it_fits(plan, lambda xstate: _generate(plan, source, hold_off, 1, stepping, stagger,
                                                                   facts, xstate=xstate))
    try:
        return _generate(plan, source, hold_off, HOST_ANSWERS, stepping, stagger, facts)
    except (layout.HostRam, layout.StackTooDeep, layout.RamFull, layout.Several):
        return _generate(plan, source, hold_off, 1, stepping, stagger, facts)


def _generate(plan: Plan, source: SourceFile | None, hold_off: int, answers: int, stepping: bool,
              stagger: bool, facts: dict, merged: bool = False, xstate: bool = False) -> AsmUnit:
    """`generate`, with room for `answers` answers waiting in HAQ (with `host`), with or without
    rises as steps, or with each port's rise among the falls of the port before it (`stagger`)."""
    ctx = _Ctx(plan, source, [], {}, at_start=facts)
    ctx.slots = select_slots(plan)
    ctx.edge_ports = edge_ports(plan)
    ctx.host_watchers = host_watchers(plan)
    ctx.fbase = "frame_w" if watches(plan) else "frame_io"
    main_ops: list[dict] = []
    _ops(ctx, plan.main, main_ops)
    sequences = []
    for seq in plan.sequences:
        ops: list[dict] = []
        ctx.owner = f"sequence `{seq.name}`"
        _ops(ctx, seq.body, ops)
        sequences.append({"label": _seq_label(plan, seq.name), "name": seq.name, "ops": ops,
                          "where": ctx.where(seq.span)})
    serial = plan.program.serial
    taken = select_ram(plan)
    deep_runtime = watches(plan) or hosted(plan)      # frame_w's looks, or the host's reading: WATCH_STACK more
    wrapped = frame_wrapped(plan)                     # and frame_h around frame_w: WRAP_STACK more
    stack_bytes = costs.stack_bytes(plan.nesting, serial is not None, deep_runtime, wrapped)
    nports = len(plan.ports)
    in_xram = host_xram(plan) or xstate     # the host's arrays and the motion state in XRAM
    room_promised = costs.stack_room(serial is not None, taken, nports, in_xram)
    least_stack = costs.stack_bytes(0, serial is not None, deep_runtime, wrapped)
    decides = hosted(plan)              # with `host`, the RAM allocated decides (host-ram, too-deep)
    if stack_bytes > room_promised and not decides:     # lint's `too-deep` reports this first
        raise layout.StackTooDeep(f"the program nests too deeply: it needs {stack_bytes} bytes of stack, "
                                  f"the firmware has {room_promised}")
    state_base = layout.state_base(nports, in_xram)
    limits: list[layout.LayoutError] = []      # the serial line's limits: all of them are said at once
    txq = tx_queue(plan)
    if serial is not None and send_run(plan) > txq:
        sends_ = [st for st in steps(plan) if isinstance(st, SendStep)]
        limits.append(layout.SendOverrun(f"the program can send {_bytes(send_run(plan))} with no frame between them; "
                                         f"the transmit queue holds {txq} at the most",
                                         span=sends_[0].span if sends_ else serial.span,
                                         labels=tuple((st.span, "sends too") for st in sends_[1:4])))
    # the runtime, and the RAM, leave out what no record or statement uses
    uses = {"eased": bool(ctx.ease_tables), "repeats": ctx.repeats,
            "holds": any(r["flags"] & layout.FLAG["HOLDF"] for r in ctx.records),
            "nodur": any(r["flags"] & layout.FLAG["NODUR"] for r in ctx.records),
            "kinds": {(bool(r["flags"] & layout.FLAG["EASED"]), bool(r["flags"] & layout.FLAG["NODUR"]))
                      for r in ctx.records if not r["flags"] & layout.FLAG["HOLDF"]},
            "sends": serial is not None and (sends(plan.main, plan, ctx.sends_memo) or hosted(plan))}
    hosting = serial is not None and hosted(plan)
    rxq = host_queue(plan)

    # what the stack leaves; with `host`, the RAM allocated decides (host-ram)
    def host_ram_short(past: int) -> layout.HostRam:
        message, hint = flow_mod.host_ram_text(plan, past)
        return layout.HostRam(message, hint, next(st for st in steps(plan) if isinstance(st, HostStep)).span)
    ram = layout.RamAllocator(state_base - (least_stack if decides else stack_bytes), layout.work_base(nports),
                              host_ram_short if decides else None)
    ram.next = layout.ADDR["FLAGS"] + 1
    ram.alloc("SEGF", 2, "F of the current move")
    framed_bit = layout.bit_address(ram.alloc("RUNF", 1, "the runtime's flags (bit-addressable): FRAMED, and BFULL, TXON and PLAYH where used"), 0)
    ram.next = layout.work_base(nports)
    ram.alloc("ERR0", 2, "DDA start of the current linear move: floor(-F / 2) mod 65536")
    ram.alloc("FLEFT", 2, "frames left in the current move or hold")
    if uses["eased"]:
        ram.alloc("SEGK", 2, "frame number k in the current move")
        ram.alloc("ETAB", 2, "eased curve table of the current move, minus 1")
        ram.alloc("EVAL", 1, "e(k/F) x 256 this frame")
    if uses["nodur"]:       # F found at run time: the frames its largest |delta| needs, per speed class
        for cls in range(len(plan.speed_tables)):
            ram.alloc(_dmax(cls), 1, f"the largest |delta| of speed class {cls} in the current record")
    ram.alloc("LPTR", 2, "the record list being run: the next record")
    more = any(r.get("more") for r in ctx.records)
    if more:
        ram.alloc("MOREC", 1, "records left that share the flags and F of the one before")
    watch = _select_ram(ctx, ram)
    fbase = "frame_w" if watch else "frame_io"
    fcall = "frame_h" if serial is not None and hosted(plan) and host_playable(plan.program) else fbase
    target = plan.program.target
    period_cycles = target.cycles(plan.period_us)
    if merged:
        ram.alloc("MH", len(plan.ports), "frame_io: each port's next distinct N in its list, while it merges them")
    else:
        _engine_ram(ram)
    if stagger or merged:
        ram.alloc("EDP", 2, "DPTR as frame_io's caller had it, while the background writes a port's items")
    s = None if serial is None else _serial(serial, ram, uses["sends"], rxq, txq)
    if s is not None:
        s["marks"] = hosting        # a byte lost to a full queue spoils the line it was in
    if hosting:
        for name, size, what in HOST_VARS:
            ram.alloc(name, answers if name == "HAQ" else size, what)
        if host_playable(plan.program):
            ram.alloc("HFRZ", nports, "while a sequence `PL` started plays: per port in use, the lines `STOP c` "
                                      "holds where they are until it ends")
        xat = 0
        holds = layout.host_holds(plan, in_xram)
        if holds:
            ram.alloc("HHP", 1, "the next free hold: the entries held while a group waits end here")
            ram.alloc("HHJ", 1, "the end of the holds of lines that joined the group (those after: "
                                "the line being read's)")
        if in_xram:
            ram.alloc("HGEN", 1, "the generation of the line being read: a pending entry is this line's "
                                 "when its HTAG is HGEN (host_drop counts it up, and each group line's end)")
            ram.alloc("HGA", 1, "the generation of the waiting group's first line: the group's entries "
                                "are those with HTAG from HGA to HGEN - 1")
        for name, size, what in HOST_ARRAYS + ((HOST_TAGS,) if in_xram else ()):
            if in_xram:       # in XRAM page 0, below the motion state
                ram.xsymbols.append((name, xat, f"{what} (XRAM)"))
                xat += size * len(plan.channels)
            else:
                ram.alloc(name, size * len(plan.channels), what, direct=False)
        if holds and in_xram:
            ram.xsymbols.append(("HHO", xat, f"{holds} holds of {layout.HOLD_BYTES} bytes: its line's generation, "
                                              "a servo, its S, its width or offset (XRAM)"))
            xat += holds * layout.HOLD_BYTES
        elif holds:
            ram.alloc("HHO", holds * layout.hold_bytes(False), f"{holds} holds of {layout.hold_bytes(False)} bytes: a "
                      "servo, its S, its width or offset", direct=False)
        assert xat <= layout.state_at(nports), "the host's arrays reach the motion state in XRAM"
    # the buffers reached only through @R0/@R1 last: they may go past the directly addressable RAM
    items = 1 + 3 * (_most_lines(plan) - 1) + 3
    mload = None
    if merged:
        mload = costs.merged_load(target, port_motions(plan, joint=True)[0], costs.merged_split(nports))
        groups = max(mload.groups, 1)
        for port in plan.ports:
            s_ = sum(1 for c in plan.channels if c.port == port)
            ram.alloc(f"DL{port}", 2 * s_ + 1, f"P{port}'s distinct N, ascending, each with its lines, then 0xFF", direct=False)
        ram.alloc("ITEMS", nports + groups * (2 + nports) + 1, "the handler's items: the frame's timeline of groups", direct=False)
    elif stagger:     # two buffers, each with its first edge's N: one in use, one being written
        ram.alloc("ITA", 1 + items, "items of a port, after its first edge's N (IBUF clear: in use)", direct=False)
        ram.alloc("ITB", 1 + items, "items of a port, after its first edge's N (IBUF set: in use)", direct=False)
    else:
        ram.alloc("ITEMS", items, "the handler's items for the port being pulsed", direct=False)
    if uses["sends"]:
        ram.alloc("TXQ", txq, "the transmit queue", direct=False)
    if s is not None:
        slots = rxq + 1         # one slot always free: the ring is full when the slot after RXW is RXR's
        s.update(_rx_ring(ram.alloc("RXQ", slots, f"the receive queue: {rxq} bytes in a ring of {slots} slots",
                                    direct=False), slots))
    ram.check()
    stack_base = ram.next
    if decides and state_base - stack_base < stack_bytes:
        room = state_base - stack_base
        limit = max(0, (room - least_stack) // 2)      # below 0: not even the runtime's own fits
        trail: list = []
        deep = walk.first_too_deep(plan.main, lambda name: plan.sequence(name).body, limit, trail)
        message, _ = walk.too_deep_text(plan.nesting, room, limit, deep, trail)
        raise layout.StackTooDeep(message, layout.FLATTEN, span=deep.span if deep is not None else None)
    # the last of three ports gets a sort buffer of its own (B) where the stack leaves room for it
    room = state_base - stack_base
    bport = (plan.ports[-1] if len(plan.ports) == 3 and not in_xram and stack_bytes + costs.BUFB_RAM <= room
             and not stagger else None)     # with rises among falls, each port's items are written in its turn
    motions = port_motions(plan)
    bottoms, tops = port_reach(plan, motions)
    m = len(tops)
    spans = (tuple(costs.stagger_span(target, top, target.width_cycles(0), k == m - 1, bottoms[k], bottoms[(k + 1) % m])
                   for k, top in enumerate(tops))
             if stagger else tuple(costs.port_span(target, top, stepping) for top in tops))
    e = _engine(plan, ram, period_cycles, bport, spans, stepping, stagger)
    if merged:
        _set_merged(e, plan, groups)
    e["framed"] = ctx.flagged
    chans = []
    for c in plan.channels:
        pin = 8 * c.port + c.bit
        bit = {name: layout.bit_address(layout.ADDR[name], pin) for name in ("ACT", "MOVB", "DIRB", "RMASK")}
        at = layout.ram_pin(plan.ports, c.port, c.bit)
        chans.append({"name": c.name, "pin": pin, "pin_name": c.servo.pin, "cur": layout.CUR_BASE + at,
                      "state": layout.state_at(nports) + layout.STATE_BYTES * at, "act_bit": bit["ACT"],
                      "mov_bit": bit["MOVB"], "dir_bit": bit["DIRB"], "rm_bit": bit["RMASK"],
                      "dmax": _dmax(c.speed_class)})
    reset_ports = [{"sfr": f"P{port}", "mask": 0xFF ^ sum(1 << s.bit for s in plan.program.servos if s.port == port),
                    "names": ", ".join(s.name for s in plan.program.servos if s.port == port)}
                   for port in sorted({s.port for s in plan.program.servos})]

    fneed = []
    if uses["nodur"] or hosting:
        for cls, table in enumerate(plan.speed_tables):
            page = (plan.program.target.chip.code_bytes >> 8) - 2 * (len(plan.speed_tables) - cls)   # at the top
            # the runtime looks up only each class's largest |delta|: the table must not fall
            assert all(a <= b for a, b in zip(table, table[1:])), "a frames-needed table falls"
            fneed.append({"cls": cls, "page": page, "label": f"fneed{cls}", "dmax": _dmax(cls),
                          "lo": [v & 0xFF for v in table], "hi": [v >> 8 for v in table],
                          "t_dav": f"{float(plan.class_t_dav_us[cls]):.1f}"})
        if max(max(t) for t in plan.speed_tables) > 0xFFFF:
            raise layout.SlowServo("a servo is too slow for the frames-needed tables")
    pin_dmax = ["0"] * (8 * nports)       # by the pin's index in CUR (layout.ram_pin)
    for c in plan.channels:
        pin_dmax[layout.ram_pin(plan.ports, c.port, c.bit)] = _dmax(c.speed_class)

    ease_tables = [{"label": lab, "ease": ease, "frames": frames,
                    "values": list(next(st.ease_table for st in steps(plan)
                                   if isinstance(st, MoveStep) and (st.ease, st.frames) == (ease, frames)))}
                   for (ease, frames), lab in ctx.ease_tables.items()]
    if plan.period_us > target.max_period_us():     # lint's `period-too-long` reports this first
        raise layout.PeriodTooLong(
            f"a frame of {plan.period_us} us is {period_cycles} machine cycles at {target.describe()}, "
            f"and Timer0 counts at most {target_mod.TIMER_CYCLES}")
    host_ctx = _host(plan, chans, fneed, rxq, fbase, answers) if hosting else None
    passes = _first_steps(uses["kinds"], plan.first_step and not (plan.compact or host_ctx and host_ctx["plays"]), in_xram)
    lay_out = lambda: render("firmware.asm.j2",   # noqa: E731  (again when the spans change)
                  source="" if source is None else source.path.rsplit("/", 1)[-1], period=plan.period_us,
                  ram=ram.symbols, flag_bits=layout.flag_equates(), hl=layout.HLINE, framed_bit=framed_bit, bfull_bit=framed_bit + 1, txon_bit=framed_bit + 2, playh_bit=framed_bit + 3,
                  byte_maps=list(ctx.byte_maps.values()),
                  end_bit=layout.RECORD_FLAGS[-1].bit, chans=chans, e=e, hold=_hold(hold_off),
                  handler_bank=layout.HANDLER_BANK, cur_base=layout.CUR_BASE,
                  state_base=state_base, state_at=layout.state_at(nports), state_bytes=layout.STATE_BYTES, xstate=in_xram,
                  xram=ram.xsymbols, stack_base=stack_base, s=s,
                  compact=plan.compact, more=more, **{k: uses[k] for k in ("repeats", "eased", "holds")},
                  more_bit=layout.bit_address(layout.ADDR["FLAGS"], layout.MORE_BIT),
                  ports=e["ports"], reset_ports=reset_ports, main_ops=main_ops, sequences=sequences,
                  looks=ctx.looks, watch=watch, fcall=fcall,
                  lists=ctx.lists, flag_end=layout.FLAG["ENDF"], ease_tables=ease_tables,
                  fneed=fneed if uses["nodur"] else [], ftables=fneed, pin_dmax=pin_dmax,
                  **passes,
                  h=host_ctx,
                  period_cycles=period_cycles,
                  ctab=None if target.grid and not (stagger or merged) else {"lo": [target.width_cycles(n) & 0xFF for n in range(N_MAX + 1)],
                                                 "hi": [target.width_cycles(n) >> 8 for n in range(N_MAX + 1)]},
                  target_text=target.describe(), cycle_text=fmt_us(target.cycle_us),
                  div_text=f"{float(target.div_cycles):g}",
                  fall_text="500 + 8 x N" if target.grid else "round_half_up((500 + 8 N) us / t_c)")
    text = lay_out()
    deepest = runtime_stack(text, tuple(sq["label"] for sq in sequences))
    if deepest > costs.runtime_stack(deep_runtime, wrapped):
        raise RuntimeError(f"the runtime goes {deepest} bytes deep below a program's call, more than the "
                           f"{costs.runtime_stack(deep_runtime, wrapped)} the stack bound counts")
    ram_bytes = ram.total(8 * nports, stack_bytes, in_xram) + (costs.BUFB_RAM if bport is not None else 0)
    breakdown: dict[str, int] = {}
    for r in ctx.records:
        breakdown[f"moves of {r['owner']}"] = breakdown.get(f"moves of {r['owner']}", 0) + len(r["data"])
    if not target.grid:
        breakdown["edge time table C(N)"] = 2 * 256
    if ease_tables:
        breakdown["eased curve tables"] = sum(len(t["values"]) for t in ease_tables)
    if ctx.byte_maps:
        breakdown["maps of the bytes selects name"] = 32 * len(ctx.byte_maps)
    if fneed:
        breakdown[f"frames-needed tables ({len(fneed)} speed class{'es' if len(fneed) != 1 else ''})"] = 512 * len(fneed)
    if hosting:
        breakdown["host: the S table E(|delta|)"] = N_MAX + 1
    starts = move_starts(plan)
    names = (None, {}) if plan.compact or hosting or not plan.ports else \
        record_names(ctx.records, chans, plan.ports)

    # the ports' falls in one frame together: the last two's, and every port's (not for the ports at once)
    groups = (plan.ports[-2:], plan.ports)
    together = (0, 0) if len(plan.ports) < 2 or merged else costs.falls_together(
        target, port_motions(plan, joint=True)[0], tuple(c.port for c in plan.channels), groups,
        tuple(sum(costs.port_load(target, motions[p]).falls for p in which) for which in groups))

    def measure(text: str):
        return frame_budget(text, plan.ports, tuple(p["s"] for p in e["ports"]),
                            tuple(costs.port_load(target, motions[p]) for p in plan.ports),
                            None if len(plan.ports) != 1 or starts[plan.ports[0]] is None
                            else costs.start_loads(target, starts[plan.ports[0]]),
                            0 if s is None else s["byte_cycles"], bport is not None,
                            uses["sends"], uses["holds"], _pl_barred(plan, sequences) if hosting else None,
                            names, costs.beside_extra(target), mload, together)
    budget, work_from = measure(text)
    spans = e["spans"]
    if budget is not None and merged:
        budget = dataclasses.replace(budget, tops=tops, bottoms=bottoms)
    elif budget is not None:      # a port's span longer where the next port's sort or the serial line needs it
        spans = costs.fit_spans(target, dataclasses.replace(budget, bottoms=bottoms), tops)
        assert stagger or all(span >= costs.port_span(target, top, stepping) for span, top in zip(spans, tops)), \
            "a span shorter than its longest pulse and the step to the next rise"
        if spans != e["spans"]:     # the spans are immediates: the code's cycles must not change
            _set_rises(e, plan, period_cycles, spans)
            before, text = text, lay_out()
            if not wcet.same_cycles(before, text):     # (a rise beside a fall: its blocks' NOPs)
                again, work_from = measure(text)        # (where the work starts can move in the text)
                if again != budget:
                    raise RuntimeError("the code laid out again for its spans takes other cycles than before")
        budget = dataclasses.replace(budget, spans=spans, tops=tops, bottoms=bottoms)
    offsets = (tuple(costs.PORT_WRITE * k for k in range(nports)) if merged
               else tuple(costs.rise_offsets(plan.ports, target, spans).values()))
    run = None if budget is None else max(budget.emits or budget.rises, default=0)
    if run is not None and run > target.width_cycles(0):
        raise layout.HandlerTooSlow(       # its exit would add to Timer0 after the fall it waits for
            f"at {target.describe()} the edge handler's run at a port's rise takes {run} "
            f"machine cycles, longer than the {target.width_cycles(0)} before the earliest fall")
    if budget is not None and s is not None:
        try:
            _check_serial_rate(plan, budget)
        except layout.SerialTooFast as exc:
            limits.append(exc)
    least = floor = None
    try:
        least = None if budget is None else costs.frame_cycles(target, budget)
        floor = None if least is None else _send_floor(plan, budget, least)
        shortest = None if floor is None else target.us_at_least(floor)
        # a period below the shortest that holds by chance (with a serial line the need is a step
        # function of it) is refused too: every period accepted is one the minimum reported covers
        period_holds = least is None or (period_cycles >= least and costs.holds(target, budget, period_cycles))
    except costs.TooSlow as exc:
        if s is None:
            raise layout.HandlerTooSlow(str(exc)) from None
        if not any(isinstance(e, layout.SerialTooFast) for e in limits):
            limits.append(layout.SerialTooFast(f"at {serial.baud} baud {exc}", span=serial.span))
        shortest, period_holds = None, False
    if budget is not None and s is not None and period_holds and not limits:   # else `period-too-short` first
        try:
            _check_sends(plan, budget, period_cycles, shortest)
        except layout.SendOverrun as exc:
            exc.shortest_us = shortest      # this build holds the sends from there on
            limits.append(exc)
    if limits:
        raise limits[0] if len(limits) == 1 else layout.Several(limits)
    return AsmUnit(text, plan.period_us, plan.ports, offsets, ram_bytes, stack_bytes,
                   tuple(f["page"] for f in fneed),
                   tuple(sorted(breakdown.items(), key=lambda kv: (-kv[1], kv[0]))),
                   budget, work_from,
                   shortest,
                   target, plan.compact, tuple(ctx.selects), period_holds,
                   (flow_mod.HOST_XRAM_PER_SERVO * len(plan.channels) + layout.HOLD_BYTES * layout.host_holds(plan, in_xram)
                    + layout.RAM_SIZE - layout.state_at(nports)) if in_xram else 0,
                   passes["fused"] is not None and passes["sx"],
                   target.us_at_least(least) if floor is not None and least is not None and floor > least else None)


def _select_ram(ctx: _Ctx, ram: layout.RamAllocator) -> list[dict]:
    """RAM for the selects (their counts and samples before are on the stack, in their frames:
    `walk.select_frame`), and the levels frame_w looks at (empty: no meanwhile)."""
    if ctx.edge_ports:
        ram.alloc("SMP", len(ctx.edge_ports), "a look's samples of the ports with edge events")
    watched = sorted({o["slot"] for o in ctx.looks if o["meanwhile"] is not None})
    for level in watched:
        ram.alloc(f"WID{level}", 1, f"the select running its meanwhile body at level {level} (0: none)")
        ram.alloc(f"WSP{level}", 1, f"the stack pointer where it started the body")
    out = []
    for i, level in enumerate(watched):
        out.append({"slot": level, "selects": [o for o in ctx.looks if o["slot"] == level and o["meanwhile"] is not None],
                    "cleared": watched[i:], "last": i == len(watched) - 1,
                    "next": f"fw{watched[i + 1]}" if i + 1 < len(watched) else ""})
    return out


def _first_steps(kinds: set[tuple[bool, bool]], can: bool, xram: bool = False) -> dict:
    """Which moves set each pin up and step its first frame in one call (`Plan.first_step`), from
    the kinds of move records the program has, (eased, F found at run time): `fused` "linear"
    where a linear move of known F is one of them (an eased one then goes the two passes), else
    "eased" where an eased move of known F is, else None; with the motion state in XRAM (`xram`)
    "both" where both kinds are (setup_step tests EASED); `sx`: some record goes the two passes,
    `dda`: a linear one among them (without, neither pass is laid out)."""
    fused = None
    if can and xram:
        fused = {(True, True): "both", (True, False): "eased", (False, True): "linear"}.get(
            ((True, False) in kinds, (False, False) in kinds))
    elif can:
        fused = "linear" if (False, False) in kinds else "eased" if (True, False) in kinds else None
    two = {k for k in kinds if fused is None or k[1] or (fused == "linear" and k[0])}
    return {"fused": fused, "sx": bool(two) or not fused, "dda": any(not eased for eased, _ in two) or not kinds}


def _hold(cycles: int) -> str:
    if not cycles:
        return ""
    return ("        CLR     EA                      ; test build: interrupts held off\n"
            + "        NOP\n" * cycles + "        SETB    EA\n")


def _port_pins(plan: Plan, port: int) -> list[dict]:
    bits = [c.bit for c in plan.channels if c.port == port]
    return [{"i": i, "at": layout.SORT_PAIR * i, "bit": b, "cur": layout.CUR_BASE + layout.ram_pin(plan.ports, port, b),
             "bit_mask": 1 << b,
             "name": next(c.name for c in plan.channels if c.port == port and c.bit == b)}
            for i, b in enumerate(bits)]


def _most_lines(plan: Plan) -> int:
    """The servo lines of the port that has the most (the handler's items and `emit_list` are sized by it)."""
    return max((len(_port_pins(plan, port)) for port in plan.ports), default=1)


def _dmax(cls: int) -> str:
    """The RAM byte holding the largest |delta| of speed class `cls` in the current record."""
    return f"DMAX{cls}"


def _engine_ram(ram: layout.RamAllocator) -> None:
    """The edge handler's and frame_io's variables."""
    ram.alloc("RISEM", 1, "the lines of the next port to rise from buffer A that have a target")
    ram.alloc("EMC", 1, "ports the handler has taken from sort buffer A (counts on)")
    ram.alloc("SRT", 1, "ports frame_io has sorted into it (counts on)")


def _engine(plan: Plan, ram: layout.RamAllocator, period_cycles: int, bport: int | None,
            spans: tuple[int, ...], stepping: bool, stagger: bool = False) -> dict:
    """The edge handler's and frame_io's numbers (templates irq.asm.j2, frame_irq.asm.j2).
    `bport`: the port sorted into buffer B (None: every port goes through buffer A); `spans`: each
    port's rise to the next one's (costs.fit_spans); `stepping`: a rise can come as a step of the last
    fall's entry (costs.RISE_STEP)."""
    target = plan.program.target
    ports = []
    for k, port in enumerate(plan.ports):
        last = k == len(plan.ports) - 1
        nxt = plan.ports[0 if last else k + 1]
        ports.append({"port": port, "pins": _port_pins(plan, port), "win": f"win_p{port}", "last": last,
                      "cur0": layout.CUR_BASE + layout.ram_pin(plan.ports, port, 0),
                      "state0": layout.state_at(len(plan.ports)) + layout.STATE_BYTES * layout.ram_pin(plan.ports, port, 0),
                      "next_port": nxt, "next_win": f"win_p{nxt}"})
        ports[-1]["s"] = len(ports[-1]["pins"])
        ports[-1]["others"] = ports[-1]["s"] - 1      # the pairs after the first
        # built for size, a port whose servos are its pins 0, 1, ... loads its pairs in a loop
        ports[-1]["looped"] = plan.compact and [pin["bit"] for pin in ports[-1]["pins"]] == list(range(ports[-1]["s"]))
        ports[-1]["all_mask"] = sum(pin["bit_mask"] for pin in ports[-1]["pins"])
    most = _most_lines(plan)
    ram.symbols += [("WN", layout.SORT_BASE, "sort buffer A: N of pair i at WN + 2i (distinct N, ascending, once sorted)"),
                    ("WM", layout.SORT_BASE + 1, "sort buffer A: the lines of pair i at WM + 2i")]
    if bport is not None:
        ram.symbols += [("BUFB", layout.BUFB_BASE, f"sort buffer B, P{bport}'s distinct N and lines in pairs (indirect)"),
                        ("RISEMB", layout.BUFB_BASE - 1, f"the lines of P{bport} that have a target (indirect)")]
    # frame_io's order: the port with buffer B first (sorted before the work between frames), then
    # the others in port order; the engine starts once the first port's N are sorted
    order = sorted(ports, key=lambda p: p["port"] != bport)
    blocks = [{"p": p, "to_b": p["port"] == bport, "start": p is ports[0]} for p in order]
    near_dn = costs.near_dn(target, costs.SPLIT)
    if target.grid:
        ctime = ["SWAP    A                       ; t = C(N) = 500 + 8 N, in R7:A", "RR      A",
                 "MOV     R7, A", "ANL     A, #0xF8", f"ADD     A, #<{target.width_cycles(0)}", "XCH     A, R7",
                 "ANL     A, #0x07", f"ADDC    A, #>{target.width_cycles(0)}", "XCH     A, R7"]
    else:
        ctime = ["MOV     R7, A                   ; t = C(N) from the table (DPTR = ctab), in R7:A",
                 "MOVC    A, @A+DPTR", "XCH     A, R7", "INC     DPH", "MOVC    A, @A+DPTR", "XCH     A, R7"]
    table = [] if target.grid else ["MOV     DPTR, #ctab"]
    sizes = sorted({p["s"] for p in ports})
    e = {
        "vmin": costs.PAD_FROM, "vmax": costs.PAD_FROM + costs.LATENCY, "latency": costs.LATENCY,
        "pad_end": costs.PAD_FROM + costs.LATENCY + 2,
        "stop": costs.STOP, "add": costs.STOP + 1,        # ~interval + STOP + 1 = 65536 - interval + STOP
        "entry": costs.ENTRY, "split": costs.SPLIT, "sled_add": costs.SLED + 8,   # ~gap + SLED + 8 = SLED + 7 - gap
        "later": list(range(1, most)),
        "sled": costs.SLED, "fall_off": costs.SLED, "exit_off": costs.SLED + 7,
        "exitn_off": costs.SLED + 10, "rise_off": costs.SLED + 13,
        "steps": stepping, "rs_off": costs.SLED + 21, "rstep_off": costs.SLED + 29,
        "rsled": costs.RSLED, "rise_step": costs.RISE_STEP, "rsled_end": costs.RSLED + costs.RISE_STEP,
        # stagger: each window's fall code, its exits, then a sled and the next port's rise
        "stagger": stagger, "step": costs.STEP, "beside": costs.BESIDE, "rfar_off": costs.SLED + 10, "end_off": costs.SLED + 13,
        "rs_base": costs.SLED + 16, "rland": 2 * costs.SLED + 16, "rsled_add": (2 * costs.SLED + 24) % 0x100,
        "first_off": 2 * costs.SLED + 24,
        "merged": False, "compact": plan.compact, "loads": sorted({p["s"] for p in ports if p["looped"]}),
        "grid": target.grid, "ports": ports, "most": most, "near_dn": near_dn, "bport": bport, "blocks": blocks,
        "period": period_cycles, "t0_first": 65536 - period_cycles,     # no servo lines: Timer0 times a frame,
        "t0_on": 65536 - period_cycles + T0_STILL, "t0_still": T0_STILL,  # and carries on with its count
        "ctime": "\n".join("        " + line for line in table + ctime),
        "ctime_kept": "\n".join("        " + line for line in ctime),     # where DPTR is ctab already
        "sorts": [{"s": n, "at": [layout.SORT_PAIR * i for i in range(n)],
                   "network": [(a, b, layout.SORT_PAIR * a, layout.SORT_PAIR * b) for a, b in costs.SORTING_NETWORKS[n]]}
                  for n in sizes],
    }
    if stagger:
        e["rise_off"] = e["first_off"]       # the first frame's rise, in the first port's window
    _set_rises(e, plan, period_cycles, spans)
    return e


def _set_merged(e: dict, plan: Plan, groups: int) -> None:
    """The numbers of the build whose ports' pulses overlap (irq_merged.asm.j2, frame_merged.asm.j2),
    with room for `groups` groups of falls in a frame (`costs.merged_load`)."""
    m = len(plan.ports)
    target = plan.program.target
    step, split = costs.merged_step(m), costs.merged_split(m)
    sled = split - 1 - step     # a step with gap g from `step` to `split` - 1 enters at sled + step - g
    e.update(merged=True, mwin="win_m", mstep=step, mstep_port=costs.PORT_WRITE, msplit=split, msled=sled,
             msled_add=(sled + step + 1) % 0x100, fall_off=sled, mexit_off=sled + 4 * m + 3,
             mend_off=sled + 4 * m + 6, groups=groups,
             mnear_dn=costs.near_dn(target, split))


def _set_rises(e: dict, plan: Plan, period_cycles: int, spans: tuple[int, ...]) -> None:
    """Each port's rise in the engine's numbers `e`: from the first port's, each `spans` after the
    one before; the next port's rise after it (the first's, a frame later, after the last)."""
    rise = costs.rise_offsets(plan.ports, plan.program.target, spans)
    for p in e["ports"]:
        p["rise"] = rise[p["port"]]
        p["rnext"] = (period_cycles if p["last"] else rise[p["next_port"]]) - p["rise"]
        p["rest_add"] = (costs.STOP - p["rnext"]) % 0x10000   # no fall: straight to the next rise
        # a last fall less than SPLIT cycles before the next rise: the rise is a step of its entry
        # (gap g from RISE_STEP up: rsled offset RSLED + RISE_STEP - g, from C(N)'s low byte; 255: never)
        target = plan.program.target
        p["step_n"] = next((n for n in range(251) if p["rnext"] - target.width_cycles(n) < costs.SPLIT), 255)
        c0 = target.width_cycles(0) if target.grid else 0
        p["step_add"] = (c0 + costs.RSLED + costs.RISE_STEP - p["rnext"]) % 0x100
        # stagger: the highest N whose fall comes before the next port's rise, and the N after it
        p["nstar"] = max((n for n in range(251) if target.width_cycles(n) < p["rnext"]), default=-1)
        p["n_after"] = p["nstar"] + 1
        p["upto"], p["rise_at"] = ((f"N <= {p['nstar']}", f"after the N up to {p['nstar']}") if p["nstar"] >= 0
                                   else ("N < 0, never", "before every N"))
        # rins takes the rise for a step only where nstar - N is below this (its gap from C(N) is then
        # found from low bytes): 0 where the rise is SPLIT or more after C(nstar), so never a step
        # (the last port's, or one whose span its sort made longer, can be 256 cycles or more after)
        far = p["nstar"] >= 0 and p["rnext"] - target.width_cycles(p["nstar"]) >= costs.SPLIT
        p["near_rise"] = 0 if far else e["near_dn"]
        _set_beside(e, p, target)
    for k, p in enumerate(e["ports"]):
        before = e["ports"][k - 1]
        p["prev_port"], p["prev_rnext"] = before["port"], before["rnext"]
    e["spans"] = spans


def _set_beside(e: dict, p: dict, target) -> None:
    """Where rises come beside falls (`costs.beside`), port p's rise among its falls may come BESIDE
    cycles after the fall of N j = nstar (`combo`): the blocks of its window that put out that fall
    and the rise (FR), both and the fall of j + 1 (FRF), or the rise and the fall of j + 1 (RF), each
    entered as a step of exactly its gap from an edge at N j - 1, and the items stagger_emit writes
    for them. Their offsets (after the rise, and in the first port's window the first frame's rise)
    and the NOPs that make each gap (`costs.beside_gaps`). Every port of such a build has the same
    code whatever its rise, but for immediates: where the rise is STEP or more from every fall, no N
    is j (the spans are fitted after a first layout, and the code keeps its cycles: wcet.same_cycles)."""
    p["beside"] = e["stagger"] and costs.beside(target)
    if not p["beside"]:
        return
    c = target.width_cycles
    j = p["nstar"]
    g_fr, g_j = costs.beside_gaps(target)        # C(j) - C(j - 1), C(j + 1) - C(j): the same for every j
    g_rf, d2 = g_fr + costs.BESIDE, g_j - costs.BESIDE     # the edge at j - 1 to the rise, the rise to j + 1
    # (a last port's next rise, a frame later, can be BESIDE after the fall of an N its lines never reach)
    combo = p["combo"] = (1 <= j < N_MAX and p["rnext"] - c(j) == costs.BESIDE
                          and (c(j) - c(j - 1), c(j + 1) - c(j)) == (g_fr, g_j))
    assert g_fr >= costs.STEP and d2 >= 3, (g_fr, d2)
    never = 0xFE                                 # no N is 0xFE
    base = e["first_off"] + (8 if p is e["ports"][0] else 0)
    fr = g_fr - costs.STEP + 11
    frf = g_fr - costs.STEP + 15 + d2 - 3
    p.update(bj=j if combo else never, bjm=j - 1 if combo else never, bj1=j + 1 if combo else never,
             bcjm=c(j - 1) & 0xFF if combo else 0, bcj1=c(j + 1) & 0xFF if combo else 0,
             fr_nops=g_fr - costs.STEP, rf_nops=g_rf - costs.STEP, d2_nops=d2 - 3,
             fr_off=base, frf_off=base + fr, rf_off=base + fr + frf)
    assert p["rf_off"] <= 0xFF, "a rise beside a fall: the window's blocks are out of a jump's reach"


@functools.lru_cache(maxsize=16)
def runtime_stack(text: str, sequence_labels: tuple[str, ...]) -> int:
    """The most bytes any runtime routine the code calls puts on the stack below its call (return
    addresses and pushes included), read from the code: costs.runtime_stack must cover it. (Kept
    for the last texts: the builds the period stage tries for one program often lay out the same.)"""
    code = wcet.Code(text)
    called = sorted({i.args[0] for i in code.instrs if i.op in ("LCALL", "ACALL")} - set(sequence_labels))
    memo: dict[int, int] = {}
    return max((code.stack_below(name, memo) for name in called), default=0)


NAMES_MOST = 64     # distinct records (named servos, flags) the analysis follows one by one (`record_names`)
_IN_RECORD = sum(f.value for f in layout.RECORD_FLAGS if f.in_record)


def record_names(records: list[dict], chans: list[dict], ports: tuple[int, ...]
                 ) -> tuple[wcet.Names | None, dict]:
    """wcet's `Names` fact for a build for speed without a host, and each move statement's indices
    in its `sets`, by its id (a statement a frameless `repeat` writes out more than once can have several).
    None where the records have more than NAMES_MOST distinct pairs of named servos and flags:
    each path is then charged as if its record named every servo."""
    named = [r for r in records if "names" in r]
    kinds = sorted({(r["names"], r["flags"] & _IN_RECORD, r["act"]) for r in named})
    if not kinds or len(kinds) > NAMES_MOST:
        return None, {}
    index = {v: i for i, v in enumerate(kinds)}

    def bits(kind: str, port: int) -> tuple[str | None, ...]:
        by_bit = {c["pin"] - 8 * port: _hex8(c[kind]) for c in chans if c["pin"] // 8 == port}
        return tuple(by_bit.get(b) for b in range(8))
    names = wcet.Names(first=f"RMASK+{ports[0]}", rmask=tuple((f"RMASK+{p}", bits("rm_bit", p)) for p in ports),
                       movb=tuple((f"MOVB+{p}", bits("mov_bit", p)) for p in ports),
                       sets=tuple(masks for masks, _, _ in kinds),
                       flags=tuple(frozenset((f.name, bool(flags & f.value)) for f in layout.RECORD_FLAGS if f.in_record)
                                   for _, flags, _ in kinds),
                       act=tuple((f"ACT+{p}", bits("act_bit", p)) for p in ports), acts=tuple(act for _, _, act in kinds))
    of_step: dict = {}
    for r in named:
        of_step.setdefault(r["step"], set()).add(index[(r["names"], r["flags"] & _IN_RECORD, r["act"])])
    return names, of_step


_BUDGETS_MOST = 16      # the texts `frame_budget` keeps the answer for
_budgets: OrderedDict = OrderedDict()


def frame_budget(text: str, *args, **kwargs) -> tuple[costs.Budget | None, str]:
    """`_frame_budget`, kept for the last texts with the same facts: the builds the period stage
    tries for one program (with and without the host's holds or `first_step`, where those change
    nothing, and each command's own period stage) often lay out the same text."""
    key = (text, repr((args, sorted(kwargs.items()))))
    got = _budgets.get(key)
    if got is None:
        got = _budgets[key] = _frame_budget(text, *args, **kwargs)
        while len(_budgets) > _BUDGETS_MOST:
            _budgets.popitem(last=False)
    else:
        _budgets.move_to_end(key)
    return got


def _frame_budget(text: str, ports: tuple[int, ...], lines: tuple[int, ...], loads: tuple[costs.PortLoad, ...],
                 starts: frozenset | None = None, byte_cycles: int = 0, last_in_b: bool = False,
                 sends: bool = False, holds: bool = True,
                 barred: tuple[str, tuple[tuple[str, str], ...]] | None = None,
                 names: tuple[wcet.Names | None, dict] = (None, {}), beside: int = 0,
                 merged: costs.MergedLoad | None = None, together: tuple[int, int] = (0, 0)) -> tuple[costs.Budget | None, str]:
    """What this assembly takes per frame (see costs.frame_cycles), and where the longest work
    between frames starts (or why it cannot be bounded). `loads`: each port's worst frame
    (costs.port_load); its sort is the longest path less the swaps no frame makes. `starts`: one
    port's move starts (costs.start_loads), so that the work of a path that starts a move is
    paired with that move's first frame (None: every path with the worst frame). `byte_cycles`:
    a byte's time on the serial line (0: the program has none); `sends`: the program has a `send`;
    `holds`: the code has hold records (without, every path that reads a record reads a move's);
    `barred`: the code no RET returns to while a sequence `PL` started plays (`_pl_barred`);
    `names`: which servos each record names, and each move statement's records (`record_names`),
    so that a path that reads a record is charged for the servos that record names. `beside`: what
    a rise beside a fall adds to the handler's cycles for its port (`costs.beside_extra`). `together`:
    the most of the last two ports' falls in one frame, and of every port's (`costs.falls_together`;
    0: not known together)."""
    try:
        facts = ("FLAGS", frozenset(f.name for f in layout.RECORD_FLAGS if f.in_record), frozenset({"PLAYH"}),
                 barred, names[0])
        code = wcet.Code(text, *facts)
        frames, index = wcet.frames_code(text, *facts)      # the work between frames: shared by the builds
        try:
            work, at = frames.between_frames()
            at = index(at)
        except wcet.WcetError:
            frames = code                           # its message, with this text's lines
            work, at = frames.between_frames()
        serial = {}
        if byte_cycles:     # from the vector's LCALL (2): the handler is at the vector
            serial = {"serial_run": 2 + code.longest("uart_isr", set()),
                      "serial_head": 2 + code.straight("uart_isr", "ui_got") + 1,
                      "byte_cycles": byte_cycles, "serial_sends": sends}
        if merged is not None:
            return _merged_budget(code, work, ports, lines, loads, merged, serial), code.label_at(at)
        fs = tuple(code.longest(f"fs{p}", {f"fi{q}" for q in ports} | {"fi_done"}) for p in ports)
        # with rises among falls a port is sorted first, then its items written once the handler
        # took the port before's (ft: after the wait): the sort's term is both
        items = tuple(code.longest(f"ft{p}", {f"fs{q}" for q in ports} | {"fi_done"}) - _unread(code, p, load.distinct)
                      for p, load in zip(ports, loads)) if ports and f"ft{ports[0]}" in code.labels else ()
        # and each port's up to their header and first edge (stagger_emit.asm.j2's loop)
        heads = tuple(code.longest(f"ft{p}", set(items_loop(p))) for p in ports) if items else ()
        head = heads[0] if heads else 0
        sorts = tuple(f - _unswapped(code, n, load.swaps) + (items[k] if items else 0)
                      for k, (f, n, load) in enumerate(zip(fs, lines, loads)))
        paired = {}
        if starts:      # the paths that read a move record (a hold's HOLDF set, or not known, is not one)
            by = frames.by_record()
            moving = {tag: v for tag, v in by.items() if tag is not None and (("HOLDF", False) in tag or not holds)}

            def work_of(eased: bool, runtime_f: bool, step) -> int:    # the paths this move's records can take
                recs = names[1].get(step)
                return max((v for tag, v in moving.items()
                            if ("EASED", not eased) not in tag and ("NODUR", not runtime_f) not in tag
                            and (recs is None or dict(tag).get(wcet.REC) in recs | {None})), default=work)

            paired = {"start_frame": max(work_of(e, r, step) + fs[0] - _unswapped(code, lines[0], sw) + falls
                                         for falls, sw, e, r, step in starts),
                      "other_work": max((v for tag, v in by.items() if tag not in moving), default=0)}
        exits = {f"exit_p{p}" for p in ports} | {"exit_fall"}
        stepped = bool(ports) and f"emit_s{ports[0]}" in code.labels     # rises can come as steps
        staggered = bool(ports) and f"exit_rf{ports[0]}" in code.labels   # or among the falls before them
        emits: tuple[int, ...] = ()
        if staggered:   # from the last edge: the step's read and jump (4), LJMP (2), the handover to the RETI
            emits = tuple(costs.ENTRY + 6 + code.longest(f"emit_s{p}", {"exit_timer"})
                          + code.longest_exit({"exit_timer"}) for p in ports)
            rises = tuple(costs.SPLIT - 1 + beside + v - costs.ENTRY for v in emits)
        else:
            rises = tuple((costs.RISE_HEAD if stepped else costs.ENTRY + 2) + code.longest(f"emit_p{p}", exits)
                          + code.longest_exit(exits) for p in ports)
    except wcet.WcetError as exc:
        return None, str(exc)
    return (costs.Budget(work, sorts, rises, lines, tuple(load.falls for load in loads), *together, last_in_b=last_in_b,
                         steps=stepped and not staggered, stagger=staggered, emits=emits, items=items, head=head, heads=heads,
                         **paired, **serial),
            code.label_at(at))


def items_loop(port: int) -> tuple[str, str]:
    """The labels where stagger_emit.asm.j2's loop over a port's other edges begins, with a rise
    beside a fall or without: the header and the first edge are written before it."""
    return f"fe{port}_l", f"fb{port}_l"


def _merged_budget(code: wcet.Code, work: int, ports: tuple[int, ...], lines: tuple[int, ...],
                   loads: tuple[costs.PortLoad, ...], merged: costs.MergedLoad, serial: dict) -> costs.Budget:
    """The budget of the build whose ports' pulses overlap (frame_merged.asm.j2, irq_merged.asm.j2):
    frame_io's sorts before its wait (less the swaps no frame makes) and its return once the rise's
    items are read, its merging between the two (and the part of it up to the items the rise's entry
    reads: `costs.merged_late`), the rise's entry and the falls' (`costs.merged_load`), and the last
    group's exit to the merging; with a serial line, its handler's (`serial`: as frame_budget's)."""
    m = len(ports)
    # from a group's last edge: the next item's read and jump (4), the LJMP (2), the exit to its RETI
    exit_ = 6 + code.longest_exit({"exit_far", "exit_end"})
    if exit_ > costs.MEXIT:
        raise wcet.WcetError(f"an exit of the edge handler takes {exit_} cycles, more than the {costs.MEXIT} "
                             "its sled allows for")
    sorts = code.longest("frame_io", {"fm_wait"}) - sum(_unswapped(code, n, load.swaps) for n, load in zip(lines, loads))

    def spin(start: str, end: str) -> int:      # a wait's loop: what it waits for is seen within two passes
        return 2 * sum(ins.cycles for ins in code.instrs[code.labels[start]:code.labels[end]])
    end = 6 + code.longest("exit_end", set())
    # the return once the rise's items are read: its wait, then the RET (the rise's entry is in `rises`)
    back = spin("fm_rise", "fi_done") + code.longest("fi_done", set())
    group = costs.PORT_WRITE * (m - 1)         # a group's first edge to its last
    return costs.Budget(work, (sorts + back,), (costs.ENTRY + group + exit_,), lines, (merged.falls,),
                        merged=True, merge=code.longest("fm_post", {"fm_rise"}),
                        head=code.longest("fm_post", {"mg0_m", "fm_rise"}),
                        tail=costs.ENTRY + group + end + spin("fm_wait", "fm_post"), **serial)


def _pl_barred(plan: Plan, sequences: list[dict]) -> tuple[str, tuple[tuple[str, str], ...]] | None:
    """wcet's `barred` fact: while PLAYH is set (a sequence `PL` started plays, host_plays to
    host_free), no RET returns into `main` or into a sequence `PL` cannot play (program.asm.j2
    lays them out from `main` to `looks_start`, in this order)."""
    playable = set(host_playable(plan.program))
    if not playable:
        return None
    labels = ["main"] + [sq["label"] for sq in sequences] + ["looks_start"]
    names = [None] + [sq["name"] for sq in sequences]
    return "PLAYH", tuple((a, b) for a, b, name in zip(labels, labels[1:], names) if name not in playable)


def _unread(code: wcet.Code, port: int, distinct: int) -> int:
    """The cycles the longest path through a port's items (stagger_emit.asm.j2) counts for passes of
    its loop over the pairs that no frame makes: where its lines with a target fall at `distinct` N
    at most, the header reads the first pair and at most distinct - 1 passes read one more; every
    other pass reads the end mark and writes no fall (no call of `efall`). The longest path counts
    each pass as the longest that makes no call made once in the loop, and one pass as the longest
    that makes it (the rise placed among the falls): so each pass that reads the end mark is
    charged the difference to the longest pass that calls no `efall`, less one pass where such a
    pass with the call made once can take longer than the longest pass does with it."""
    head = next((f"{pre}{port}_p" for pre in ("fe", "fb") if f"{pre}{port}_p" in code.labels), None)
    if head is None:
        return 0
    count, full, without, short, short_once = code.passes(head, {"efall"})
    ends = count - max(distinct - 1, 0)
    if short_once - short > full - without:
        ends -= 1
    return max(ends, 0) * (without - short)


def _unswapped(code: wcet.Code, n: int, swaps: int) -> int:
    """The cycles of the swaps the longest path through sort<n> counts (every comparator's) and
    no frame makes: all but `swaps` of them, the cheapest first."""
    bodies = sorted(code.straight(f"sw{n}_{i}", f"so{n}_{i}") for i in range(1, len(costs.SORTING_NETWORKS[n]) + 1))
    return sum(bodies[:len(bodies) - swaps])


def _serial(serial, ram: layout.RamAllocator, sending: bool, rxq: int, q: int) -> dict:
    """The serial line's numbers (serial.asm.j2) and its counters (its queues are allocated with
    the other buffers). `sending`: the program sends (else no transmit side); `rxq`: the receive
    queue's size; `q`: the transmit queue's (flow.tx_queue)."""
    ram.alloc("RXW", 1, "the receive queue's slot for the next byte received")
    ram.alloc("RXR", 1, "the receive queue's slot of the oldest byte (RXW: none)")
    ram.alloc("RXB", 1, "the byte just received")
    if sending:
        ram.alloc("TXW", 1, "bytes the program queued to send (counts on)")
        ram.alloc("TXR", 1, "bytes the serial handler sent from the queue (counts on)")
    return {"baud": serial.baud, "th1": serial.th1, "smod": serial.smod, "rate": f"{float(serial.actual):.1f}",
            "byte_cycles": target_mod.byte_cycles(serial.th1, serial.smod), "queue": q, "mask": q - 1,
            "full_bit": q.bit_length() - 1, "sends": sending, "rxq": rxq}


def _rx_ring(base: int, slots: int) -> dict:
    """The receive queue's ring of `slots` slots at `base`: its first slot (rx_base), the address
    past its last slot (rx_end), and what turns rx_end into base under XRL (rx_wrap)."""
    end = base + slots          # past RAM_SIZE only where RamAllocator.check refuses the layout
    return {"rx_slots": slots, "rx_base": base, "rx_end": end & 0xFF, "rx_wrap": base ^ (end & 0xFF)}


HOST_WORDS = ("P", "PO", "S", "T", "Q", "QP", "V", "VE", "VER", "ST", "STO", "STOP", "PL", "SQ")
assert HOST_WORDS[:4] == ("P", "PO", "S", "T")      # host_item: the words below T are an entry's options


T0_STILL = 8            # frame_irq.asm.j2, no servo lines: the cycles Timer0 stands still at a frame's end
HOST_ANSWERS = 3        # answers (Q, QP, VER) that wait in HAQ while the reading goes on, where RAM allows (else 1)
# The variables of host.asm.j2 (flow.HOST_VARS bytes) and its per-servo arrays (flow.HOST_PER_SERVO bytes a servo).
HOST_VARS = (("HST", 1, "host parser: its flags"), ("HST2", 1, "host parser: more flags"),
             ("HW", 1, "host parser: the word being read"), ("HNUM", 2, "host parser: the number"),
             ("HCH", 1, "host parser: the servo of the open entry (0xFF: none)"),
             ("HEP", 2, "host parser: the entry's P (or PO + 100)"),
             ("HES", 2, "host parser: the entry's S"), ("HARG", 2, "host parser: T (0 without, once a group line has ended), or a command's number"),
             ("HCMD", 1, "host parser: the line's command word"),
             ("HLINE", 1, "lines for host_step: bit 0 groups, 1 VER, 2 offsets, 3 a sequence, 4 HAQ full, 5 STOP"),
             ("HVER", 1, "the next byte of the answer to VER (bits 6, 7: the answers waiting in HAQ)"),
             ("HAQ", 1, "the answers waiting, in order (0xFF: VER's; HVER's bits 6, 7 count them)"),
             ("HPLAY", 1, "while a sequence `PL` started plays: the stack pointer it started at (0: none)"))
HOST_ARRAYS = (("HPW", 2, "per servo: the pending width (high byte 0xFF: none), or offset + 100 (0xFC)"),
               ("HPS", 2, "per servo: the pending S (0: none)"), ("HOF", 1, "per servo: its offset in us"))
HOST_TAGS = ("HTAG", 1, "per servo: the generation (HGEN) of the line that wrote its pending entry")
assert sum(v[1] for v in HOST_VARS) == flow_mod.HOST_VARS and sum(a[1] for a in HOST_ARRAYS) == flow_mod.HOST_PER_SERVO
assert sum(a[1] for a in HOST_ARRAYS + (HOST_TAGS,)) == flow_mod.HOST_XRAM_PER_SERVO


def _host(plan: Plan, chans: list[dict], tables: list[dict], rxq: int, fbase: str, answers: int) -> dict:
    """The numbers of host.asm.j2: per servo its record and table, the channel map and the tables
    of the protocol's arithmetic (docs/host-protocol.md; servoc.ssc32 is the same in Python)."""
    from . import ssc32
    from .model import host_channel
    period = plan.period_us
    # a reading of host_passes bytes is counted in R7 and may count HGEN up once a byte, the commit
    # once more (host_gen)
    assert host_passes(plan) <= 0xFE, "the host's reading is counted in one byte"
    st_q, st_e = ssc32.speed_t_parts(period)        # T(d) = d x Q + E(d): one page, not three
    assert st_q < 0x10000 and all(d * st_q + st_e[d] == ssc32.speed_t(d, period) for d in range(N_MAX + 1))
    words = {w: i + 1 for i, w in enumerate(HOST_WORDS)}
    playable = host_playable(plan.program)
    table = [0xFF] * (32 * (len(HOST_WORDS) + 1))
    for w, i in words.items():
        before = words.get(w[:-1], 0)
        table[32 * before + ord(w[-1]) - 0x40] = i
    chan_map, chan_act, chan_mask, chan_cur = [0xFF] * 32, [0] * 32, [0] * 32, [0] * 32
    out = []
    for h, (c, ch) in enumerate(zip(plan.channels, chans)):
        servo = c.servo
        lo, hi = servo.limit if servo.limit is not None else (0, N_MAX)
        k = host_channel(servo)
        chan_map[k], chan_act[k], chan_mask[k], chan_cur[k] = h, layout.ADDR["ACT"] + servo.port, 1 << servo.bit, ch["cur"]
        lim = ssc32.output_params(lo, hi, servo.reverse, servo.trim)
        out.append({**ch, "port": servo.port, "mask": 1 << servo.bit, "channel": k, "lim": lim,
                    "lim_what": f"limit {lo}..{hi}{', reverse' if servo.reverse else ''}, trim {servo.trim}",
                    "fneed": tables[c.speed_class]["label"]})
    return {"count": len(out), "chans": out,
            "chan_act": chan_act, "chan_mask": chan_mask, "chan_cur": chan_cur, "queue": rxq, "passes": host_passes(plan), "answers": answers, "words": words, "words_table": table,
            "chan_map": chan_map, "ports": plan.ports, "rt": ssc32.time_factor(period),
            "qp": [(500 + 8 * n) // 10 for n in range(N_MAX + 1)],
            "st_q": st_q, "st_e": st_e,
            "version": ssc32.VERSION_REPLY.decode().rstrip("\r"),
            "plays": [_seq_label(plan, name) for name in playable], "fbase": fbase,
            "play_list": [{"n": [q.name for q in plan.program.sequences].index(name), "name": name,
                           "label": _seq_label(plan, name)} for name in playable],
            "playable": [int(q.name in playable) for q in plan.program.sequences],
            "xram": host_xram(plan), "holds": layout.host_holds(plan), "hold_bytes": layout.hold_bytes(host_xram(plan)),
            "answers_on": flow_mod.reads_answers(plan),
            "gen_limit": 0xFF - host_passes(plan) - 1}


def _bytes(n: int) -> str:
    return "any number of bytes" if n >= UNBOUNDED else f"{n} byte{'s' if n != 1 else ''}"


def _check_serial_rate(plan: Plan, budget: costs.Budget) -> None:
    """No byte received is lost (costs.py), at the `serial` declaration."""
    target = plan.program.target
    serial = plan.program.serial
    late = costs.serial_latency(target, budget)
    if late > costs.rx_gap(budget.byte_cycles):
        works = [b for b in target_mod.working_bauds(target)
                 if costs.rx_gap(target_mod.byte_cycles(*target_mod.timer1_baud(target, b)[:2])) >= late]
        raise layout.SerialTooFast(
            f"at {serial.baud} baud a byte comes every {budget.byte_cycles} machine cycles "
            f"({costs.rx_gap(budget.byte_cycles)} from a host 2 % fast), but the edge handler can "
            f"keep the serial line waiting {late} cycles (its longest run: a port's lines and the next port's rise)",
            help=(f"use `serial {works[-1]}`" if works else "use a slower rate") +
                 ", or fewer servo lines on one port, or a faster crystal", span=serial.span)


def _send_need(plan: Plan, budget: costs.Budget) -> int:
    """A run of sends leaves the line free for the next if its bytes are out before it comes: the
    cycles that takes after the run's first byte is queued (0: the program never sends)."""
    if plan.program.serial is None or not budget.byte_cycles:
        return 0
    return send_run(plan) * budget.byte_cycles + costs.serial_latency(plan.program.target, budget)


def _send_gap_at(plan: Plan, budget: costs.Budget, need: int, period_cycles: int) -> tuple[int, int]:
    """(gap, cap): the fewest frames between two runs of sends, counted up to `cap`, the frames of
    `period_cycles` that surely leave the line the `need` cycles (a gap of cap or more needs no
    more)."""
    cap = -(-(need + budget.work) // period_cycles) + 1
    return send_gap(plan, cap), cap


def _send_floor(plan: Plan, budget: costs.Budget, shortest: int) -> int:
    """`shortest` (cycles), or the period from which on the runs of sends, `send_gap` frames apart
    at the fewest, leave the line time for theirs (`_check_sends`) when that is longer."""
    need = _send_need(plan, budget)
    if not need:
        return shortest
    gap, cap = _send_gap_at(plan, budget, need, shortest)
    return shortest if gap >= cap else max(shortest, -(-(need + budget.work) // gap))


def _check_sends(plan: Plan, budget: costs.Budget, period_cycles: int, shortest: int | None = None) -> None:
    """The bytes sent never outrun the line (costs.py), at the program's sends; `shortest`: the
    shortest period (µs) at which they do not, which the help names."""
    serial = plan.program.serial
    run = send_run(plan)
    if run:
        # the next run comes `gap` frames later, less the work that can come before it
        need = _send_need(plan, budget)
        gap, _ = _send_gap_at(plan, budget, need, period_cycles)
        if need > gap * period_cycles - budget.work:
            sends_ = [st for st in steps(plan) if isinstance(st, SendStep)]
            frames = -(-(need + budget.work) // period_cycles)      # frames that leave the line time enough
            raise layout.SendOverrun(
                f"the program can send {_bytes(run)} {gap} frame{'s' if gap != 1 else ''} after sending before; at "
                f"{serial.baud} baud that takes {need} machine cycles, more than the "
                f"{gap * period_cycles - budget.work} there are",
                help=f"keep at least {frames} frames ({fmt_ms(frames * plan.period_us)}: a `hold` of that long) "
                     "between the sends, send fewer bytes at a time, or use a faster rate"
                     + (f"; or `frame {fmt_ms(shortest).replace(' ', '')}` or longer, the shortest period at which "
                        "they fit" if shortest is not None and shortest > plan.period_us else ""),
                span=sends_[0].span if sends_ else serial.span,
                labels=tuple((st.span, "sends too") for st in sends_[1:4]) + ((serial.span, "the line's rate"),))
