"""The benchmark report: servoc's firmware against two baselines, and the compiler's own figures.

- `compare`: servoc's firmware and the two baselines (baselines.py) drive the
  same 8 servos on P1 and go through one decoder: width error per channel,
  frame period, jitter, lines high after reset, ROM.
- `budget.frame_budget`: the shortest P servoc reports next to the shortest
  that verifies exactly in ucsim, for the worst-case stress programs and a
  held pose (budget.py), and the default P servoc picks; `budget.clock_budget`
  the same at other crystals and with the serial line busy; `budget.examples_budget`
  for the examples (real programs) at three clocks; `engine_terms.goal_rows` for the 24-servo goal
  program (every port's lines over the full range) at 12 MHz, 22.1184 MHz on two chips and
  11.0592 MHz 6T (full run only: about 13 minutes).
- `before_column`: for each of those programs, the shortest P servoc reported at revision BEFORE,
  whose ports were pulsed one after another (revision.reported_at), beside today's.
- `memory`: ROM (runtime, per keyframe, keyframes that fit 8 KB) and RAM.
- `compiler_time`: the time of each compiler stage.

`run_all(quick)` returns everything as one JSON-ready dict; `table(results)`
renders it as a markdown table. benchmarks/run.py is the command line.
"""

from __future__ import annotations

import dataclasses
import random
import statistics
import time
from pathlib import Path

from baselines import (FRAMES, POSITIONS, BuildError, Decoded, build_hobby, build_source_algorithm,
                       measure_baseline, positions_source)
from budget import BEFORE_KEY, SPAN, clock_budget, examples_budget, frame_budget, hold_source
from engine_terms import goal_rows
from revision import reported_at
from servoc import api, codegen, target, toolchain
from servoc.diagnostics import Reporter
from servoc.source import SourceFile

BEFORE = "5f75dbb"
"""The revision of the "before" column: the last whose three ports were pulsed one after another
(the 24-servo goal program's shortest P 7833 us at 12 MHz, 7681 us at 22.1184 MHz)."""
ROM_SIZE = target.CHIPS[target.DEFAULT_CHIP].code_bytes
EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


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


def gait_source(k: int, seed: int = 3) -> str:
    """The hexapod of examples/hexapod.servo walking `k` tripod steps, each with its own angles
    (6 moves a step, each naming the few servos that move), all in main's loop."""
    rng = random.Random(seed)
    text = (EXAMPLES / "hexapod.servo").read_text(encoding="utf-8")
    out, body = [text[:text.index("sequence tripod_step")]], []
    for v in range(k):
        up, fwd, back, down = rng.randrange(35, 46), rng.randrange(105, 116), rng.randrange(65, 76), rng.randrange(55, 66)
        out.append(f"pose a_up{v} = stand with {{ tripod_a_femurs: {up}deg }}\n"
                   f"pose a_fwd{v} = a_up{v} with {{ tripod_a_coxae: {fwd}deg, tripod_b_coxae: {back}deg }}\n"
                   f"pose a_down{v} = a_fwd{v} with {{ tripod_a_femurs: {down}deg }}\n"
                   f"pose b_up{v} = a_down{v} with {{ tripod_b_femurs: {up}deg }}\n"
                   f"pose b_fwd{v} = b_up{v} with {{ tripod_b_coxae: {fwd}deg, tripod_a_coxae: {back}deg }}\n"
                   f"pose b_down{v} = b_fwd{v} with {{ tripod_b_femurs: {down}deg }}\n")
        body += [f"    move {p}{v} in {t}ms" for p, t in (("a_up", 120), ("a_fwd", 200), ("a_down", 120),
                                                        ("b_up", 120), ("b_fwd", 200), ("b_down", 120))]
    out.append("main {\n  move rest in 1s\n  move stand in 800ms ease out\n  loop {\n" + "\n".join(body) + "\n  }\n}\n")
    return "".join(out)


def _build(text: str, how: str) -> tuple[api.FrontEnd, api.Firmware | None, list[str]]:
    """Compile as `servoc compile` does (`how` "compile": for speed, for size if that does not
    fit), or only for speed ("speed") or only for size ("size")."""
    if how == "speed":
        source = SourceFile("bench.servo", text)
        reporter = Reporter(source)
        fe = api.front_end(source, reporter)
        if fe.plan is not None and fe.plan.compact:     # the period stage chose size: the speed build's plan
            fe = dataclasses.replace(fe, plan=api.choose_period(
                fe.plan.program, dataclasses.replace(fe.plan, compact=False), decide=False))
        unit = api.generate(fe.plan, source, reporter)
        fw = None if unit is None else api.assemble(unit, reporter)
    else:
        fe, fw, reporter = compile_text(text, "bench.servo", how == "size")
    return fe, fw, [d.code for d in reporter.diagnostics if d.is_error]


