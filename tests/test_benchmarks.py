"""Tests of the benchmarks (baselines.py, budget.py, suite.py, run.py) on their cheap pieces.

The baselines are built with SDCC and run in ucsim like in the benchmark;
the figures checked are the ones the comparison is about: the hobby frame is
about 20 ms with inexact widths, the source algorithm is exact except where
its traps (zero differences) send DJNZ round 256 times, servoc is exact.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import re
import sys
from pathlib import Path

import pytest

from servoc import api, target, toolchain
from servoc.sim import PortWrite, SimTrace

pytestmark = pytest.mark.toolchain

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def _load(module_name: str, file_name: str):
    """Load a benchmark module under the name the others import it by (so load them in import order)."""
    spec = importlib.util.spec_from_file_location(module_name, BENCH / file_name)
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


baselines = _load("baselines", "baselines.py")
budget = _load("budget", "budget.py")
_load("engine_terms", "engine_terms.py")
revision = _load("revision", "revision.py")
suite = _load("suite", "suite.py")
run_cli = _load("bench_run", "run.py")

FRAMES = 12
TRAP_US = 256 * 8          # DJNZ from 0: 256 DIVs


@pytest.fixture(scope="module")
def hobby():
    return baselines.measure_baseline(baselines.build_hobby(), 22_000, FRAMES)


@pytest.fixture(scope="module")
def source_algorithm():
    return baselines.measure_baseline(baselines.build_source_algorithm(), 11_000, FRAMES)


@pytest.fixture(scope="module")
def servoc_side():
    return suite.measure_servoc(FRAMES)


def test_baselines_drive_the_same_positions():
    assert baselines.baseline_positions(baselines.HOBBY_C) == baselines.POSITIONS
    assert baselines.baseline_positions(baselines.SOURCE_ASM) == baselines.POSITIONS
    assert re.search(r"pose p \{ s0: 0, s1: 1, s2: 125, s3: 125", baselines.positions_source())
    # both ends, a tie and adjacent values
    assert {0, 250} <= set(baselines.POSITIONS) and len(set(baselines.POSITIONS)) < len(baselines.POSITIONS)
    assert any(b - a == 1 for a, b in zip(sorted(baselines.POSITIONS), sorted(baselines.POSITIONS)[1:]))


def test_decoder_on_a_known_trace():
    # P1.0 and P1.1 rise at 100 and 1100 (period 1000); P1.0 falls after 500 us (N = 0),
    # P1.1 after 508 and 509 us (N = 1: errors 0 and +1); P1.0 stays high 3 us after reset
    writes = [PortWrite(3, 1, 0x00)]
    for rise, w1 in ((100, 508), (1100, 509)):
        writes += [PortWrite(rise, 1, 0x03), PortWrite(rise + 500, 1, 0x02), PortWrite(rise + w1, 1, 0x00)]
    trace = SimTrace(tuple(writes), 3000)
    d = baselines.decode(trace, 1, (0, 1), 2)
    assert d.width_error_us == [[0, 0], [0, 1]]
    assert d.max_abs_error_us == [0, 1] and d.max_abs_error_all_us == 1
    assert (d.exact_pulses, d.pulses) == (3, 4)
    assert d.period_mean_us == 1000 and d.jitter_us == 0
    assert d.reset_high_us == [3, 3] and d.reset_high_max_us == 3
    with pytest.raises(ValueError, match="complete pulses"):
        baselines.decode(trace, 1, (0, 1), 3)


def test_hobby_baseline(hobby):
    # a 20 ms frame (longer by the interrupt latencies), inexact widths, lines low only after startup
    assert 19_500 <= hobby.period_mean_us <= 23_000
    assert hobby.jitter_us <= 2
    assert all(0 < e <= 200 for e in hobby.max_abs_error_us)
    assert hobby.exact_pulses == 0
    assert hobby.reset_high_max_us is not None and hobby.reset_high_max_us > 20


def test_source_algorithm_shows_the_zero_difference_trap(source_algorithm):
    d = source_algorithm
    by_line = [set(errs) for errs in d.width_error_us]
    assert all(len(s) == 1 for s in by_line), "the same widths every frame"
    err = [next(iter(s)) for s in by_line]
    # N sorted ascending: 0 (M = 0: 256 DIVs), 1, 60, 125, 125 (M = 0 again), 200, 249, 250
    assert err[0] == TRAP_US                      # N = 0 as the smallest difference
    assert sorted((err[2], err[3])) == [TRAP_US, 2 * TRAP_US]   # the tie: one edge each, 256 DIVs apart
    assert err[4] == err[5] == err[6] == 2 * TRAP_US
    assert err[1] == err[7] == TRAP_US
    assert d.reset_high_max_us is not None and d.reset_high_max_us > 500   # P1 not driven low at reset
    assert 9_000 < d.period_mean_us < 11_000 and d.jitter_us == 0


def test_source_algorithm_is_exact_without_its_traps():
    # the same code with distinct nonzero N: the deduction keeps every edge on the 8 us grid
    distinct = (3, 1, 125, 126, 200, 249, 250, 60)
    text = baselines.SOURCE_ASM.read_text()
    text = re.sub(r"^(table:\s*\.db\s+).*$", lambda m: m[1] + ", ".join(map(str, distinct)), text, flags=re.M)
    trace = baselines.simulate_frames(toolchain.assemble(text, name="distinct").hex_text, 1, 5, 7_000)
    d = baselines.decode(trace, 1, distinct, 5)
    assert d.max_abs_error_all_us == 0
    assert d.jitter_us == 0


def test_servoc_is_exact(servoc_side):
    d, fe, fw = servoc_side
    assert d.max_abs_error_all_us == 0 and d.exact_pulses == d.pulses == 8 * FRAMES
    assert d.period_mean_us == fe.plan.period_us and d.jitter_us <= 2
    assert d.reset_high_max_us is not None and d.reset_high_max_us <= 20
    assert fw.rom_bytes <= target.DEFAULT.chip.code_bytes


def test_hold_search_brackets():
    # with the next frame's rise at the last fall nothing is exact; with a longer frame the held pose is
    assert not budget.hold_exact_at(1, target.DEFAULT.width_cycles(max(baselines.POSITIONS)), 20)
    assert budget.hold_exact_at(1, budget.pulse_floor(1) + 512, 20)


def test_the_search_down_from_the_reported_period_stops_at_the_first_failure_not_at_a_chance():
    # a predicate that holds from 1400 to 1460 by chance, fails from 1461 to 1507 and holds from
    # 1508 on (the 22.1184 MHz stress program's shape): every P from the answer to the top must hold
    calls = []

    def ok(p):
        calls.append(p)
        return 1400 <= p <= 1460 or p >= 1508

    assert budget.holds_down_to(ok, 1000, 1600) == 1508
    assert calls == list(range(1600, 1506, -1))     # one build per us down to the first failure
    assert budget.holds_down_to(lambda p: p >= 1001, 1000, 1600) == 1001      # the lower bound is never tried
    with pytest.raises(AssertionError):
        budget.holds_down_to(lambda p: p > 1600, 1000, 1600)
    calls.clear()
    assert budget.holds_down_to(ok, 1000, 1600, 8) == 1508      # every 8 us, then every us above the failure
    assert calls == [1600, *range(1592, 1503, -8), *range(1511, 1506, -1)]


def test_the_stress_rows_are_scanned_below_their_reported_period_wherever_it_lies(monkeypatch):
    # with the ports' pulses overlapping, 24 servos report less than 3 x 2500 us: the scan still goes
    # down from there, one build per us, to the first failure
    calls = []
    monkeypatch.setattr(budget, "budget_period", lambda *a, **k: 6830)
    monkeypatch.setattr(budget, "exact_at", lambda ports, per_port, p, *a, **k: calls.append(p) or p >= 6647)
    assert budget.shortest_exact_period(3) == 6647 < 3 * target.DEFAULT.width_cycles(250)
    assert calls == list(range(6830, 6645, -1))


def test_the_before_column_is_each_rows_program_planned_by_the_revision_named(monkeypatch):
    """before_column hands each row's program to revision.reported_at and puts what it gives back in
    the row; the child that plans them, run here on this tree (which `reported_at` checks out as a
    worktree), gives this tree's shortest P, planned again at it where asked, and refusals' codes."""
    stress = budget.stress_source(1, 3, budget.PLANNED_AT)
    goal = sys.modules["engine_terms"].goal_source("")
    results = {"frame_budget": {"worst_case": [{budget.BEFORE_KEY: (stress, False)}],
                                "steady_state": [{budget.BEFORE_KEY: (budget.stress_source(1, 3, 100), False)}]},
               "clock_budget": [], "examples_budget": [], "goal_budget": [{budget.BEFORE_KEY: (goal, True)}]}
    asked = []

    def child_here(rev, programs):      # the worktree is this tree
        asked.append(rev)
        return json.loads(revision.child(revision._SHORTEST, revision.ROOT, stdin=json.dumps(programs)))
    monkeypatch.setattr(suite, "reported_at", child_here)
    assert suite.before_column(results, "abc1234") == "abc1234" and asked == ["abc1234"]
    first = budget.plan_text(goal, "goal")[1].min_period_us
    again = budget.plan_text(goal.replace("frame 20ms", f"frame {first}us"), "goal")[1].min_period_us
    with pytest.raises(baselines.BuildError) as refused:
        budget.plan_text(budget.stress_source(1, 3, 100), "refused")
    codes = ["infeasible-speed", "period-too-short"]
    assert sorted(set(ast.literal_eval(str(refused.value).split(": ", 1)[1]))) == codes
    assert [x["before_us"] for x in suite._period_rows(results)] == [budget.budget_period(1, 3), codes, again]
    assert all(set(x) == {"before_us"} for x in suite._period_rows(results))


def test_reported_at_checks_a_revision_out_beside_the_tree_and_removes_it_again():
    """revision.reported_at on this repository's HEAD: that revision's own servoc plans each program
    (a shortest P, or a refusal's codes) in a worktree that is gone again after."""
    import subprocess
    listed = lambda: subprocess.run(["git", "-C", str(revision.ROOT), "worktree", "list"],      # noqa: E731
                                    capture_output=True, text=True, check=True).stdout
    before = listed()
    got = revision.reported_at("HEAD", [(budget.stress_source(1, 3, budget.PLANNED_AT), False),
                                        (budget.stress_source(1, 3, 100), False)])
    assert isinstance(got[0], int) and 1000 < got[0] < budget.PLANNED_AT
    assert "period-too-short" in got[1]
    assert listed() == before


def test_keyframes():
    mem = suite.memory(quick=True)
    for key in ("keyframes", "gait_steps"):
        speed, compiled = mem[f"{key}_speed"], mem[f"{key}_compile"]
        for m, how in ((speed, "speed"), (compiled, "compile")):
            assert m["bytes_per_item"] > 0 and m["rom_bytes"] <= target.DEFAULT.chip.code_bytes
            assert abs(m["confirmed"] - m["estimate"]) <= 3
            _, fw, errors = suite._build(suite.keyframe_source(m["confirmed"] + 1) if key == "keyframes"
                                         else suite.gait_source(m["confirmed"] + 1), how)
            assert fw is None and errors == ["rom-overflow"]
        # built for speed, more would not fit; `servoc compile` builds those for size
        assert not speed["built_for_size"] and compiled["built_for_size"]
        assert compiled["confirmed"] > speed["confirmed"]
    assert mem["keyframes_compile"]["confirmed"] >= 250
    assert 0 < mem["ram_bytes_8_servos"] <= mem["ram_bytes_24_servos"] <= 256


def test_compile_stages():
    comp = suite.compiler_time(quick=True)
    assert set(comp["seconds"]) == set(suite.STAGES)
    assert all(t > 0 for t in comp["seconds"].values())
    assert abs(sum(comp["share"].values()) - 1) < 0.01
    assert comp["without_sdcc_seconds"] < comp["total_seconds"]
    assert comp["errors"] == []


def test_table_and_json(tmp_path, monkeypatch, hobby, source_algorithm, servoc_side):
    # the command end to end, with the slow searches replaced by small fixed results
    d, fe, fw = servoc_side
    fake = {
        "mode": "quick", "positions": list(baselines.POSITIONS), "frames_decoded": FRAMES, "seconds": 1.0,
        "comparison": {"hobby": {"rom_bytes": 1, **hobby.summary()},
                       "source_algorithm": {"rom_bytes": 2, **source_algorithm.summary()},
                       "servoc": {"rom_bytes": fw.rom_bytes, "period_chosen_us": fe.plan.period_us, **d.summary()}},
        "frame_budget": {"port_span_cycles": budget.SPAN,
                         "worst_case": [{"ports": p, "servos": 8 * p, "runtime_f": rf, "reported_min_p_us": 10020,
                                         "shortest_exact_p_us": 9999, "difference_us": 21, "resolution_us": 8,
                                         "over_pulses_cycles": 777, "default_p_us": 5300}
                                        for p in (1, 3) for rf in (False, True)],
                         "steady_state": [{"ports": p, "servos": 8 * p, "reported_min_p_us": 2600 * p,
                                           "shortest_exact_p_us": 2540 * p, "difference_us": 60 * p,
                                           "resolution_us": 1, "over_pulses_cycles": 30, "default_p_us": 5300}
                                          for p in (1, 3)]},
        "examples_budget": [{"program": "examples/biped.servo", "target": "at89c52 clock 22.1184MHz",
                             "reported_min_p_us": 1810, "shortest_exact_p_us": 1800, "difference_us": 10,
                             "resolution_us": 1, "before_us": ["period-too-short"]}],
        "goal_budget": [{"clock": "22.1184 MHz, STC89C52RC", "build": "at once", "reported_us": 3337,
                         "shortest_exact_p_us": 2881, "resolution_us": 8, "difference_us": 456, "before_us": 7681}],
        "before": "abc1234",
        "memory": {"runtime_bytes_8_servos": 10, "runtime_bytes_24_servos": 20, "ram_bytes_8_servos": 196,
                   "ram_bytes_24_servos": 230,
                   **{f"{key}_{how}": {"bytes_per_item": 24.0, "runtime_bytes": 15, "estimate": 146, "confirmed": 146,
                                       "rom_bytes": 8000, "ram_bytes": 240, "period_us": 8000,
                                       "built_for_size": how == "compile"}
                      for key in ("keyframes", "gait_steps") for how in ("speed", "compile")}},
        "compiler": {"moves": 100, "errors": [], "seconds": {s: 0.01 for s in suite.STAGES},
                     "share": {s: 1 / 6 for s in suite.STAGES}, "total_seconds": 0.06, "without_sdcc_seconds": 0.05},
    }
    monkeypatch.setattr(run_cli.suite, "run_all", lambda quick, progress=None: fake)
    out = tmp_path / "r.json"
    assert run_cli.main(["--quick", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["comparison"]["servoc"]["max_abs_error_all_us"] == 0
    text = suite.table(fake)
    lines = text.splitlines()
    assert lines[0].startswith("| figure | hobby.c") and lines[1].startswith("|---")
    assert all(line.count("|") == 6 for line in lines)
    assert lines[0].endswith("| servoc at abc1234 (ports one after another): shortest P reported (us; today against it) |")
    assert any("146/146 (24.0 B; P = 8000 us) / 146/146 (24.0 B; for size, P = 8000 us)" in line for line in lines)
    assert "| max abs width error, all channels (us) | " in text
    assert "777 (to 8 us)" in text and "146/146" in text
    assert ("| servoc: shortest P reported / shortest exact in ucsim / difference, worst case, 24 servos on P0-P2, "
            "run-time F (us) |  |  | 10020 / 9999 (to 8 us) / +21 (+0.2%) |  |") in text
    assert "pose held, 8 servos on P0 (us) |  |  | 2600 / 2540 / +60 (+2.4%) |  |" in text
    assert ("difference, examples/biped.servo, at89c52 clock 22.1184MHz (us) |  |  | 1810 / 1800 / +10 (+0.6%) "
            "| refused: period-too-short |" in text)
    assert ("the goal program (24 moving servos, N 0 and 250 on every port), 22.1184 MHz, STC89C52RC, ports at once "
            "(us) |  |  | 3337 / 2881 (to 8 us) / +456 (+15.8%) | 7681 (-56.6%) |") in text


def test_the_examples_benchmark_builds_each_example_at_each_clock_and_period():
    for line in budget.EXAMPLE_CLOCKS:
        for name in budget.EXAMPLES:
            text = budget.example_source(name, line, 9000)
            assert text.count("frame ") == 1 and "frame 9000us" in text
            _, plan = budget.plan_text(text, name)
            assert plan.period_us == 9000 and (not line or line.split()[1] == plan.program.target.chip.name.lower())


def test_sim_reports_all_port_writes_of_the_baselines():
    # the decoder sees P1 only; the baselines must not be writing other ports
    for hex_text in (baselines.build_hobby(), baselines.build_source_algorithm()):
        trace = api.simulate(hex_text, 30_000)
        assert {w.port for w in trace.writes} == {1}


def test_meanwhile_benchmark_programs_lint_clean_and_scale():
    """benchmarks/meanwhile.py's programs are valid at every size it measures (small ones here),
    and the `repeat` body's program does not grow with its frames."""
    _load("serial_line", "serial_line.py")
    meanwhile = _load("bench_meanwhile", "meanwhile.py")
    for frames in (100, 1_000):
        for make in (meanwhile.repeated, meanwhile.flat):
            took, ok = meanwhile.lint_seconds(make(frames))
            assert ok, make.__name__
    assert abs(len(meanwhile.repeated(100_000)) - len(meanwhile.repeated(100))) <= 3


def test_import_benchmark_files_are_read_as_their_format_and_import_clean(tmp_path):
    """benchmarks/import_scale.py's generated animations (300 frames here): each is recognised as
    its format, imports without an error, and the sampled ones meet every frame within 1 N."""
    bench = _load("bench_import", "import_scale.py")
    bench.FRAMES = 300
    for make, name, fmt in ((bench.maestro, "a.xml", "maestro"), (bench.blender, "a.json", "blender"),
                            (bench.bottango, "a.cpp", "bottango"), (bench.csv, "a.csv", "csv")):
        path = tmp_path / name
        make(path)
        row = bench.measure(path)
        assert row["format"] == fmt and row["errors"] == 0 and row["deviation"] <= 1
        # a Maestro frame is a move and the hold until the next frame starts; the others a move at most
        assert row["moves_out"] <= (2 if fmt == "maestro" else 1) * row["frames_in"] and row["frames_in"] >= 300


def test_engine_terms_goal_program_and_its_terms():
    """The 24-servo program of engine_terms.py puts N 0 and 250 on every port in one frame, and its
    CPU's term is the model's frame term (costs: sorts + W + each port's rise entry and falls)."""
    from servoc import costs
    terms_mod = _load("engine_terms", "engine_terms.py")
    _, plan = budget.plan_text(terms_mod.goal_source(""), "goal")
    ports = [[t.n for t in pose.targets[8 * k:8 * k + 8]] for pose in plan.program.poses for k in range(3)]
    assert len(ports) == 6 and all(0 in ns and 250 in ns for ns in ports) and len(plan.ports) == 3
    t = terms_mod.terms("")
    b = api.codegen.generate(plan).budget
    assert t["cpu_cycles"] == sum(b.sorts) + b.work + costs.frame_load(b)
    assert t["reported_us"] >= max(t["pulses_us"], t["cpu_us"])


def test_each_stretch_of_the_background_measured_in_ucsim_is_within_what_the_budget_charges():
    """benchmarks/background.py: the goal program of engine_terms.py with short moves, built with
    rises among falls at its own shortest period and run in ucsim with probes at frame_io's labels
    and at every run of the edge handler. The background's own cycles in each stretch (W, each
    port's sort and items) and the wall time of the work after the last sort, to the first port's
    header and to the end of its items, are at most what the budget read from the code charges for
    them, and within a fifth of it (the probes are where the budget says its parts begin and end)."""
    _load("engine_terms", "engine_terms.py")
    background = _load("background", "background.py")
    engine_terms = sys.modules["engine_terms"]
    text = re.sub(r"(servo s\d+ = P\d\.\d)( speed \S+)?", lambda m: m.group(1) + (
        " speed 0.0002s/60deg" if m.group(2) else " speed 0.0001s/60deg"),       # two speed classes, fast
        engine_terms.goal_source("", 7472)).replace("1200ms", "150ms")
    fe_plan = budget.plan_text(text, "goal", below_budget=True)[1]
    period = api.codegen.generate(fe_plan, stagger=True).min_period_us
    r = background.measure(period, text.replace("frame 7472us", f"frame {period}us"))
    parts, charged = r["parts"], r["charged"]
    assert set(charged) == set(parts) - {"chain handler", "header handler"}
    assert parts["chain handler"] > parts["header handler"] > 0
    for name, cycles in charged.items():
        assert 0.8 * cycles <= parts[name] <= cycles, (name, parts[name], cycles, parts)


def test_the_docs_figures_of_the_goal_program_are_the_codes_and_the_latest_benchmarks():
    """docs/language.md ("The shortest frame period") quotes the 24-servo goal program's terms at
    three clocks and the shortest periods that verify in ucsim: the terms are those of the code
    generated now (engine_terms.terms), the exact periods those of benchmarks/results.json, whose
    reported periods are the code's too (the latest run is current)."""
    terms_mod = _load("engine_terms", "engine_terms.py")
    docs = (BENCH.parent / "docs/language.md").read_text(encoding="utf-8")
    section = " ".join(docs[docs.index("## The shortest frame period"):docs.index("## Bringing motion in")].split())
    rows = {r["clock"]: r for r in json.loads((BENCH / "results.json").read_text(encoding="utf-8"))["goal_budget"]}
    ms = lambda us: f"{us / 1000:.3f} ms"       # noqa: E731
    n = lambda v: f"{v:,}"                      # noqa: E731
    clocks = dict(terms_mod.CLOCKS)
    want = []
    for name in ("12 MHz", "22.1184 MHz, AT89C52", "22.1184 MHz, STC89C52RC"):
        t = terms_mod.terms(clocks[name])
        assert rows[name]["reported_us"] == t["reported_us"], name
        want.append((name, t, rows[name]["shortest_exact_p_us"]))
    (_, twelve, twelve_exact), (_, at89, at89_exact), (_, stc, stc_exact) = want
    apart = terms_mod.terms(*terms_mod.APART[1:])
    expected = [
        f"the pulses' term is {ms(twelve_exact)} and the firmware verifies in ucsim from there up",
        f"the period reported is {ms(twelve['reported_us'])}",
        f"it would be {ms(apart['reported_us'])}, exact",
        f"period: {ms(at89['reported_us'])} reported (rises among falls, the last port's pulses whole), and the "
        f"firmware verifies in ucsim from {ms(at89_exact)} up",
        f"{ms(stc['reported_us'])} reported, and the firmware verifies in ucsim from {ms(stc_exact)} up",
        f"{n(stc['cpu_cycles'])} cycles of work",
        f"{n(twelve['cpu_cycles'])} cycles at 12 MHz ({n(apart['cpu_cycles'])} with the ports one after another)",
        f"{n(at89['cpu_cycles'])} on the AT89C52 at 22.1184 MHz ({ms(at89['cpu_us'])})",
        f"W is {n(twelve['work'])}, the sorts {n(apart['sorts'])} ({n(twelve['sorts'])} at 12 MHz and {n(at89['sorts'])}",
        f"the rise entries {n(apart['rises'])} ({twelve['rises']} and {at89['rises']}",
        f"the falls {n(twelve['falls'])}",
        f"one entry for the rise ({stc['rises']} cycles) and {stc['falls']} for the frame's groups",
        f"the sorts and the merging take {n(stc['sorts'])}, and W is {n(stc['work'])}",
    ]
    assert at89["work"] == twelve["work"] == apart["work"] and at89["falls"] == twelve["falls"]
    missing = [w for w in expected if w not in section]
    assert not missing, missing


def test_the_readme_table_is_the_latest_runs_and_says_what_its_before_column_shows():
    """README.md's table is suite.table of benchmarks/results.json (the run it comes from), and its
    words on the last column are that run's: no row longer than at suite.BEFORE, and by how much shorter."""
    readme = (BENCH.parent / "README.md").read_text(encoding="utf-8")
    results = json.loads((BENCH / "results.json").read_text(encoding="utf-8"))
    assert suite.table(results) in readme and results["before"] == suite.BEFORE
    rows = suite._period_rows(results)
    assert all(isinstance(x["before_us"], int) for x in rows)
    def ports(x: dict) -> int:      # the goal program's: 3; an example's: its plan's
        if "program" in x:
            name = Path(x["program"]).stem
            return len(budget.plan_text(budget.example_source(name, ""), name)[1].ports)
        return x.get("ports", 3)
    ports = [ports(x) for x in rows]
    change = [100 * (suite._reported(x) - x["before_us"]) / x["before_us"] for x in rows]
    assert max(change) < 0
    few = lambda one: (round(-max(c for c, p in zip(change, ports) if (p == 1) == one)),     # noqa: E731
                       round(-min(c for c, p in zip(change, ports) if (p == 1) == one)))
    (lo3, hi3), (lo1, hi1) = few(False), few(True)
    said = " ".join(readme.split())
    assert (f"no row is longer; the rows with two or three ports are {lo3} to {hi3} % shorter, those with one port "
            f"{lo1} to {hi1} %.") in said
