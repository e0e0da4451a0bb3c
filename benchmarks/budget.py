"""The frame budget in ucsim: the shortest frame period P at which a firmware verifies exactly.

One search with a predicate ok(P) ("the firmware built at P verifies
exactly"): `holds_down_to`, down from the P servoc reports 1 us at a time (or
a coarser step, then 1 us) to the first P that fails: the shortest P from
which every P up to the reported one holds (no bisection: where the ports'
pulses overlap, a shorter P can hold by chance). It runs on two kinds of
programs, built at P with servoc's own budget bypassed (`build_unchecked`)
so that P can go below it:

- stress programs (`stress_source`): every servo moves on every frame
  (one-frame moves), so each frame reads a new move record, computes DDA
  terms and steps every servo, with nested repeats and a sequence ending
  together; with `runtime_f` a move without duration is played from two
  different poses, so its F is found at run time from the frames-needed
  tables. The worst case of the firmware's work between frames.
- held-pose programs (`hold_source`): 8 servos per port set at once to
  POSITIONS, then held. The steady state.

`frame_budget` puts the shortest exact P next to the shortest P servoc
reports for the same program (`Plan.min_period_us`, read from the generated
code) and the default P it picks.

    .venv/bin/python benchmarks/budget.py    # shortest exact P of the stress programs, 1 to 24 servos
"""

from __future__ import annotations

import time
from pathlib import Path

from baselines import POSITIONS, BuildError
from servoc import api, codegen, costs, events
from servoc.diagnostics import Reporter
from servoc.steps import Plan
from servoc.source import SourceFile
from servoc.units import DEFAULT_PERIOD_FLOOR_US

from servoc.target import DEFAULT as _T12

PLANNED_AT = 20000
"""us: the `frame` the stress programs are planned at for the shortest P servoc reports."""
BEFORE_KEY = "_before"
"""A row's program for the table's "before" column ([text, planned again at its shortest P]:
suite.before_column), dropped from the results once that is measured."""

SPAN = costs.port_span(_T12)
"""A port's rise to the next port's at 12 MHz: the floor of P is SPAN x ports (the pulses alone)."""


def pulse_floor(ports: int) -> int:
    return SPAN * ports


def holds_down_to(ok, lo: int, hi: int, step: int = 1) -> int:
    """Smallest P in (lo, hi] such that ok holds at every whole us from P to hi: scanned down from
    hi (servoc's reported P) 1 us at a time to the first P that fails. No monotony assumed: where each
    port's rise comes among the falls of the port before it (costs.stagger_span), a period below the
    shortest servoc reports can put the next frame's first rise, by chance, at a time that clears
    every fall of the last port, while longer ones do not (a binary search then finds such a chance
    and reports a P from which not every period holds). Costs one build per us between the answer
    and hi, and one more. `step` > 1: scanned every `step` us down to the first failure, then every
    us above it (a failure narrower than `step` higher up may be missed: to within `step`)."""
    if not ok(hi):
        raise AssertionError(f"not exact even at P = {hi} us")
    p = hi
    while step > 1 and p - step > lo and ok(p - step):
        p -= step
    while p - 1 > lo and ok(p - 1):
        p -= 1
    return p