def _leanest(text: str, how: str) -> int:
    """The ROM bytes of `text` built `how` without rises as steps or among falls (codegen.generate)
    and, built for speed, without `first_step` where that is smaller (api.choose_period): where the
    code with them might not fit, the build goes without them."""
    fe, _, _ = _build(text, how)
    plans = [fe.plan]
    if not fe.plan.compact:
        plans.append(api.choose_period(fe.plan.program, dataclasses.replace(fe.plan, first_step=False), decide=False))
    sizes = []
    for plan in plans:
        fw = api.assemble(codegen.generate(plan, fe.source, stepping=False), Reporter(fe.source))
        sizes.append(fw.rom_bytes)
    return min(sizes)


def most_that_fit(make_source, k: int, how: str, say) -> dict:
    """The most items `make_source(n)` can hold in 8 KB built `how` (see `_build`): estimated from
    the bytes k and 2k items take (built for speed, or for size when `how` is not "speed"), then
    confirmed by compiling."""
    est = "speed" if how == "speed" else "size"
    (_, fw_k, err_k), (_, fw_2k, err_2k) = _build(make_source(k), est), _build(make_source(2 * k), est)
    if fw_k is None or fw_2k is None:
        raise BuildError(f"{k} and {2 * k} items did not compile: {err_k} {err_2k}")
    # near the limit the build drops what it can (`_leanest`): the bytes per item from two builds of
    # the same kind (else from the leanest of each), the rest from the leanest
    kind = lambda fw: (fw.unit.budget.steps, fw.unit.budget.stagger) if fw.unit.budget else None   # noqa: E731
    if kind(fw_k) == kind(fw_2k):
        per_item = (fw_2k.rom_bytes - fw_k.rom_bytes) / k
    else:
        per_item = (_leanest(make_source(2 * k), est) - _leanest(make_source(k), est)) / k
    fixed = min(fw_k.rom_bytes, _leanest(make_source(k), est)) - k * per_item
    estimate = int((ROM_SIZE - fixed) // per_item)
    say(f"  built {how}: estimate {estimate}, confirming by compiling")
    fits: dict[int, bool] = {}

    def compiles(n: int) -> bool:
        if n not in fits:
            _, fw, errors = _build(make_source(n), how)
            if fw is None and errors != ["rom-overflow"]:
                raise BuildError(f"{n} items: unexpected errors {errors}")
            fits[n] = fw is not None
        return fits[n]

    n = estimate
    if compiles(n):
        while compiles(n + 1):
            n += 1
    else:
        while not compiles(n):
            n -= 1
    fe, fw, _ = _build(make_source(n), how)
    return {"bytes_per_item": round(per_item, 2), "runtime_bytes": fw_k.runtime_bytes, "estimate": estimate,
            "confirmed": n, "rom_bytes": fw.rom_bytes, "ram_bytes": fw.unit.ram_bytes,
            "period_us": fw.unit.period_us, "built_for_size": fe.plan.compact}


def memory(quick: bool, progress=None) -> dict:
    say = progress or (lambda s: None)
    say("ROM and RAM: positions program")
    _fe8, fw8 = build_servoc()
    _fe24, fw24 = build_servoc(hold_source(3, None), "hold.servo")
    out = {
        "runtime_bytes_8_servos": fw8.runtime_bytes,
        "runtime_bytes_24_servos": fw24.runtime_bytes,
        "rom_bytes_8_servos_positions": fw8.rom_bytes,
        "ram_bytes_8_servos": fw8.unit.ram_bytes,
        "ram_bytes_24_servos": fw24.unit.ram_bytes,
        "stack_bytes_24_servos": fw24.unit.stack_bytes,
    }
    # random 24-servo keyframes and the hexapod's varied gait: built for speed only, and as
    # `servoc compile` builds them (for size, once they no longer fit built for speed)
    for name, make_source, k in (("keyframes", keyframe_source, 10 if quick else 20),
                                 ("gait_steps", gait_source, 5 if quick else 10)):
        for how in ("speed", "compile"):
            say(f"{name} that fit 8 KB")
            out[f"{name}_{how}"] = most_that_fit(make_source, k, how, say)
    return out


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
        "examples_budget": examples_budget(quick, progress),
        "goal_budget": [] if quick else goal_rows(60, progress),
        "memory": memory(quick, progress),
        "compiler": compiler_time(quick, progress),
    }
    if progress:
        progress(f"shortest P reported at {BEFORE}, each program")
    results["before"] = before_column(results)
    results["seconds"] = round(time.perf_counter() - t0, 1)
    return results


def _period_rows(results: dict) -> list[dict]:
    """The rows that report a shortest P, in the table's order."""
    fb = results["frame_budget"]
    return (fb["worst_case"] + fb["steady_state"] + results["clock_budget"] + results["goal_budget"]
            + results["examples_budget"])


def before_column(results: dict, rev: str = BEFORE) -> str:
    """Each row's program (BEFORE_KEY, then dropped from the row) planned by revision `rev`: its
    shortest P reported there, as the row's `before_us` (or the error codes `rev` gave). Returns `rev`."""
    rows = _period_rows(results)
    for x, got in zip(rows, reported_at(rev, [x.pop(BEFORE_KEY) for x in rows])):
        x["before_us"] = got
    return rev


