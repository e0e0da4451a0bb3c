"""The benchmark suite: servoc's firmware against two baselines, and the compiler's own figures.

Baselines (benchmarks/baselines/), each driving 8 servos on P1 with the same
positions `POSITIONS`:
- hobby.c: C for `sdcc -mmcs51 --model-small`, a 20 ms frame in eight 2.5 ms
  Timer0 slots;
- source_algorithm.asm: the source note's cycle transcribed plainly for
  sdas8051 (rise together, bubble sort, differences, DJNZ delays, 2.8 ms tail).

All three firmwares run in ucsim and go through the same decoder
(`SimTrace.pulses` and `SimTrace.first_low`): width error per channel
(measured width minus 500 + 8 N), frame period (mean rise-to-rise), jitter
(max - min rise-to-rise) and how long the lines stay high after reset.

servoc's own figures: cycles between frames (shortest exactly verified P
minus the port routines) for the worst-case programs of `stress.py` and for a
program holding a pose, the default P it picks, ROM (runtime, per keyframe,
keyframes that fit 8 KB), RAM, and the time of each compiler stage.

`run_all(quick)` returns everything as one JSON-ready dict; `table(results)`
renders it as a markdown table. benchmarks/run.py is the command line.
"""

from __future__ import annotations

import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR.parent))
sys.path.insert(0, str(BENCH_DIR))

import stress  # noqa: E402

from servoc import api, codegen, costs, sim, toolchain  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402
from servoc.units import BASE_US, DEFAULT_PERIOD_FLOOR_US, DIV_US  # noqa: E402

BASELINE_DIR = BENCH_DIR / "baselines"
HOBBY_C = BASELINE_DIR / "hobby.c"
SOURCE_ASM = BASELINE_DIR / "source_algorithm.asm"

POSITIONS = (0, 1, 125, 125, 200, 249, 250, 60)
"""N of P1.0..P1.7 in all three firmwares: both ends, a tie, adjacent values."""
PORT = 1
FRAMES = 50
ROM_SIZE = toolchain.AT89C52_ROM_SIZE
PORT_CYCLES = codegen.PORT_CYCLES


def expected_width(n: int) -> int:
    return BASE_US + DIV_US * n


# ---------------------------------------------------------------- firmwares

class BuildError(Exception):
    """A baseline or a benchmark program did not build."""


def baseline_positions(path: Path) -> tuple[int, ...]:
    """The 8 positions written in a baseline's source (its first 8-number list)."""
    text = path.read_text()
    if path.suffix == ".c":
        m = re.search(r"position\[SERVOS\]\s*=\s*\{([^}]*)\}", text)
        numbers = m[1] if m else ""
    else:
        m = re.search(r"^table:\s*\.db\s+(.*)$", text, re.M)
        numbers = m[1] if m else ""
    return tuple(int(x, 0) for x in numbers.split(",") if x.strip())


def build_hobby(path: Path = HOBBY_C) -> str:
    """Compile hobby.c with SDCC (small model) and return the HEX text."""
    sdcc = _tool("sdcc")
    packihx = toolchain.find_tool("packihx")
    with tempfile.TemporaryDirectory(prefix="servoc-bench-") as tmp:
        src = Path(tmp) / "hobby.c"
        src.write_text(path.read_text())
        proc = subprocess.run([sdcc, "-mmcs51", "--model-small", "hobby.c"], cwd=tmp, capture_output=True,
                              text=True, stdin=subprocess.DEVNULL, timeout=120, check=False)
        ihx = Path(tmp) / "hobby.ihx"
        if proc.returncode != 0 or not ihx.is_file():
            raise BuildError(f"sdcc failed on {path}:\n{proc.stdout}{proc.stderr}")
        proc = subprocess.run([packihx, "hobby.ihx"], cwd=tmp, capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=60, check=False)
        if proc.returncode != 0 or not proc.stdout.strip():
            raise BuildError(f"packihx failed on hobby.ihx:\n{proc.stderr}")
        return proc.stdout


def build_source_algorithm(path: Path = SOURCE_ASM) -> str:
    """Assemble source_algorithm.asm with sdas8051/sdld and return the HEX text."""
    return toolchain.assemble(path.read_text(), name="source_algorithm").hex_text


