"""Code generation: Plan -> AsmUnit (sdas8051 assembly text).

The generator computes every number the firmware needs (RAM addresses,
records, sorting networks, delay loop counts, jump offsets) and hands them to
the jinja2 templates in `firmware_templates/`, which only lay out text.

Firmware shape (AT89C52, 12 MHz, 1 us per machine cycle):
- reset drives every servo line low, starts Timer2 in auto-reload mode with
  period P, and runs the program code;
- the program is native code: a move is `MOV DPTR,#record / LCALL do_move`,
  a hold `LCALL do_hold`, `repeat` keeps its counter on the stack, `loop` is a
  jump, `play` an LCALL of the sequence's code;
- every frame, each port in use is prepared (its N sorted with their AND
  masks by an unrolled sorting network, equal N merged, differenced into an
  edge chain), then, on the timer tick, pulsed by a routine of fixed length:
  one ORL raises the port's active lines, a fixed head of 493 cycles, then a
  chain of 8-cycle edge blocks entered by JMP @A+DPTR so that each line falls
  with ANL at exactly 500 + 8 N cycles after the rise;
- at any other machine cycle (e.g. 11.0592 MHz) the port routine counts
  machine cycles instead (`costs.CyclesEngine`, pulse_cycles.asm.j2): each
  line falls at C(N) = round_half_up((500 + 8 N) us / t_c) cycles, its block
  holding the gap to the edge before in 2-cycle loops.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import jinja2

from . import layout, resources
from . import costs
from .costs import FINAL_N, HEAD_CYCLES, PORT_CYCLES
from . import wcet
from . import target as target_mod
from .target import DEFAULT as DEFAULT_TARGET, Target, fmt_us
from .plan import HoldStep, LoopStep, MoveStep, Plan, PlayStep, RepeatStep, Step, steps, takes_frames
from .source import SourceFile

# Optimal sorting networks (comparator counts 0, 1, 3, 5, 9, 12, 16, 19).
SORTING_NETWORKS: dict[int, tuple[tuple[int, int], ...]] = {
    1: (),
    2: ((0, 1),),
    3: ((0, 2), (0, 1), (1, 2)),
    4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2)),
    5: ((0, 3), (1, 4), (0, 2), (1, 3), (0, 1), (2, 4), (1, 2), (3, 4), (2, 3)),
    6: ((0, 5), (1, 3), (2, 4), (1, 2), (3, 4), (0, 3), (2, 5), (0, 1), (2, 3), (4, 5), (1, 2), (3, 4)),
    7: ((0, 6), (2, 3), (4, 5), (0, 2), (1, 4), (3, 6), (0, 1), (2, 5), (3, 4), (1, 2), (4, 6), (2, 3),
        (4, 5), (1, 2), (3, 4), (5, 6)),
    8: ((0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7), (0, 1), (2, 3), (4, 5), (6, 7),
        (2, 4), (3, 5), (1, 4), (3, 6), (1, 2), (3, 4), (5, 6)),
}

BLOCK_BYTES = 18            # bytes of one edge block (see pulse.asm.j2)
CE_CYCLES = 13              # one compare-exchange, either way
MERGE_CYCLES = 16           # one sorted line after the first, edge or merge
FIRST_CYCLES = 10           # the smallest line
TICK_PARITY = 0             # TL2 parity of an on-time poll (measured in ucsim: 0 gives zero jitter)


def edges_cycles(s: int) -> int:
    """Cycles of the edges<s> routine including its RET (constant whatever the N)."""
    return CE_CYCLES * len(SORTING_NETWORKS[s]) + MERGE_CYCLES * (s - 1) + FIRST_CYCLES + 2


def head_pad(s: int) -> tuple[int, int]:
    """(DJNZ loops, NOPs) that bring a port's head with s lines to exactly HEAD_CYCLES."""
    used = (1                      # ORL: the rise
            + 4 * s                # load N and masks
            + 2                    # MOV R0, MOV R6
            + 2 + edges_cycles(s)  # LCALL edges<s>
            + 4                    # closing block count
            + 9                    # jump offset
            + 2                    # MOV DPTR
            + 2)                   # JMP @A+DPTR
    pad = HEAD_CYCLES - used
    if pad < 0:
        raise AssertionError("port head overflows")
    if pad < 3:
        return 0, pad
    loops, nops = divmod(pad - 1, 2)     # MOV R7,#loops is 1 cycle, each DJNZ 2
    return loops, nops


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
    work_cycles: int | None = None  # longest work between two frames, read from the text (None: unbounded)
    work_from: str = ""             # where that longest path starts
    min_period_us: int | None = None   # the shortest frame period this code holds (None: unbounded)
    target: Target = DEFAULT_TARGET    # the chip it is built for


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
    return _ENV


