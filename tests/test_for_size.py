"""Firmware built for size (`Plan.compact`): what `servoc compile` builds when the fast build does
not fit the chip's code memory. The motion code runs in per-port loops, the pairs are loaded
and merged in loops (the sort stays unrolled), runs of move records share one flags byte and F,
and the runtime leaves out what the program does not use. Its period is read from its own code
like any other's: every program here verifies in ucsim, to the cycle, at the minimum it reports.
"""

import dataclasses
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import build_text, front_end_text, pose, servo_decls
from servoc import api, layout
from test_costs import ADVERSARIAL, all_at, at_period, own_minimum, programs

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import suite  # noqa: E402  the benchmark's random 24-servo keyframe programs


def _min_for_size(template: str, period: int) -> int:
    fe, diags = front_end_text(at_period(template, period))
    assert fe.plan is not None, diags
    return api.choose_period(fe.plan.program, dataclasses.replace(fe.plan, compact=True)).min_period_us


def own_minimum_for_size(template: str, start: int = 20000) -> int:
    """The period P with P >= the minimum the code built for size reports at P (F depends on P)."""
    period = start
    for _ in range(6):
        least = _min_for_size(template, period)
        if least == period:
            return period
        period = least
    return max(period, _min_for_size(template, period))


def _verify_for_size(template: str, frames: int, start: int = 20000):
    period = own_minimum_for_size(template, start)
    built = build_text(at_period(template, period), for_size=True)
    assert built.plan.compact and built.plan.period_us == built.plan.min_period_us == period
    report = built.verify(frames)
    assert report.ok and report.max_error_cycles == 0, (period, report.summary(),
                                                        [str(m) for m in report.mismatches[:5]])
    assert _min_for_size(template, period - 1) > period - 1
    return built


@pytest.mark.parametrize("name,line", [("carry-24", ""), ("eased", ""), ("runtime-f", ""), ("deep-24", ""),
                                       ("start-8", ""), ("zero-frame", ""),
                                       ("spread-24", "target stc89c52rc clock 11.0592MHz"),
                                       ("runtime-f", "target stc89c52rc clock 11.0592MHz"),
                                       ("eased", "target stc89c52rc clock 11.0592MHz mode 6T")])
def test_adversarial_programs_built_for_size_verify_at_their_reported_minimum(name, line):
    template = (line + "\n" if line else "") + ADVERSARIAL[name]
    built = _verify_for_size(template, 120, 9000 if "6T" in line else 20000)
    text = built.firmware.unit.text
    assert "LCALL   step_port" in text and "sort" in text
    # the sort stays unrolled: no backward branch in it
    sort = text[text.index("\nsort"):text.index("RET", text.index("\nsort"))]
    assert "DJNZ" not in sort and "SJMP" not in sort


SCATTERED_PINS = [(0, 1), (0, 4), (0, 7), (1, 0), (1, 3), (1, 6), (2, 2), (2, 5), (2, 7)]
SCATTERED_NAMES = [f"s{p}_{b}" for p, b in SCATTERED_PINS]
SCATTERED = (servo_decls(SCATTERED_PINS, options="speed 0.0001s/60deg")
             + pose("a", {n: 10 + 25 * i for i, n in enumerate(SCATTERED_NAMES)})
             + pose("b", {n: 240 - 23 * i for i, n in enumerate(SCATTERED_NAMES)})
             + pose("c", {n: 125 for n in SCATTERED_NAMES[::3]})
             + "sequence s { move c in {1P}us; hold {2P}us; move b in {3P}us ease in-out }\n"
             + "main { move a in {1P}us; loop { repeat 2 { play s; move a in {2P}us }; move c in {1P}us; "
             + "move b in {1P}us; move a in {1P}us } }\n")


@pytest.mark.parametrize("line", ["", "target stc89c52rc clock 11.0592MHz"])
def test_servos_on_scattered_pins_built_for_size_verify_at_their_minimum(line):
    """Ports whose servos are not their pins 0, 1, ...: frame_io copies them one by one, the
    motion loops still go over all 8 pins of each port; moves that name some servos (masks)."""
    built = _verify_for_size((line + "\n" if line else "") + SCATTERED, 150)
    assert "LCALL   load" not in built.firmware.unit.text


@settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(programs())
def test_generated_programs_built_for_size_verify_at_their_reported_minimum(template):
    _verify_for_size(template, 100)