def _tool(name: str) -> str:
    found = shutil.which(name)
    if found is None:
        raise BuildError(f"{name} not found on PATH (Debian/Ubuntu: apt-get install sdcc)")
    return found


def positions_source(frame: str | None = None) -> str:
    """The .servo program for POSITIONS on P1: raw N, set at once, then held."""
    lines = [] if frame is None else [f"frame {frame}"]
    lines += [f"servo s{b} = P{PORT}.{b}" for b in range(8)]
    pose = ", ".join(f"s{b}: {n}" for b, n in enumerate(POSITIONS))
    lines += [f"pose p {{ {pose} }}", "main {", "  move p in 100ms", "  hold 1s", "}"]
    return "\n".join(lines) + "\n"


def compile_text(text: str, name: str = "bench.servo") -> tuple[api.FrontEnd, api.Firmware | None, Reporter]:
    """Compile .servo text through servoc.api, from a temporary file like the CLI."""
    with tempfile.TemporaryDirectory(prefix="servoc-bench-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        source, reporter = api.load_source(path)
        fe, fw = api.build(source, reporter)
    return fe, fw, reporter


def build_servoc(text: str | None = None) -> tuple[api.FrontEnd, api.Firmware]:
    fe, fw, reporter = compile_text(text or positions_source(), "positions.servo")
    errors = [f"{d.code}: {d.message}" for d in reporter.diagnostics if d.is_error]
    if fw is None or errors:
        raise BuildError("servoc did not compile the positions program: " + "; ".join(errors))
    return fe, fw


# ---------------------------------------------------------------- decoder

@dataclass
class Decoded:
    """The same figures for every firmware, from its SimTrace."""

    frames: int                     # pulses decoded per channel
    width_error_us: list[list[int]]  # per channel, per pulse: width - (500 + 8 N)
    max_abs_error_us: list[int]     # per channel
    max_abs_error_all_us: int
    exact_pulses: int               # pulses with zero error, all channels
    pulses: int
    period_mean_us: float           # mean rise-to-rise over all channels
    period_min_us: int
    period_max_us: int
    jitter_us: int                  # max over channels of (max - min rise-to-rise)
    reset_high_us: list[int | None]  # first_low per line
    reset_high_max_us: int | None

    def summary(self) -> dict:
        d = asdict(self)
        del d["width_error_us"]
        d["width_errors_seen_us"] = [sorted(set(e)) for e in self.width_error_us]
        return d


def decode(trace: sim.SimTrace, port: int, positions: tuple[int, ...], frames: int) -> Decoded:
    """Widths, periods and reset figures of `frames` pulses per line of `port`."""
    errors: list[list[int]] = []
    periods: list[int] = []
    jitter = 0
    for bit, n in enumerate(positions):
        pulses = trace.pulses(port, bit)[:frames]
        if len(pulses) < frames:
            raise ValueError(f"P{port}.{bit}: only {len(pulses)} complete pulses, {frames} needed")
        errors.append([w - expected_width(n) for _, w in pulses])
        rr = [b[0] - a[0] for a, b in zip(pulses, pulses[1:])]
        periods += rr
        jitter = max(jitter, max(rr) - min(rr))
    firsts = [trace.first_low(port, bit) for bit in range(len(positions))]
    known = [f for f in firsts if f is not None]
    max_abs = [max(abs(e) for e in errs) for errs in errors]
    return Decoded(
        frames=frames,
        width_error_us=errors,
        max_abs_error_us=max_abs,
        max_abs_error_all_us=max(max_abs),
        exact_pulses=sum(e == 0 for errs in errors for e in errs),
        pulses=sum(len(errs) for errs in errors),
        period_mean_us=round(statistics.fmean(periods), 3),
        period_min_us=min(periods),
        period_max_us=max(periods),
        jitter_us=jitter,
        reset_high_us=firsts,
        reset_high_max_us=None if len(known) < len(firsts) else max(known),
    )


def simulate_frames(hex_text: str, port: int, frames: int, guess_period: int) -> sim.SimTrace:
    """Simulate until every line of `port` has `frames` complete pulses (doubling the guess)."""
    cycles = (frames + 3) * guess_period + 20_000
    for _ in range(6):
        trace = sim.run(hex_text, cycles, ports=(port,))
        if all(len(trace.pulses(port, b)) >= frames for b in range(8)):
            return trace
        cycles *= 2
    return trace


def measure_baseline(hex_text: str, guess_period: int, frames: int = FRAMES) -> Decoded:
    return decode(simulate_frames(hex_text, PORT, frames, guess_period), PORT, POSITIONS, frames)


def measure_servoc(frames: int = FRAMES) -> tuple[Decoded, api.FrontEnd, api.Firmware]:
    fe, fw = build_servoc()
    trace = api.simulate(fw.hex_text, api.cycles_needed(fe.plan, frames + 1))
    return decode(trace, PORT, POSITIONS, frames), fe, fw


def compare(frames: int = FRAMES, progress=None) -> dict:
    """The three firmwares through the same decoder."""
    say = progress or (lambda s: None)
    out: dict = {}
    say("baseline hobby.c: sdcc, ucsim")
    hobby_hex = build_hobby()
    out["hobby"] = {"rom_bytes": toolchain.rom_used(hobby_hex),
                    **measure_baseline(hobby_hex, 22_000, frames).summary()}
    say("baseline source_algorithm.asm: sdas8051, ucsim")
    src_hex = build_source_algorithm()
    out["source_algorithm"] = {"rom_bytes": toolchain.rom_used(src_hex),
                               **measure_baseline(src_hex, 11_000, frames).summary()}
    say("servoc: positions program, ucsim")
    dec, fe, fw = measure_servoc(frames)
    out["servoc"] = {"rom_bytes": fw.rom_bytes, "period_chosen_us": fe.plan.period_us, **dec.summary()}
    return out


# ---------------------------------------------------------------- frame budget

def _build_unchecked(text: str, name: str) -> tuple:
    """Plan and assemble `text` at its `frame`, below the budget too (as stress.exact_at does)."""
    source = SourceFile(f"{name}.servo", text)
    reporter = Reporter(source)
    plan = api.plan(api.check(api.parse(source, reporter), reporter), reporter)
    unit = codegen.generate(plan, source)
    return plan, toolchain.assemble(unit.text, name=name).hex_text


def hold_source(ports: int, period: int | None) -> str:
    """8 servos per port set at once to POSITIONS, then a held pose (and main's end)."""
    lines = [] if period is None else [f"frame {period}us"]
    lines += [f"servo s{p}_{b} = P{p}.{b}" for p in range(ports) for b in range(8)]
    pose = ", ".join(f"s{p}_{b}: {POSITIONS[b]}" for p in range(ports) for b in range(8))
    lines += [f"pose p {{ {pose} }}", "main {", "  move p in 1ms", "  hold 300ms", "}"]
    return "\n".join(lines) + "\n"


def hold_exact_at(ports: int, period: int, frames: int = 150) -> bool:
    plan, hex_text = _build_unchecked(hold_source(ports, period), "hold")
    return api.verify_hex(plan, hex_text, frames).ok


def bisect_shortest(ok, lo: int, hi: int, step: int = 1) -> int:
    """Smallest P in (lo, hi] with ok(P), to within `step`, assuming ok is monotone and ok(hi)."""
    if not ok(hi):
        raise AssertionError(f"not exact even at P = {hi} us")
    while hi - lo > step:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


def stress_shortest(ports: int, runtime_f: bool, quick: bool) -> tuple[int, int]:
    """(shortest exact P, resolution) of stress.py's worst-case program, 8 servos per port.

    Full: `stress.shortest_exact_period` (1 us). Quick: fewer, shorter checks
    below the cost model's bound, to 8 us (the figure is an upper bound).
    """
    if not quick:
        return stress.shortest_exact_period(ports, 8, runtime_f), 1
    hi = stress.budget_period(ports, 8, runtime_f)

    def ok(p: int) -> bool:
        return stress.exact_at(ports, 8, p, runtime_f, frames=100)

    while not ok(hi):
        hi += 512
    return bisect_shortest(ok, max(PORT_CYCLES * ports, hi - 1024), hi, 8), 8


def default_period(text: str) -> int:
    source = SourceFile("default.servo", text)
    reporter = Reporter(source)
    plan = api.plan(api.check(api.parse(source, reporter), reporter), reporter)
    errors = [d.code for d in reporter.diagnostics if d.is_error]
    if errors:
        raise BuildError(f"default-period program has errors: {errors}")
    return plan.period_us


def stress_default_period(ports: int, runtime_f: bool) -> int:
    text = stress.stress_source(ports, 8, DEFAULT_PERIOD_FLOOR_US, runtime_f)
    return default_period("".join(text.splitlines(keepends=True)[1:]))   # without its `frame` line


def frame_budget(quick: bool, progress=None) -> dict:
    say = progress or (lambda s: None)
    out: dict = {"port_cycles": PORT_CYCLES, "worst_case": [], "steady_state": []}
    kinds = [False] if quick else [False, True]
    for ports in (1, 2, 3):
        for rf in kinds:
            say(f"shortest exact P, stress program, {ports} port(s){' run-time F' if rf else ''}")
            t0 = time.perf_counter()
            p, res = stress_shortest(ports, rf, quick)
            out["worst_case"].append({
                "ports": ports, "servos": 8 * ports, "runtime_f": rf, "shortest_exact_p_us": p,
                "resolution_us": res, "between_frames_cycles": p - PORT_CYCLES * ports,
                "model_min_p_us": stress.budget_period(ports, 8, rf),
                "default_p_us": stress_default_period(ports, rf),
                "search_seconds": round(time.perf_counter() - t0, 1)})
        say(f"shortest exact P, pose held, {ports} port(s)")
        step = 2 if quick else 1
        p = bisect_shortest(lambda q: hold_exact_at(ports, q, 100 if quick else 150),
                            PORT_CYCLES * ports, PORT_CYCLES * ports + 512, step)
        out["steady_state"].append({
            "ports": ports, "servos": 8 * ports, "shortest_exact_p_us": p, "resolution_us": step,
            "between_frames_cycles": p - PORT_CYCLES * ports,
            "default_p_us": default_period(hold_source(ports, None))})
    return out


# ---------------------------------------------------------------- memory

def keyframe_source(k: int, seed: int = 1) -> str:
    """24 servos on P0-P2 and `k` distinct random keyframes, each moved to once in 1 s."""
    rng = random.Random(seed)
    lines = [f"servo s{i} = P{i // 8}.{i % 8}" for i in range(24)]
    for j in range(k):
        vals = ", ".join(f"s{i}: {rng.randrange(0, 251)}" for i in range(24))
        lines.append(f"pose k{j} {{ {vals} }}")
    lines += ["main {"] + [f"  move k{j} in 1s" for j in range(k)] + ["}"]
    return "\n".join(lines) + "\n"


def _keyframe_build(k: int) -> tuple[api.Firmware | None, list[str]]:
    _fe, fw, reporter = compile_text(keyframe_source(k), "keyframes.servo")
    return fw, [d.code for d in reporter.diagnostics if d.is_error]


def memory(quick: bool, progress=None) -> dict:
    say = progress or (lambda s: None)
    say("ROM and RAM: positions program, keyframe programs")
    _fe8, fw8 = build_servoc()
    _fe24, fw24 = build_servoc(hold_source(3, None))
    k = 10 if quick else 20
    fw_k, err_k = _keyframe_build(k)
    fw_2k, err_2k = _keyframe_build(2 * k)
    if fw_k is None or fw_2k is None:
        raise BuildError(f"keyframe programs did not compile: {err_k} {err_2k}")
    per_kf = (fw_2k.rom_bytes - fw_k.rom_bytes) / k
    fixed = fw_k.rom_bytes - k * per_kf
    estimate = int((ROM_SIZE - fixed) // per_kf)
    say(f"keyframes that fit 8 KB: estimate {estimate}, confirming by compiling")
    fits = {}

    def compiles(n: int) -> bool:
        if n not in fits:
            fw, errors = _keyframe_build(n)
            if fw is None and errors != ["rom-overflow"]:
                raise BuildError(f"{n} keyframes: unexpected errors {errors}")
            fits[n] = fw is not None
        return fits[n]

    n = estimate
    if compiles(n):
        while compiles(n + 1):
            n += 1
    else:
        while not compiles(n):
            n -= 1
    fw_max, _ = _keyframe_build(n)
    return {
        "runtime_bytes_8_servos": fw8.runtime_bytes,
        "runtime_bytes_24_servos": fw24.runtime_bytes,
        "rom_bytes_8_servos_positions": fw8.rom_bytes,
        "ram_bytes_8_servos": fw8.unit.ram_bytes,
        "ram_bytes_24_servos": fw24.unit.ram_bytes,
        "stack_bytes_24_servos": fw24.unit.stack_bytes,
        "keyframe_k": k,
        "rom_bytes_k_keyframes": fw_k.rom_bytes,
        "rom_bytes_2k_keyframes": fw_2k.rom_bytes,
        "bytes_per_keyframe_24_servos": round(per_kf, 2),
        "fixed_bytes_24_servos": round(fixed, 1),
        "keyframes_fit_estimate": estimate,
        "keyframes_fit_confirmed": n,
        "rom_bytes_at_max_keyframes": fw_max.rom_bytes,
        "ram_bytes_at_max_keyframes": fw_max.unit.ram_bytes,
    }


# ---------------------------------------------------------------- compiler time

STAGES = ("parse", "check", "plan", "lint", "generate", "assemble")


def moves_source(moves: int, poses: int = 50, seed: int = 2) -> str:
    """24 servos, `poses` random poses and `moves` moves among them in main."""
    rng = random.Random(seed)
    lines = ["# generated: compiler timing benchmark"]
    lines += [f"servo s{i} = P{i // 8}.{i % 8}" for i in range(24)]
    lines.append("group left = " + ", ".join(f"s{i}" for i in range(12)))
    for j in range(poses):
        vals = ", ".join(f"s{i}: {rng.randrange(0, 251)}" for i in range(24))
        lines.append(f"pose k{j} {{ {vals} }}")
    body = []
    for m in range(moves):
        body.append(f"  move k{rng.randrange(poses)} in {rng.choice((800, 1000, 1200, 1500))}ms")
    lines += ["main {"] + body + ["}"]
    return "\n".join(lines) + "\n"


def time_stages(text: str) -> tuple[dict[str, float], list[str]]:
    """Seconds of each stage of one compile, through servoc.api, and the error codes."""
    t = {}
    source = SourceFile("moves.servo", text)
    reporter = Reporter(source)
    t0 = time.perf_counter()
    tree = api.parse(source, reporter)
    t1 = time.perf_counter()
    program = api.check(tree, reporter)
    t2 = time.perf_counter()
    plan = api.plan(program, reporter)
    t3 = time.perf_counter()
    api.lint(plan, reporter)
    t4 = time.perf_counter()
    unit = api.generate(plan, source, reporter)
    t5 = time.perf_counter()
    if unit is None:
        raise BuildError("code generation failed: " + "; ".join(d.message for d in reporter.diagnostics))
    api.assemble(unit, reporter)
    t6 = time.perf_counter()
    for name, a, b in zip(STAGES, (t0, t1, t2, t3, t4, t5), (t1, t2, t3, t4, t5, t6)):
        t[name] = b - a
    return t, sorted({d.code for d in reporter.diagnostics if d.is_error})


def compiler_time(quick: bool, progress=None) -> dict:
    """Stage times of one cold compile (grammar and templates loaded on first use) and the
    median of the warm compiles that follow it, in the same process."""
    moves = 100 if quick else 1000
    runs = 1 if quick else 5
    say = progress or (lambda s: None)
    say(f"compiler stages: {moves}-move 24-servo program, 1 cold + {runs} warm run(s)")
    text = moves_source(moves)
    cold, errors = time_stages(text)
    samples = [time_stages(text)[0] for _ in range(runs)]
    med = {s: statistics.median(x[s] for x in samples) for s in STAGES}
    total = sum(med.values())
    return {
        "moves": moves, "servos": 24, "warm_runs": runs, "source_lines": text.count("\n"),
        "errors": errors,
        "seconds": {s: round(med[s], 4) for s in STAGES},
        "share": {s: round(med[s] / total, 3) for s in STAGES},
        "total_seconds": round(total, 4),
        "without_sdcc_seconds": round(total - med["assemble"], 4),
        "cold_seconds": {s: round(cold[s], 4) for s in STAGES},
        "cold_total_seconds": round(sum(cold.values()), 4),
    }


# ---------------------------------------------------------------- everything

def run_all(quick: bool = False, progress=None) -> dict:
    t0 = time.perf_counter()
    results = {
        "mode": "quick" if quick else "full",
        "positions": list(POSITIONS),
        "frames_decoded": FRAMES,
        "comparison": compare(FRAMES, progress),
        "frame_budget": frame_budget(quick, progress),
        "memory": memory(quick, progress),
        "compiler": compiler_time(quick, progress),
    }
    results["seconds"] = round(time.perf_counter() - t0, 1)
    return results


def _ports(n: int) -> str:
    return {1: "1 port (P0) x 8 servos", 2: "2 ports (P0, P1) x 8", 3: "3 ports (P0-P2) x 8"}[n]


def _fmt_list(xs) -> str:
    return " ".join("?" if x is None else str(x) for x in xs)


def table(r: dict) -> str:
    """One markdown table: the comparison, then servoc's own figures."""
    c = r["comparison"]
    h, s, v = c["hobby"], c["source_algorithm"], c["servoc"]
    rows: list[tuple[str, str, str, str]] = []

    def cmp(label: str, key: str, fmt=str) -> None:
        rows.append((label, fmt(h[key]), fmt(s[key]), fmt(v[key])))

    cmp(f"max abs width error per channel P1.0-P1.7 (us; N = {_fmt_list(r['positions'])})",
        "max_abs_error_us", _fmt_list)
    cmp("max abs width error, all channels (us)", "max_abs_error_all_us")
    rows.append(("exact pulses", *(f"{x['exact_pulses']}/{x['pulses']}" for x in (h, s, v))))
    cmp("frame period, mean rise-to-rise (us)", "period_mean_us", lambda x: f"{x:.1f}")
    cmp("jitter, max - min rise-to-rise (us)", "jitter_us")
    cmp("lines high after reset, first_low max (us)", "reset_high_max_us")
    cmp("ROM bytes", "rom_bytes")
    fb, mem, comp = r["frame_budget"], r["memory"], r["compiler"]
    for w in fb["worst_case"]:
        res = "" if w["resolution_us"] == 1 else f" (to {w['resolution_us']} us)"
        kind = ", run-time F" if w["runtime_f"] else ""
        rows.append((f"servoc: cycles between frames, worst case, {_ports(w['ports'])}{kind}", "", "",
                     f"{w['between_frames_cycles']}{res}"))
    for st in fb["steady_state"]:
        res = "" if st["resolution_us"] == 1 else f" (to {st['resolution_us']} us)"
        rows.append((f"servoc: cycles between frames, pose held, {_ports(st['ports'])}", "", "",
                     f"{st['between_frames_cycles']}{res}"))
    for w in fb["worst_case"]:
        if w["ports"] in (1, 3) and not w["runtime_f"]:
            rows.append((f"servoc: shortest exact P / default P, worst case, {w['servos']} servos (us)", "", "",
                         f"{w['shortest_exact_p_us']} / {w['default_p_us']}"))
    for st in fb["steady_state"]:
        if st["ports"] in (1, 3):
            rows.append((f"servoc: shortest exact P / default P, pose held, {st['servos']} servos (us)", "", "",
                         f"{st['shortest_exact_p_us']} / {st['default_p_us']}"))
    rows += [
        ("servoc: ROM runtime bytes, 8 / 24 servos", "", "",
         f"{mem['runtime_bytes_8_servos']} / {mem['runtime_bytes_24_servos']}"),
        ("servoc: ROM bytes per 24-servo keyframe", "", "", f"{mem['bytes_per_keyframe_24_servos']}"),
        ("servoc: 24-servo keyframes in 8 KB, estimated / largest that compiles", "", "",
         f"{mem['keyframes_fit_estimate']} / {mem['keyframes_fit_confirmed']}"),
        ("servoc: RAM bytes, 8 / 24 servos", "", "", f"{mem['ram_bytes_8_servos']} / {mem['ram_bytes_24_servos']}"),
    ]
    secs, share = comp["seconds"], comp["share"]
    stage_text = ", ".join(f"{k} {secs[k]:.3f} s ({100 * share[k]:.0f}%)" for k in STAGES)
    fit = "fits" if not comp["errors"] else ", ".join(comp["errors"])
    rows += [
        (f"servoc: compile time per stage, {comp['moves']}-move 24-servo program ({fit}), warm median", "", "",
         stage_text),
        ("servoc: compile time total / without SDCC (assemble) / first compile in the process (s)", "", "",
         f"{comp['total_seconds']:.3f} / {comp['without_sdcc_seconds']:.3f} / {comp.get('cold_total_seconds', 0):.3f}"),
    ]
    head = ("figure", "hobby.c (SDCC, Timer0)", "source_algorithm.asm", "servoc")
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)