def render(template: str, **context) -> str:
    try:
        return environment().get_template(template).render(**context)
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

    def label(self, prefix: str) -> str:
        self.labels += 1
        return f"{prefix}{self.labels}"

    def where(self, span) -> str:
        if self.source is None:
            return ""
        line, _ = self.source.line_col(span.start)
        text = self.source.line_text(line).split("#")[0].strip()
        return f"{self.source.path.rsplit('/', 1)[-1]}:{line}  {text}"


def _static_frames(plan: Plan, step: MoveStep) -> int | None:
    if step.frames is not None:
        return step.frames
    seen = {inst.frames for inst in plan.moves if inst.step is step}
    return seen.pop() if len(seen) == 1 else None


def _move_record(ctx: _Ctx, step: MoveStep, known: dict[int, int]) -> dict:
    """The record of a move. `known` holds the targets set by the records before it in its list:
    a servo whose target is already the pose's is left out of the record (it does not move), and
    `known` takes the move's targets."""
    plan = ctx.plan
    frames = _static_frames(plan, step)
    notes: list[str] = [f"move {step.pose}", "F found at run time" if frames is None else f"F = {frames}"]
    label = None
    if step.ease != "linear":
        key = (step.ease, step.frames)
        label = ctx.ease_tables.setdefault(key, f"etab{len(ctx.ease_tables) + 1}")
        notes.append(f"ease {step.ease} table {label}")
    targets = {ch: n for ch, n in step.targets if known.get(ch) != n}
    if len(step.targets) == len(plan.channels) and len(plan.ports) + len(targets) >= len(plan.channels):
        targets = dict(step.targets)    # naming every servo needs no masks: not longer than masks and the changed
    known.update(step.targets)
    masks = None
    if len(targets) == len(plan.channels):
        notes.append("every servo")
    else:
        masks = []
        for port in plan.ports:
            chans = [c for c in plan.channels if c.port == port and c.index in targets]
            masks.append(sum(1 << c.bit for c in chans))
            notes.append(f"P{port}: " + (", ".join(c.name for c in chans) or "none"))
    notes += [f"{c.name} N {targets[c.index]}" for c in plan.channels if c.index in targets]
    if len(targets) < len(step.targets):
        notes.append(f"{len(step.targets) - len(targets)} already there")
    flags, data = layout.move_record(frames, label, targets, masks)
    return {"flags": flags, "data": data, "notes": notes, "where": ctx.where(step.span), "owner": ctx.owner}


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
            label = f"list{len(ctx.lists) + 1}"
            ctx.lists.append({"label": label, "records": list(run), "where": run[0]["where"]})
            ctx.records.extend(run)
            out.append({"op": "list", "label": label, "wheres": [r["where"] for r in run]})
            run.clear()

    for st in body:
        if not takes_frames((st,), ctx.plan, ctx.frames_memo):
            continue            # takes no frame: no code, so nothing it does can delay a frame
        where = ctx.where(st.span)
        if isinstance(st, MoveStep):
            run.append(_move_record(ctx, st, known))
            continue
        if isinstance(st, HoldStep):
            run.append(_hold_record(ctx, st))
            continue
        flush()
        if isinstance(st, RepeatStep):
            lab = ctx.label("rep")
            out.append({"op": "repeat", "label": lab, "count": st.count, "where": where})
            _ops(ctx, st.body, out)
            out.append({"op": "repeat_end", "label": lab, "where": where})
        elif isinstance(st, LoopStep):
            lab = ctx.label("loop")
            out.append({"op": "loop", "label": lab, "where": where})
            _ops(ctx, st.body, out)
            out.append({"op": "loop_end", "label": lab, "where": where})
        elif isinstance(st, PlayStep):
            out.append({"op": "play", "label": _seq_label(ctx.plan, st.sequence), "name": st.sequence, "where": where})
    flush()