def test_records_with_the_same_flags_and_f_share_them():
    def move(f: int, n: int, eased: bool = False) -> dict:
        flags, data = layout.move_record(f, "etab1" if eased else None, {0: n, 1: n}, None)
        return {"flags": flags, "data": data, "notes": []}

    def hold(f: int) -> dict:
        flags, data = layout.hold_record(f)
        return {"flags": flags, "data": data, "notes": []}

    runtime_f = {"flags": layout.move_record(None, None, {0: 1}, [1])[0],
                 "data": layout.move_record(None, None, {0: 1}, [1])[1], "notes": []}
    records = [move(5, 1), move(5, 2), move(5, 3), move(300, 4), move(300, 5), hold(5), move(5, 6),
               move(5, 7, True), runtime_f, runtime_f]
    out = layout.share_headers(records)
    assert [len(r["data"]) for r in out] == [5, 2, 2, 6, 2, 2, 4, 6, 3, 3]
    more = 1 << layout.MORE_BIT
    assert out[0]["data"][:2] == [layout.hex8(records[0]["flags"] | more), "2"]
    assert out[1]["data"] == ["2", "2"] and out[2]["data"] == ["3", "3"]
    assert out[3]["data"][:2] == [layout.hex8(records[3]["flags"] | more), "1"]
    assert out[5] == records[5] and out[6] == records[6] and out[8:] == records[8:]   # each alone
    # a count names at most 255 records
    many = layout.share_headers([move(5, i % 250) for i in range(300)])
    assert [r["data"][1] for r in many if r.get("more")] == ["255", "43"]
    assert sum(len(r["data"]) for r in many) == 300 * 2 + 2 * 3


def test_a_program_that_fits_is_built_for_speed():
    built = build_text(suite.keyframe_source(20))
    assert not built.plan.compact and "LCALL   step_port" not in built.firmware.unit.text


def test_where_the_fast_build_does_not_fit_it_goes_without_first_step_before_going_for_size():
    """72 of the benchmark's hexapod gait steps (linear and eased moves): built for speed with
    `first_step` (a linear move's pins set up and first stepped in one call; the eased moves'
    pins in two passes) they need more than 8 KB; without it (both in two passes, less code) they
    fit, still built for speed (not for size, whose period is longer), and their first moves verify."""
    text = suite.gait_source(72)
    built = build_text(text)
    assert not built.plan.compact and not built.plan.first_step and built.firmware.rom_bytes <= 8192
    assert "setup_step" not in built.firmware.unit.text and "LCALL   dda_step" in built.firmware.unit.text
    with_it = api.choose_period(built.plan.program, dataclasses.replace(built.plan, first_step=True), decide=False)
    unit = api.codegen.generate(with_it)
    assert layout.rom_end(unit.text) > 8192 and unit.both_passes
    assert not api.codegen.generate(built.plan).both_passes
    size = api.choose_period(built.plan.program, dataclasses.replace(built.plan, compact=True), decide=False)
    assert built.plan.min_period_us < size.min_period_us
    moves = built.plan.moves[:2]
    report = built.verify(sum(m.frames for m in moves) + 3)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:5]])


def test_250_random_keyframes_fit_8_kb_built_for_size_and_verify():
    """The benchmark's program: 24 servos, 250 random poses, each moved to in 1 s. Built for
    speed it needs more than 8 KB; built for size it fits, and its first moves verify."""
    built = build_text(suite.keyframe_source(250))
    assert built.plan.compact and built.firmware.rom_bytes <= 8192
    moves = built.plan.moves[:3]
    report = built.verify(sum(m.frames for m in moves) + 3)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:5]])


def _big_serial_program(seed: int = 7) -> str:
    """hexapod_serial.servo with 14 gait variants of 10 random 24-servo poses each, played once at
    power-up and then on a byte each: too big for 8 KB built for speed."""
    import random
    rng = random.Random(seed)
    text = (Path(__file__).resolve().parent.parent / "examples" / "hexapod_serial.servo").read_text()
    head, main = text[:text.index("home rest")], text[text.index("home rest"):]
    names = [line.split()[1] for line in head.splitlines() if line.startswith("servo ")]
    poses, seqs = [], []
    for v in range(14):
        moves = []
        for j in range(10):
            poses.append(f"pose v{v}_{j} {{ " + ", ".join(f"{n}: {rng.randrange(80, 111)}deg" for n in names) + " }")
            moves.append(f"  move v{v}_{j} in {rng.choice([400, 400, 500])}ms")
        moves.append("  move stand in 500ms ease in-out")      # where the select's branches start from
        seqs.append(f"sequence gait{v} {{\n" + "\n".join(moves) + "\n}")
    main = main.replace('  send "R"\n', '  send "R"\n' + "".join(f"  play gait{v}\n" for v in range(3)))
    ons = "".join(f'      on "{chr(ord("A") + v)}" {{ play gait{v}; send "{chr(ord("A") + v)}" }}\n' for v in range(14))
    main = main.replace('      on other', ons + '      on other')
    return head + "\n".join(poses) + "\n" + "\n".join(seqs) + "\n" + main