def holds_below(ok, reported: int, step: int = 1) -> int:
    """`holds_down_to` from servoc's reported P down to 2/3 of it, wherever the pulses' term lies
    (with the ports' pulses overlapping, 24 servos report less than 3 x 2500 us)."""
    return holds_down_to(ok, reported * 2 // 3, reported, step)


# ---------------------------------------------------------------- building at any P

def plan_text(text: str, name: str = "bench", below_budget: bool = False) -> tuple[SourceFile, Plan]:
    """The source and plan of .servo text (parse, check, plan, lint through servoc.api).

    Any error is a BuildError, except `period-too-short` when `below_budget`."""
    source = SourceFile(f"{name}.servo", text)
    reporter = Reporter(source)
    fe = api.front_end(source, reporter)
    errors = [d.code for d in reporter.diagnostics if d.is_error]
    if fe.plan is None or set(errors) - ({"period-too-short"} if below_budget else set()):
        raise BuildError(f"{name}: {errors}")
    return source, fe.plan


def build_unchecked(text: str, name: str, build: dict | None = None) -> tuple[Plan, api.Firmware]:
    """Plan and assemble `text` at its own `frame`, also below the shortest P servoc allows
    (`api.generate` refuses that, so the code comes from `codegen.generate` itself). `build` given
    (codegen.generate's `stepping`, `stagger`): that build, not the one whose period is shortest,
    and the plan with its ports' rises."""
    source, plan = plan_text(text, name, below_budget=True)
    reporter = Reporter(source)
    unit = codegen.generate(plan, source, **(build or {}))
    if build:
        plan = api.with_rises(plan, unit)
    fw = api.assemble(unit, reporter)
    if fw is None:
        raise BuildError(f"{name}: " + "; ".join(d.message for d in reporter.diagnostics))
    return plan, fw


def exact(plan: Plan, fw: api.Firmware, frames: int) -> bool:
    """Does the firmware verify exactly in ucsim over `frames` frames, or more: enough to play every
    move instance once, so that a loop longer than `frames` is seen whole?"""
    frames = max(frames, sum(m.frames for m in plan.moves) + 2)
    return api.verify_hex(plan, fw.hex_text, frames).ok


# ---------------------------------------------------------------- worst case: stress programs

def stress_source(ports: int, per_port: int, period: int, runtime_f: bool = False, depth: int | None = None,
                  target: str = "", serial: bool = False) -> str:
    pins = [(p, b) for p in range(ports) for b in range(per_port)]
    lines = ([target] if target else []) + ([SERIAL_LINE] if serial else []) + [f"frame {period}us"]
    speed = "" if runtime_f else " speed 0.0001s/60deg"     # fast enough for any P the firmware holds
    for i, (p, b) in enumerate(pins):
        lines.append(f"servo s{i} = P{p}.{b}{speed}")
    low = ", ".join(f"s{i}: {(7 * i) % 40}" for i in range(len(pins)))
    if runtime_f:
        # servos in pairs at the same N (two lines on one edge, as on a symmetric robot); every servo
        # moves from hi to far
        high = ", ".join(f"s{i}: {250 - (11 * (i // 2)) % 40}" for i in range(len(pins)))
        far = ", ".join(f"s{i}: {245 - (11 * (i // 2)) % 40 - i // 2 % 4}" for i in range(len(pins)))
    else:
        high = ", ".join(f"s{i}: {250 - (11 * i) % 40}" for i in range(len(pins)))
        far = ", ".join(f"s{i}: {240 + i % 10}" for i in range(len(pins)))
    lines += [f"pose lo {{ {low} }}", f"pose hi {{ {high} }}", f"pose far {{ {far} }}"]
    if runtime_f:
        # `move far` is entered from `hi` (in the second frame already) and from `lo`: its F is found
        # at run time, with every servo moving
        lines += ["sequence go { move far }", "main {", f"  move hi in {period}us", "  loop {",
                  "    play go", "    move lo in 700ms", "    play go", "    move hi in 100ms", "  }", "}"]
    elif depth is not None:
        # `depth` repeats all ending after the same frame, then all starting again
        body = [f"move hi in {period}us", f"move lo in {period}us"]
        for _ in range(depth):
            body = ["repeat 1 {"] + body + ["}"]
        lines += ["main {", "  loop {"] + body + ["  }", "}"]
    else:
        # every frame a new one-frame move: record, DDA terms and a step for every servo
        lines += ["sequence step {", "  repeat 2 { repeat 2 {", f"    move hi in {period}us",
                  f"    move lo in {period}us", "  } }", "}", "main {", "  loop {",
                  "    repeat 3 { play step }", "  }", "}"]
    return "\n".join(lines) + "\n"


def budget_period(ports: int, per_port: int, runtime_f: bool = False, depth: int | None = None,
                  period: int = PLANNED_AT, target: str = "", serial: bool = False) -> int:
    """The shortest P servoc reports for the stress program (planned at `period`)."""
    return plan_text(stress_source(ports, per_port, period, runtime_f, depth, target, serial),
                     "stress")[1].min_period_us


def exact_at(ports: int, per_port: int, period: int, runtime_f: bool = False, frames: int = 400,
             depth: int | None = None, target: str = "") -> bool:
    """Build the stress program at `period` (the budget bypassed) and verify it in ucsim."""
    plan, fw = build_unchecked(stress_source(ports, per_port, period, runtime_f, depth, target), "stress")
    assert bool(fw.unit.fneed_pages) == runtime_f
    return exact(plan, fw, frames)


def shortest_exact_period(ports: int, per_port: int = 8, runtime_f: bool = False, depth: int | None = None,
                          quick: bool = False) -> int:
    """The shortest P (us) from which the stress program verifies exactly at every P up to the one
    servoc reports (`holds_down_to`), over 400 frames (quick mode: 100)."""
    frames = 100 if quick else 400
    reported = budget_period(ports, per_port, runtime_f, depth)
    return holds_below(lambda p: exact_at(ports, per_port, p, runtime_f, frames, depth), reported)


def stress_default_period(ports: int, runtime_f: bool) -> int:
    """The P servoc picks for the stress program without a `frame` line."""
    text = stress_source(ports, 8, DEFAULT_PERIOD_FLOOR_US, runtime_f)
    return plan_text(text.split("\n", 1)[1], "default")[1].period_us


# ---------------------------------------------------------------- steady state: a held pose

def hold_source(ports: int, period: int | None) -> str:
    """8 servos per port set at once to POSITIONS, then a held pose (and main's end)."""
    lines = [] if period is None else [f"frame {period}us"]
    lines += [f"servo s{p}_{b} = P{p}.{b}" for p in range(ports) for b in range(8)]
    pose = ", ".join(f"s{p}_{b}: {POSITIONS[b]}" for p in range(ports) for b in range(8))
    lines += [f"pose p {{ {pose} }}", "main {", "  move p in 1ms", "  hold 300ms", "}"]
    return "\n".join(lines) + "\n"


def hold_exact_at(ports: int, period: int, frames: int = 150) -> bool:
    return exact(*build_unchecked(hold_source(ports, period), "hold"), frames)


def hold_shortest(ports: int, quick: bool) -> tuple[int, int]:
    """(shortest exact P, resolution) of the held pose: down from the P servoc reports for it
    (`holds_down_to`; where the ports' pulses overlap, shorter periods can hold by chance)."""
    step = 2 if quick else 1
    frames = 100 if quick else 150
    reported = plan_text(hold_source(ports, None), "hold")[1].min_period_us
    p = holds_down_to(lambda q: hold_exact_at(ports, q, frames), _T12.width_cycles(max(POSITIONS)), reported, step)
    return p, step


# ---------------------------------------------------------------- other crystals, the serial line

CLOCK_TARGETS = ("target stc89c52rc clock 11.0592MHz", "target at89c52 clock 22.1184MHz")
SERIAL_LINE = "serial 4800"
BURST_MS = 9
"""With `serial`, the run gets 4 bytes back to back every BURST_MS ms (4 bytes take 8.3 ms at 4800
baud: the line is busy nearly all the time), and every pulse must still be exact."""


def serial_exact_at(ports: int, period: int, target: str = "", runtime_f: bool = False, frames: int = 100) -> bool:
    """The stress program with `serial` at `period` (the budget bypassed), verified in ucsim while
    bytes keep coming."""
    plan, fw = build_unchecked(stress_source(ports, 8, period, runtime_f, target=target, serial=True), "stress")
    return exact_with_bytes(plan, fw, frames)


def exact_with_bytes(plan: Plan, fw: api.Firmware, frames: int, back_to_back: bool = False) -> bool:
    """Does the firmware of a program with `serial` verify exactly in ucsim over `frames` frames
    while bytes keep coming: four back to back every BURST_MS ms, or (`back_to_back`) one after
    another for the whole run?"""
    cycles = api.cycles_needed(plan, frames)
    span_ms = cycles * plan.program.target.cycle_us / 1000
    if back_to_back:
        text = "5ms " + " ".join(['"x"'] * int((span_ms - 10) * plan.program.serial.baud / 10_000)) + "\n"
    else:
        text = "".join(f'{5 + BURST_MS * k}ms "x" "y" "z" "w"\n' for k in range(int((span_ms - 15) // BURST_MS)))
    evs = events.parse(text, plan.program.inputs, True)
    trace = api.simulate(fw.hex_text, cycles, plan.program.target, api.stimulus(plan, evs))
    return api.check_trace(plan, trace, frames).ok


def clock_budget(quick: bool, progress=None) -> list[dict]:
    """The worst-case stress program at 12 MHz with the serial line busy, and at crystals whose machine
    cycle is not 1 us (the cycles engine), with and without run-time F and `serial`: servoc's shortest P
    next to the shortest P from which every P up to servoc's verifies exactly in ucsim, to 1 us
    (`holds_down_to`; quick: 1 port, fewer cases)."""
    say = progress or (lambda s: None)
    out = []
    cases = [("", False, True)] + [(line, rf, ser) for line in CLOCK_TARGETS for rf in (False, True) for ser in (False, True)
                                   if line == CLOCK_TARGETS[0] or not (rf or ser)]
    if quick:
        cases = [("", False, True), (CLOCK_TARGETS[0], False, False)]
    for line, rf, ser in cases:
        for ports in (1,) if quick else (1, 3):
            what = ", ".join(x for x in (line or "12 MHz", "run-time F" if rf else "", SERIAL_LINE if ser else "") if x)
            say(f"shortest exact P, stress program, {ports} port(s), {what}")
            reported = budget_period(ports, 8, rf, target=line, serial=ser)
            if ser:
                ok = lambda q: serial_exact_at(ports, q, line, rf)      # noqa: E731
            else:
                ok = lambda q: exact_at(ports, 8, q, rf, frames=100, target=line)      # noqa: E731
            p = holds_below(ok, reported)
            out.append({"target": line.split(" ", 1)[1] if line else "at89c52 (12 MHz)", "ports": ports,
                        "servos": 8 * ports, "runtime_f": rf, "serial": SERIAL_LINE if ser else "",
                        "reported_min_p_us": reported, "shortest_exact_p_us": p, "difference_us": reported - p,
                        "resolution_us": 1, BEFORE_KEY: (stress_source(ports, 8, PLANNED_AT, rf, target=line, serial=ser), False)})
    return out


# ---------------------------------------------------------------- real programs: the examples

EXAMPLES = ("biped", "hexapod")
EXAMPLE_CLOCKS = ("", "target stc89c52rc clock 11.0592MHz", "target at89c52 clock 22.1184MHz")
EXAMPLE_STEP = 8        # us: the examples' search below servoc's P (each build plays every move once); every
                        # us where the ports overlap (a failure can be a few us wide there: `holds_down_to`)


def example_source(name: str, target: str, period: int | None = None) -> str:
    """examples/NAME.servo for `target` (empty: its default), at `period` if given, else its default P."""
    text = (Path(__file__).resolve().parent.parent / "examples" / f"{name}.servo").read_text(encoding="utf-8")
    body = [line for line in text.splitlines() if not line.startswith(("target ", "frame "))]
    head = ([target] if target else []) + ([f"frame {period}us"] if period else [])
    return "\n".join(head + body) + "\n"


def examples_budget(quick: bool, progress=None) -> list[dict]:
    """The examples at three clocks: servoc's shortest P next to the shortest P from which every P
    up to it verifies exactly in ucsim, every move played once (`holds_down_to`; quick: the biped)."""
    say = progress or (lambda s: None)
    out = []
    for name in EXAMPLES[:1] if quick else EXAMPLES:
        for line in EXAMPLE_CLOCKS:
            say(f"shortest exact P, examples/{name}.servo, {line or '12 MHz'}")
            plan = plan_text(example_source(name, line), name)[1]
            reported, step = plan.min_period_us, 1 if plan.rises_among_falls else EXAMPLE_STEP
            ok = lambda q: exact(*build_unchecked(example_source(name, line, q), name), 100)     # noqa: E731
            p = holds_below(ok, reported, step)
            out.append({"program": f"examples/{name}.servo", "target": line.split(" ", 1)[1] if line else "at89c52 (12 MHz)",
                        "reported_min_p_us": reported, "shortest_exact_p_us": p, "difference_us": reported - p,
                        "resolution_us": 1 if p == reported else step, BEFORE_KEY: (example_source(name, line), False)})
    return out


# ---------------------------------------------------------------- the figures

def frame_budget(quick: bool, progress=None) -> dict:
    """Shortest exact P against servoc's reported and default P, worst case and pose held.

    Full: 1, 2 and 3 ports, with and without run-time F. Quick: 1 and 3 ports, fewer frames, the
    held pose every 2 us down to its first failure, then every us (`holds_down_to`); the stress
    programs' every us."""
    say = progress or (lambda s: None)
    out: dict = {"port_span_cycles": SPAN, "worst_case": [], "steady_state": []}
    for ports in (1, 3) if quick else (1, 2, 3):
        for rf in (False, True):
            say(f"shortest exact P, stress program, {ports} port(s){', run-time F' if rf else ''}")
            t0 = time.perf_counter()
            reported = budget_period(ports, 8, rf)
            p = shortest_exact_period(ports, 8, rf, quick=quick)
            out["worst_case"].append({
                "ports": ports, "servos": 8 * ports, "runtime_f": rf,
                "reported_min_p_us": reported, "shortest_exact_p_us": p, "difference_us": reported - p,
                "resolution_us": 1, "over_pulses_cycles": p - pulse_floor(ports),
                "default_p_us": stress_default_period(ports, rf),
                "search_seconds": round(time.perf_counter() - t0, 1), BEFORE_KEY: (stress_source(ports, 8, PLANNED_AT, rf), False)})
        say(f"shortest exact P, pose held, {ports} port(s)")
        p, step = hold_shortest(ports, quick)
        plan = plan_text(hold_source(ports, None), "hold")[1]
        out["steady_state"].append({
            "ports": ports, "servos": 8 * ports, "reported_min_p_us": plan.min_period_us,
            "shortest_exact_p_us": p, "difference_us": plan.min_period_us - p, "resolution_us": step,
            "over_pulses_cycles": p - pulse_floor(ports), "default_p_us": plan.period_us,
            BEFORE_KEY: (hold_source(ports, None), False)})
    return out


def main() -> None:
    """Print the shortest exact P of the stress programs, 1 to 24 servos, next to servoc's."""
    for ports, per_port in [(1, 1), (1, 4), (1, 8), (2, 8), (3, 1), (3, 8)]:
        for rf in (False, True):
            p = shortest_exact_period(ports, per_port, rf)
            print(f"ports={ports} servos={ports * per_port:2d} runtime_f={rf!s:5}: shortest exact P = {p} us "
                  f"(servoc reports {budget_period(ports, per_port, rf)} us), "
                  f"{p - pulse_floor(ports)} cycles over the pulses at N 250", flush=True)


if __name__ == "__main__":
    main()