def _seq_label(plan: Plan, name: str) -> str:
    return f"seq{[s.name for s in plan.sequences].index(name) + 1}"


def generate(plan: Plan, source: SourceFile | None = None) -> AsmUnit:
    """Lay out the firmware for a plan (which must have passed lint without errors)."""
    ctx = _Ctx(plan, source, [], {})
    main_ops: list[dict] = []
    _ops(ctx, plan.main, main_ops)
    sequences = []
    for seq in plan.sequences:
        ops: list[dict] = []
        ctx.owner = f"sequence `{seq.name}`"
        _ops(ctx, seq.body, ops)
        sequences.append({"label": _seq_label(plan, seq.name), "name": seq.name, "ops": ops,
                          "where": ctx.where(seq.span)})
    stack_bytes = costs.stack_bytes(plan.nesting)
    if stack_bytes > costs.STACK_BYTES:     # lint's `too-deep` reports this first
        raise layout.StackTooDeep(f"the program nests too deeply: it needs {stack_bytes} bytes of stack, "
                                  f"the firmware has {costs.STACK_BYTES}")

    ram = layout.RamAllocator()
    ram.next = layout.ADDR["FLAGS"] + 1
    ram.alloc("SEGF", 2, "F of the current move")
    ram.next = layout.WORK_BASE
    ram.alloc("WN", 8, "sort work: N")
    ram.alloc("WM", 8, "sort work: AND masks")
    ram.alloc("ERR0", 2, "DDA start of the current linear move: floor(-F / 2) mod 65536")
    ram.alloc("SEGK", 2, "frame number k in the current move")
    ram.alloc("FLEFT", 2, "frames left in the current move or hold")
    ram.alloc("ETAB", 2, "eased curve table of the current move, minus 1")
    ram.alloc("EVAL", 1, "e(k/F) x 256 this frame")
    ram.alloc("TMPD", 1, "scratch: |delta|")
    ram.alloc("TMPL", 1, "scratch")
    ram.alloc("LPTR", 2, "the record list being run: the next record")
    target = plan.program.target
    if target.grid:
        ports, edge_routines = _grid_ports(plan, ram)
        ce = None
    else:
        ce = costs.cycles_engine(target)
        ports, edge_routines = _cycles_ports(plan, ram, ce)
    chans = []
    for c in plan.channels:
        pin = 8 * c.port + c.bit
        bit = {name: layout.bit_address(layout.ADDR[name], pin) for name in ("ACT", "MOVB", "DIRB", "RMASK")}
        chans.append({"name": c.name, "pin": pin, "pin_name": c.servo.pin, "cur": layout.CUR_BASE + pin,
                      "state": layout.STATE_BASE + layout.STATE_BYTES * pin, "act_bit": bit["ACT"],
                      "mov_bit": bit["MOVB"], "dir_bit": bit["DIRB"], "rm_bit": bit["RMASK"]})
    reset_ports = [{"sfr": f"P{port}", "mask": 0xFF ^ sum(1 << s.bit for s in plan.program.servos if s.port == port),
                    "names": ", ".join(s.name for s in plan.program.servos if s.port == port)}
                   for port in sorted({s.port for s in plan.program.servos})]

    nodur = any(r["flags"] & layout.FLAG["NODUR"] for r in ctx.records)
    fneed = []
    if nodur:
        for cls, table in enumerate(plan.speed_tables):
            page = (plan.program.target.chip.code_bytes >> 8) - 2 * (len(plan.speed_tables) - cls)   # at the top
            fneed.append({"cls": cls, "page": page, "label": f"fneed{cls}", "lo": [v & 0xFF for v in table], "hi": [v >> 8 for v in table],
                          "t_dav": f"{float(plan.class_t_dav_us[cls]):.1f}"})
        if max(max(t) for t in plan.speed_tables) > 0xFFFF:
            raise layout.SlowServo("a servo is too slow for the frames-needed tables")
    pin_page = ["0"] * 24
    for c in plan.channels:
        if fneed:
            pin_page[c.port * 8 + c.bit] = ">" + fneed[c.speed_class]["label"]

    ease_tables = [{"label": lab, "ease": ease, "frames": frames,
                    "values": list(next(st.ease_table for st in steps(plan)
                                   if isinstance(st, MoveStep) and (st.ease, st.frames) == (ease, frames)))}
                   for (ease, frames), lab in ctx.ease_tables.items()]
    period_cycles = target.cycles(plan.period_us)
    if plan.period_us > target.max_period_us():     # lint's `period-too-long` reports this first
        raise layout.PeriodTooLong(
            f"a frame of {plan.period_us} us is {period_cycles} machine cycles at {target.describe()}, "
            f"and Timer2 counts at most {target_mod.TIMER2_CYCLES}")
    reload = 0x10000 - period_cycles
    tick_fix = (TICK_PARITY - reload) & 0xFF
    text = render("firmware.asm.j2",
                  source="" if source is None else source.path.rsplit("/", 1)[-1], period=plan.period_us,
                  reload=reload, tick_fix=tick_fix, ram=ram.symbols, flag_bits=layout.flag_equates(),
                  end_bit=layout.RECORD_FLAGS[-1].bit, edge_routines=edge_routines, chans=chans,
                  head_cycles=HEAD_CYCLES, cur_base=layout.CUR_BASE, minus_cur=-layout.CUR_BASE & 0xFF,
                  state_base=layout.STATE_BASE, stack_base=layout.STACK_BASE,
                  ports=ports, reset_ports=reset_ports, main_ops=main_ops, sequences=sequences,
                  lists=ctx.lists, flag_end=layout.FLAG["ENDF"], ease_tables=ease_tables, fneed=fneed, pin_page=pin_page,
                  block_bytes=BLOCK_BYTES, final_n=FINAL_N, port_cycles=PORT_CYCLES,
                  period_cycles=period_cycles, ce=ce,
                  pulse_template="pulse.asm.j2" if ce is None else "pulse_cycles.asm.j2",
                  edges_template="edges.asm.j2" if ce is None else "edges_cycles.asm.j2",
                  ctab=None if ce is None else {"lo": [v & 0xFF for v in ce.table], "hi": [v >> 8 for v in ce.table]},
                  target_text=target.describe(), cycle_text=fmt_us(target.cycle_us),
                  div_text=f"{float(target.div_cycles):g}",
                  fall_text="500 + 8 x N" if ce is None else "round_half_up((500 + 8 N) us / t_c)")
    sizes = tuple(p["s"] for p in ports)
    offsets = tuple(costs.rise_offsets(plan.ports, target, sizes).values())
    ram_bytes = ram.total(24, stack_bytes)
    breakdown: dict[str, int] = {}
    for r in ctx.records:
        breakdown[f"moves of {r['owner']}"] = breakdown.get(f"moves of {r['owner']}", 0) + len(r["data"])
    if ce is not None:
        breakdown["edge time table C(N)"] = 2 * 256
    if ease_tables:
        breakdown["eased curve tables"] = sum(len(t["values"]) for t in ease_tables)
    if fneed:
        breakdown[f"frames-needed tables ({len(fneed)} speed class{'es' if len(fneed) != 1 else ''})"] = 512 * len(fneed)
    work, work_from = frame_work(text)
    return AsmUnit(text, plan.period_us, plan.ports, offsets, ram_bytes, stack_bytes,
                   tuple(f["page"] for f in fneed),
                   tuple(sorted(breakdown.items(), key=lambda kv: (-kv[1], kv[0]))),
                   work, work_from,
                   None if work is None else target.us_at_least(costs.frame_cycles(len(plan.ports), work, target, sizes)),
                   target)