def _servos(ports: int) -> str:
    return {1: "8 servos on P0", 2: "16 servos on P0-P1", 3: "24 servos on P0-P2"}[ports]


def _budget_rows(fb: dict) -> list[tuple[str, ...]]:
    """Per program: servoc's shortest P against the shortest exact in ucsim (and the shortest P
    reported before: `_before`), cycles over the pulses, default P."""
    label = "servoc: shortest P reported / shortest exact in ucsim / difference"
    rows = []
    cases = [(w, "worst case", ", run-time F" if w["runtime_f"] else "") for w in fb["worst_case"]]
    cases += [(st, "pose held", "") for st in fb["steady_state"]]
    for x, what, kind in cases:
        name = f"{what}, {_servos(x['ports'])}{kind}"
        rows += [
            (f"{label}, {name} (us)", "", "", _period(x), _before(x)),
            (f"servoc: cycles over the pulses at N 250 (shortest exact P - ports x {SPAN}; below 0: the spans fitted to the lines are shorter), {name}", "", "",
             f"{x['over_pulses_cycles']}{_resolution(x)}"),
        ]
        if not kind:
            rows.append((f"servoc: default P, {name} (us)", "", "", f"{x['default_p_us']}"))
    for x in fb.get("clocks", ()):
        kind = "".join(f", {k}" for k in ("run-time F" if x.get("runtime_f") else "", x.get("serial", "")) if k)
        rows.append((f"{label}, worst case, {_servos(x['ports'])}, {x['target']}{kind} (us)", "", "", _period(x), _before(x)))
    for x in fb.get("goal", ()):
        rows.append((f"{label}, the goal program (24 moving servos, N 0 and 250 on every port), {x['clock']}"
                     f"{'' if x['build'] in x['clock'] else ', ports ' + x['build']} (us)", "", "", _period(x), _before(x)))
    for x in fb.get("examples", ()):
        rows.append((f"{label}, {x['program']}, {x['target']} (us)", "", "", _period(x), _before(x)))
    return rows


def _reported(x: dict) -> int:
    return x["reported_us"] if "reported_us" in x else x["reported_min_p_us"]


def _period(x: dict) -> str:
    """A row's shortest P reported, the shortest exact in ucsim, and the difference."""
    return (f"{_reported(x)} / {x['shortest_exact_p_us']}{_resolution(x)} / {x['difference_us']:+d} ({_over(x)})")


def _before(x: dict) -> str:
    """The shortest P the revision before the ports overlapped reported for the row's program
    (`before_column`), and today's against it; empty where not measured."""
    got = x.get("before_us")
    if got is None:
        return ""
    if isinstance(got, list):
        return "refused: " + ", ".join(got)
    return f"{got} ({100 * (_reported(x) - got) / got:+.1f}%)"


def _resolution(x: dict) -> str:
    """How finely the shortest exact P was searched, where coarser than 1 us."""
    return "" if x["resolution_us"] == 1 else f" (to {x['resolution_us']} us)"


def _over(x: dict) -> str:
    """The reported shortest P over the exact one, in percent."""
    return f"{100 * x['difference_us'] / x['shortest_exact_p_us']:+.1f}%"


def _fmt_list(xs) -> str:
    return " ".join("?" if x is None else str(x) for x in xs)


def table(r: dict) -> str:
    """One markdown table: the comparison, then servoc's own figures."""
    c = r["comparison"]
    h, s, v = c["hobby"], c["source_algorithm"], c["servoc"]
    rows: list[tuple[str, ...]] = []

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
    fb, mem, comp = ({**r["frame_budget"], "clocks": r.get("clock_budget", []), "examples": r.get("examples_budget", []),
                                  "goal": r.get("goal_budget", [])},
                     r["memory"], r["compiler"])
    rows += _budget_rows(fb)
    rows += [
        ("servoc: ROM runtime bytes, 8 / 24 servos / 24 servos built for size (keyframes)", "", "",
         f"{mem['runtime_bytes_8_servos']} / {mem['runtime_bytes_24_servos']} / {mem['keyframes_compile']['runtime_bytes']}"),
        *[(f"servoc: {what} in 8 KB, built for speed / as compiled (estimated / largest that compiles; "
            f"bytes each; period)", "", "",
            " / ".join(f"{m['estimate']}/{m['confirmed']} ({m['bytes_per_item']} B; "
                       f"{'for size, ' if m['built_for_size'] else ''}P = {m['period_us']} us)"
                       for m in (mem[f"{key}_speed"], mem[f"{key}_compile"])))
          for what, key in (("random 24-servo keyframes", "keyframes"), ("hexapod gait steps (6 moves)", "gait_steps"))],
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
    head = ("figure", "hobby.c (SDCC, Timer0)", "source_algorithm.asm", "servoc",
            f"servoc at {r.get('before') or BEFORE} (ports one after another): shortest P reported (us; today against it)")
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(row + ("",) * (len(head) - len(row))) + " |" for row in rows]
    return "\n".join(lines)
