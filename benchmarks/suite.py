"""The benchmark report: servoc's firmware against two baselines, and the compiler's own figures.

- `compare`: servoc's firmware and the two baselines (baselines.py) drive the
  same 8 servos on P1 and go through one decoder: width error per channel,
  frame period, jitter, lines high after reset, ROM.
- `budget.frame_budget`: the shortest P servoc reports next to the shortest
  that verifies exactly in ucsim, for the worst-case stress programs and a
  held pose (budget.py), and the default P servoc picks.
- `memory`: ROM (runtime, per keyframe, keyframes that fit 8 KB) and RAM.
- `compiler_time`: the time of each compiler stage.

`run_all(quick)` returns everything as one JSON-ready dict; `table(results)`
renders it as a markdown table. benchmarks/run.py is the command line.
"""

from __future__ import annotations

import random
import statistics
import time

from baselines import (FRAMES, POSITIONS, BuildError, Decoded, build_hobby, build_source_algorithm,
                       measure_baseline, positions_source)
from budget import SPAN, clock_budget, frame_budget, hold_source
from servoc import api, target, toolchain
from servoc.diagnostics import Reporter
from servoc.source import SourceFile

ROM_SIZE = target.CHIPS[target.DEFAULT_CHIP].code_bytes


def compile_text(text: str, name: str = "bench.servo",
                 for_size: bool = False) -> tuple[api.FrontEnd, api.Firmware | None, Reporter]:
    """Compile .servo text through servoc.api (`api.build`); `for_size`: built for size at once."""
    source = SourceFile(name, text)
    reporter = Reporter(source)
    fe, fw = api.build(source, reporter, for_size)
    return fe, fw, reporter


def build_servoc(text: str | None = None, name: str = "positions.servo") -> tuple[api.FrontEnd, api.Firmware]:
    """Compile a program that must build (by default the positions program)."""
    fe, fw, reporter = compile_text(text or positions_source(), name)
    errors = [f"{d.code}: {d.message}" for d in reporter.diagnostics if d.is_error]
    if fw is None or errors:
        raise BuildError(f"servoc did not compile {name}: " + "; ".join(errors))
    return fe, fw


# ---------------------------------------------------------------- comparison

def measure_servoc(frames: int = FRAMES) -> tuple[Decoded, api.FrontEnd, api.Firmware]:
    """servoc's firmware for POSITIONS, measured like the baselines."""
    fe, fw = build_servoc()
    return measure_baseline(fw.hex_text, fe.plan.period_us, frames), fe, fw


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


def _keyframe_build(k: int, for_size: bool = False) -> tuple[api.Firmware | None, list[str]]:
    _fe, fw, reporter = compile_text(keyframe_source(k), "keyframes.servo", for_size)
    return fw, [d.code for d in reporter.diagnostics if d.is_error]


def memory(quick: bool, progress=None) -> dict:
    say = progress or (lambda s: None)
    say("ROM and RAM: positions program, keyframe programs")
    _fe8, fw8 = build_servoc()
    _fe24, fw24 = build_servoc(hold_source(3, None), "hold.servo")
    k = 10 if quick else 20
    # the most keyframes are built for size (what `servoc compile` does once the fast build is too big)
    fw_k, err_k = _keyframe_build(k, for_size=True)
    fw_2k, err_2k = _keyframe_build(2 * k, for_size=True)
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
    _fe_max, fw_max, _ = compile_text(keyframe_source(n), "keyframes.servo")
    return {
        "runtime_bytes_8_servos": fw8.runtime_bytes,
        "runtime_bytes_24_servos": fw24.runtime_bytes,
        "runtime_bytes_24_servos_for_size": fw_k.runtime_bytes,
        "period_us_at_max_keyframes": fw_max.unit.period_us,
        "built_for_size_at_max_keyframes": _fe_max.plan.compact,
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
        "clock_budget": clock_budget(quick, progress),
        "memory": memory(quick, progress),
        "compiler": compiler_time(quick, progress),
    }
    results["seconds"] = round(time.perf_counter() - t0, 1)
    return results


def _servos(ports: int) -> str:
    return {1: "8 servos on P0", 2: "16 servos on P0-P1", 3: "24 servos on P0-P2"}[ports]





def _budget_rows(fb: dict) -> list[tuple[str, str, str, str]]:
    """Per program: servoc's shortest P against the shortest exact in ucsim, cycles over the pulses, default P."""
    rows = []
    cases = [(w, "worst case", ", run-time F" if w["runtime_f"] else "") for w in fb["worst_case"]]
    cases += [(st, "pose held", "") for st in fb["steady_state"]]
    for x, what, kind in cases:
        res = "" if x["resolution_us"] == 1 else f" (to {x['resolution_us']} us)"
        name = f"{what}, {_servos(x['ports'])}{kind}"
        rows += [
            (f"servoc: shortest P reported / shortest exact in ucsim / difference, {name} (us)", "", "",
             f"{x['reported_min_p_us']} / {x['shortest_exact_p_us']}{res} / {x['difference_us']:+d} ({_over(x)})"),
            (f"servoc: cycles over the pulses alone (shortest exact P - ports x {SPAN}), {name}", "", "",
             f"{x['over_pulses_cycles']}{res}"),
        ]
        if not kind:
            rows.append((f"servoc: default P, {name} (us)", "", "", f"{x['default_p_us']}"))
    for x in fb.get("clocks", ()):
        kind = "".join(f", {k}" for k in ("run-time F" if x.get("runtime_f") else "", x.get("serial", "")) if k)
        rows.append((f"servoc: shortest P reported / shortest exact in ucsim / difference, worst case, "
                     f"{_servos(x['ports'])}, {x['target']}{kind} (us)", "", "",
                     f"{x['reported_min_p_us']} / {x['shortest_exact_p_us']} (to {x['resolution_us']} us) / "
                     f"{x['difference_us']:+d} ({_over(x)})"))
    return rows


def _over(x: dict) -> str:
    """The reported shortest P over the exact one, in percent."""
    return f"{100 * x['difference_us'] / x['shortest_exact_p_us']:+.1f}%"


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
    fb, mem, comp = {**r["frame_budget"], "clocks": r.get("clock_budget", [])}, r["memory"], r["compiler"]
    rows += _budget_rows(fb)
    rows += [
        ("servoc: ROM runtime bytes, 8 / 24 servos / 24 servos built for size", "", "",
         f"{mem['runtime_bytes_8_servos']} / {mem['runtime_bytes_24_servos']} / {mem['runtime_bytes_24_servos_for_size']}"),
        ("servoc: ROM bytes per 24-servo keyframe", "", "", f"{mem['bytes_per_keyframe_24_servos']}"),
        ("servoc: 24-servo keyframes in 8 KB, estimated / largest that compiles", "", "",
         f"{mem['keyframes_fit_estimate']} / {mem['keyframes_fit_confirmed']}"
         + (f" (built for size, P = {mem['period_us_at_max_keyframes']} us)"
            if mem.get("built_for_size_at_max_keyframes") else "")),
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