def _port_pins(plan: Plan, port: int) -> list[dict]:
    bits = [c.bit for c in plan.channels if c.port == port]
    return [{"i": i, "bit": b, "cur": layout.CUR_BASE + 8 * port + b, "mask": 0xFF ^ (1 << b),
             "name": next(c.name for c in plan.channels if c.port == port and c.bit == b)}
            for i, b in enumerate(bits)]


def _grid_ports(plan: Plan, ram: layout.RamAllocator) -> tuple[list[dict], list[dict]]:
    """Port data of the DIV-counting pulse routines (a 1 µs machine cycle)."""
    ports = []
    for port in plan.ports:
        pins = _port_pins(plan, port)
        n = len(pins)
        slots = ram.alloc(f"EDGES{port}", 2 * n, f"P{port}: edge blocks, (AND mask, count) each")
        fin = ram.alloc(f"FIN{port}", 1, f"P{port}: count of the closing silent block")
        loops, nops = head_pad(n)
        ports.append({
            "port": port, "s": n, "all_mask": sum(1 << p["bit"] for p in pins), "pins": pins,
            "fin": fin, "edges_cycles": edges_cycles(n),
            "blocks": [{"j": j + 1, "mask": slots + 2 * j, "cnt": slots + 2 * j + 1} for j in range(n)],
            "last_cnt": slots + 2 * n - 1, "entry_add": (1 - slots) % 256,
            "pad_loops": loops, "pad_nops": nops,
        })
    routines = [{"s": n, "network": SORTING_NETWORKS[n], "cycles": edges_cycles(n)}
                for n in sorted({p["s"] for p in ports})]
    return ports, routines