def test_a_big_program_with_a_serial_line_and_selects_is_built_for_size_and_verifies():
    """Built for speed it does not fit; built for size it does, at the 20 ms it asks for, and its
    first moves (three gaits, runs of records sharing flags and F, eased ends) verify."""
    from conftest import compile_file
    import tempfile
    import os
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "big.servo")
        Path(path).write_text(_big_serial_program())
        built, fe, diags = compile_file(path)       # api.build: for size, as speed does not fit
        assert built is not None, [d.message for d in diags if d.is_error]
        source, reporter = api.load_source(path)
        chosen = api.front_end(source, reporter).plan
        assert chosen.compact                       # the period stage chose the build for size, for lint too
        fast = api.choose_period(chosen.program, dataclasses.replace(chosen, compact=False), decide=False)
        assert not fast.compact
        assert api.assemble(api.generate(fast, source, reporter), reporter) is None    # built for speed: too big
        assert [d.code for d in reporter.diagnostics if d.is_error] == ["rom-overflow"]
    assert built.plan.compact and built.plan.period_us == 20000
    assert "MOREC" in built.firmware.unit.text
    report = built.verify(40 + 3 * 250 + 10)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:5]])


def test_too_big_even_built_for_size_says_so():
    from servoc.source import SourceFile
    from servoc.diagnostics import Reporter
    source = SourceFile("many.servo", suite.keyframe_source(300))
    reporter = Reporter(source)
    fe, fw = api.build(source, reporter)
    errors = [d for d in reporter.diagnostics if d.is_error]
    assert fw is None and fe.plan.compact and [d.code for d in errors] == ["rom-overflow"]
    assert "code memory even built for size" in errors[0].message
    # lint says the same: the period stage measured the build for size (no program lint accepts fails
    # to compile)
    linted = Reporter(source)
    api.front_end(source, linted)
    assert [(d.code, d.message) for d in linted.diagnostics if d.is_error] == [(d.code, d.message) for d in errors]


@st.composite
def two_class_programs(draw):
    """Moves whose F is found at run time on servos of two speed classes spread over two ports: the
    firmware keeps each class's largest |delta| and looks its frames up once per record. A servo
    left out of the first pose gets its first target in such a move (set at once: it adds nothing)."""
    n = draw(st.integers(6, 10))
    slow = [i % 2 == 1 for i in range(n)]
    decl = "".join(f"servo s{i} = P{1 + i // 8}.{i % 8}{' speed 0.3s/60deg' if slow[i] else ''}\n"
                   for i in range(n))
    b = [draw(st.integers(0, 250)) for _ in range(n)]
    poses = [[20 + 11 * i for i in range(n)], b, [230 - 13 * i for i in range(n)]]      # `go` from a and from c
    first = ", ".join(f"s{i}: {poses[0][i]}" for i in range(n - 1))        # s{n-1} has no target yet
    return (decl + f"pose a {{ {first} }}\n" + all_at("b", n, poses[1].__getitem__)
            + all_at("c", n, poses[2].__getitem__)
            + "sequence go { move b }\nmain { move a; loop { play go; move c; play go; move a } }\n")


@settings(max_examples=4, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(two_class_programs())
def test_run_time_f_with_two_speed_classes_verifies_built_for_speed_and_for_size(template):
    """Every move once, in both builds, each at its own minimum: F is the most frames any class's
    largest |delta| needs, to the frame (the planner's rule, `plan.move_frames_at`)."""
    period = own_minimum(template)
    fast = build_text(at_period(template, period))
    frames = sum(m.frames for m in fast.plan.moves) + 2
    assert not fast.plan.compact and any(m.step.frames is None for m in fast.plan.moves)
    assert "DMAX1" in fast.firmware.unit.text
    report = fast.verify(frames)
    assert report.ok and report.max_error_cycles == 0, (period, report.summary(), [str(m) for m in report.mismatches[:5]])
    small = _verify_for_size(template, frames)
    assert "sp_dm" in small.firmware.unit.text