def _cycles_ports(plan: Plan, ram: layout.RamAllocator, ce: costs.CyclesEngine) -> tuple[list[dict], list[dict]]:
    """Port data of the cycle-counting pulse routines (any other machine cycle): one block area for
    all ports, filled by each port's prep just before its chain runs."""
    sizes = {port: len(_port_pins(plan, port)) for port in plan.ports}
    most = max(sizes.values())
    base = ram.alloc("BLK", ce.slot_bytes * (most + 1),
                     f"edge blocks of the port being pulsed: (M, {'S, ' if ce.short else ''}P, LO, HI) each")
    ports = []
    for port in plan.ports:
        pins = _port_pins(plan, port)
        n = len(pins)
        blocks = []
        for j in range(n + 1):
            at = base + ce.slot_bytes * j
            fields = ["m", "s", "p", "lo", "hi"] if ce.short else ["m", "p", "lo", "hi"]
            blocks.append({"j": j, "closing": j == n, **{f: at + i for i, f in enumerate(fields)}})
        half = (n + 1) // 2
        ports.append({
            "port": port, "s": n, "all_mask": sum(1 << p["bit"] for p in pins), "pins": pins,
            "top": base + ce.slot_bytes * (n + 1) - 1, "blocks": blocks,
            "before": blocks[:half][::-1], "after": blocks[half:],
            "pre_cycles": ce.pre_cycles(n, ce.split(n)), "post_cycles": ce.post_cycles(n, ce.split(n)),
            "pad": delay(ce.head_pad(n)), "entry_time": ce.th + 1,
        })
    routines = []
    for n in sorted(set(sizes.values())):
        units: list[dict] = [{"kind": "ce", "a": a, "b": b, "k": k + 1}
                             for k, (a, b) in enumerate(SORTING_NETWORKS[n])]
        units += [{"kind": "table"}, {"kind": "close"}]
        units += [{"kind": "line", "i": i, "prev": i - 1, "pad": delay(ce.line - 11)} for i in range(n - 1, 0, -1)]
        units += [{"kind": "first"}]
        k = ce.split(n)
        routines.append({"s": n, "parts": [
            {"name": "a", "units": units[:k], "cycles": ce.pre_cycles(n, k)},
            {"name": "b", "units": units[k:], "cycles": ce.post_cycles(n, k)}]})
    return ports, routines


def delay(cycles: int, reg: str = "R7", outer: str = "R5") -> list[str]:
    """Instructions that take exactly `cycles` machine cycles (they use `reg` and `outer`)."""
    out: list[str] = []
    if cycles < 0:
        raise AssertionError(f"negative delay {cycles}")
    if cycles > 513:
        b = min(255, (cycles - 1) // 513)
        out += [f"MOV     {outer}, #{b}                ; 1  {b} x 513 cycles",
                f"MOV     {reg}, #255              ; 1",
                f"DJNZ    {reg}, .                 ; 2 x 255",
                f"DJNZ    {outer}, .-4              ; 2"]
        cycles -= 1 + 513 * b
    if cycles > 3:
        if cycles % 2 == 0:
            out.append("NOP                             ; 1")
            cycles -= 1
        k = (cycles - 1) // 2
        out += [f"MOV     {reg}, #{k & 0xFF}                ; 1",
                f"DJNZ    {reg}, .                 ; 2 x {k}"]
        cycles = 0
    out += ["NOP                             ; 1"] * cycles
    return out


def frame_work(text: str) -> tuple[int | None, str]:
    """The longest work between two frames in this assembly, and where it starts."""
    try:
        code = wcet.Code(text)
        cycles, at = code.between_frames()
    except wcet.WcetError as exc:
        return None, str(exc)
    return cycles, code.label_at(at)
