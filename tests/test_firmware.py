"""The generated firmware, compiled and run in ucsim, against the golden frames.

Every test here builds .servo text with servoc.api, runs the HEX image in
ucsim and compares every pulse with `plan.expand` (api.verify), or reads the
port trace directly. They need SDCC and ucsim and never skip.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import random
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from servoc import api, costs
from servoc.diagnostics import Reporter
from servoc.plan import expand
from servoc.units import DEFAULT_T_DAV_US, t_dav_from_speed

from conftest import assert_exact, build_text, front_end_text, pose, servo_decls

pytestmark = pytest.mark.toolchain

# Every example compiles and simulates a firmware, so shrinking a failure could take many minutes:
# it is left out, and a failure prints the whole .servo text instead.
SETTINGS = dict(deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def name(pin: tuple[int, int]) -> str:
    return f"s{pin[0]}_{pin[1]}"


# ============================================================ 1. static poses, every pulse exact

@st.composite
def pins_strategy(draw, min_size: int = 1, max_size: int = 24) -> list[tuple[int, int]]:
    """Random pins over P0-P2: a random subset of bits on each port (ports may be empty)."""
    pins: list[tuple[int, int]] = []
    for port in range(3):
        bits = draw(st.sets(st.integers(0, 7)))
        pins += [(port, b) for b in sorted(bits)]
    if len(pins) < min_size:
        pins.append((draw(st.integers(0, 2)), draw(st.integers(0, 7))) if not pins else pins[0])
        pins = sorted(set(pins))
    rng = draw(st.randoms(use_true_random=False))
    if len(pins) > max_size:
        pins = sorted(rng.sample(pins, max_size))
    return pins


@st.composite
def n_values(draw, count: int) -> list[int]:
    """N values with many ties: 0, 250, a base value and its neighbours one DIV apart, or any N."""
    base = draw(st.integers(0, 249))
    pool = sorted({0, 250, base, base + 1, max(0, base - 1)})
    value = st.one_of(st.sampled_from(pool), st.sampled_from(pool), st.integers(0, 250))
    return [draw(value) for _ in range(count)]


@dataclass
class StaticCase:
    pins: list[tuple[int, int]]
    first: list[int]
    second: dict[tuple[int, int], int]
    hold_frames: int
    frame_extra: int | None      # None: default period; else frame = min period + extra


@st.composite
def static_cases(draw) -> StaticCase:
    pins = draw(pins_strategy())
    first = draw(n_values(len(pins)))
    named = draw(st.lists(st.booleans(), min_size=len(pins), max_size=len(pins)))
    second_vals = draw(n_values(len(pins)))
    second = {p: v for p, v, keep in zip(pins, second_vals, named) if keep}
    hold = draw(st.integers(0, 2))
    extra = draw(st.sampled_from([None, None, 0, 1, 333]))
    return StaticCase(pins, first, second, hold, extra)


def static_source(case: StaticCase, frame_us: int | None) -> str:
    text = "" if frame_us is None else f"frame {frame_us}us\n"
    text += servo_decls(case.pins)
    text += pose("a", {name(p): v for p, v in zip(case.pins, case.first)})
    body = "  move a\n"
    if case.second:
        text += pose("b", {name(p): v for p, v in case.second.items()})
        body += f"  hold {case.hold_frames * 20}ms\n  move b\n"
    return text + "main {\n" + body + "}\n"


def static_text(case: StaticCase) -> str:
    if case.frame_extra is None:
        return static_source(case, None)
    fe, _ = front_end_text(static_source(case, 60000))
    return static_source(case, max(fe.plan.min_period_us, 1) + case.frame_extra)


@settings(max_examples=30, **SETTINGS)
@given(static_cases())
@example(StaticCase([(p, b) for p in range(3) for b in range(8)], [0] * 24, {}, 0, None))
@example(StaticCase([(p, b) for p in range(3) for b in range(8)], [250] * 24, {}, 0, 0))
@example(StaticCase([(p, b) for p in range(3) for b in range(8)], [v for v in range(8) for _ in range(3)],
                    {(p, b): 250 - 8 * b - p for p in range(3) for b in range(8)}, 1, None))
@example(StaticCase([(1, b) for b in range(8)], [0, 1, 0, 1, 250, 249, 250, 249], {}, 0, None))
@example(StaticCase([(0, 7), (1, 0), (2, 3)], [123, 123, 123], {(0, 7): 124, (2, 3): 122}, 0, 1))
def test_static_poses_every_pulse_exact(case):
    text = static_text(case)
    built = build_text(text)
    report = built.verify()
    assert_exact(report, text)
    assert report.pulses == sum(sum(n is not None for n in fr.n)
                                for fr in itertools.islice(expand(built.plan), built.plan.total_frames + 3))
    assert report.period_min == report.period_max == built.plan.period_us


# ============================================================ 2. random motion programs

SPEED_CLASSES = [
    # (servo option, t_DAV in us, widest range of N its poses use)
    ("", DEFAULT_T_DAV_US, 14),
    ("speed 0.05s/60deg", t_dav_from_speed(Fraction(50_000), Fraction(60)), 60),
    ("speed 0.01s/60deg", t_dav_from_speed(Fraction(10_000), Fraction(60)), 250),
]


@dataclass
class Servo:
    pin: tuple[int, int]
    cls: int
    lo: int
    span: int

    @property
    def name(self) -> str:
        return name(self.pin)


@dataclass
class Prog:
    servos: list[Servo]
    poses: dict[str, dict[str, int]]
    sequences: list[tuple[str, list]] = field(default_factory=list)
    main: list = field(default_factory=list)
    loop: list | None = None
    frame_extra: int = 0


def _stmt_move(draw, poses: list[str]):
    dur = draw(st.one_of(st.none(), st.integers(0, 3)))
    ease = None if dur is None else draw(st.sampled_from([None, None, "in", "out", "in-out", "linear"]))
    return ("move", draw(st.sampled_from(poses)), dur, ease)


def _stmt(draw, poses: list[str], seqs: list[str], depth: int):
    kinds = ["move", "move", "move", "hold"] + (["repeat"] if depth < 3 else []) + (["play"] if seqs else [])
    kind = draw(st.sampled_from(kinds))
    if kind == "move":
        return _stmt_move(draw, poses)
    if kind == "hold":
        return ("hold", draw(st.integers(0, 2)))
    if kind == "repeat":
        return ("repeat", draw(st.integers(1, 3)), _body(draw, poses, seqs, depth + 1, 1, 3))
    return ("play", draw(st.sampled_from(seqs)))


def _body(draw, poses, seqs, depth, lo, hi):
    return [_stmt(draw, poses, seqs, depth) for _ in range(draw(st.integers(lo, hi)))]


@st.composite
def programs(draw) -> Prog:
    pins = draw(pins_strategy(max_size=6))
    servos = []
    for pin in pins:
        cls = draw(st.integers(0, len(SPEED_CLASSES) - 1))
        span = draw(st.integers(1, SPEED_CLASSES[cls][2]))
        lo = draw(st.integers(0, 250 - span))
        servos.append(Servo(pin, cls, lo, span))
    poses: dict[str, dict[str, int]] = {}
    for i in range(draw(st.integers(2, 4))):
        named = draw(st.lists(st.sampled_from(servos), min_size=1, max_size=len(servos), unique_by=lambda s: s.pin))
        poses[f"p{i}"] = {s.name: draw(st.one_of(st.sampled_from([s.lo, s.lo + s.span]),
                                                  st.integers(s.lo, s.lo + s.span)))
                          for s in sorted(named, key=lambda s: s.pin)}
    names = list(poses)
    prog = Prog(servos, poses, frame_extra=draw(st.sampled_from([0, 0, 7, 1500])))
    for j in range(draw(st.integers(0, 2))):
        prog.sequences.append((f"q{j}", _body(draw, names, [n for n, _ in prog.sequences], 1, 1, 3)))
    seqs = [n for n, _ in prog.sequences]
    prog.main = _body(draw, names, seqs, 0, 1, 5) + [_stmt_move(draw, names)]     # some pulse for sure
    if draw(st.sampled_from([True, True, False])):
        # A move without duration entered from two different poses: its F is found at run time.
        a, b, c = (draw(st.sampled_from(names)) for _ in range(3))
        prog.sequences.append(("again", [("move", c, None, None)] + _body(draw, names, seqs, 1, 0, 2)))
        prog.main = [("move", a, None, None), ("play", "again"), ("move", b, None, None), ("play", "again")] \
            + prog.main
    if draw(st.booleans()):
        prog.loop = _body(draw, names, seqs, 1, 0, 2) + [("move", draw(st.sampled_from(names)), None, None)]
    return prog


def _min_frames(prog: Prog, pose_name: str, period: int) -> int:
    """Frames that make a move to the pose feasible from any pose: the servos' widest |delta| at top speed."""
    by_name = {s.name: s for s in prog.servos}
    need = max(by_name[n].span * SPEED_CLASSES[by_name[n].cls][1] for n in prog.poses[pose_name])
    return max(1, math.ceil(need / period))


def render(prog: Prog, period: int) -> str:
    out = [f"frame {period}us\n"]
    for s in prog.servos:
        out.append(servo_decls([s.pin], options=SPEED_CLASSES[s.cls][0]))
    for pname, values in prog.poses.items():
        out.append(pose(pname, values))

    def body(stmts, indent):
        lines = []
        pad = "  " * indent
        for st_ in stmts:
            if st_[0] == "move":
                _, pname, dur, ease = st_
                if dur is None:
                    lines.append(f"{pad}move {pname}")
                else:
                    frames = _min_frames(prog, pname, period) + dur
                    lines.append(f"{pad}move {pname} in {frames * period}us" + (f" ease {ease}" if ease else ""))
            elif st_[0] == "hold":
                lines.append(f"{pad}hold {st_[1] * period}us")
            elif st_[0] == "repeat":
                lines.append(f"{pad}repeat {st_[1]} {{")
                lines += body(st_[2], indent + 1)
                lines.append(f"{pad}}}")
            else:
                lines.append(f"{pad}play {st_[1]}")
        return lines

    for qname, stmts in prog.sequences:
        out.append(f"sequence {qname} {{\n" + "\n".join(body(stmts, 1)) + "\n}\n")
    main = body(prog.main, 1)
    if prog.loop is not None:
        main += ["  loop {"] + body(prog.loop, 2) + ["  }"]
    out.append("main {\n" + "\n".join(main) + "\n}\n")
    return "".join(out)


def program_text(prog: Prog) -> str:
    """Render with a frame period at or above the firmware's minimum for this program."""
    period = 6000
    for _ in range(4):
        fe, diags = front_end_text(render(prog, period))
        assert fe.plan is not None, diags
        want = fe.plan.min_period_us + prog.frame_extra
        if period >= fe.plan.min_period_us and (period == want or prog.frame_extra == 1500):
            break
        period = want
    return render(prog, period)


def check_program(text: str, frames_cap: int = 400):
    built = build_text(text)
    plan = built.plan
    frames = min(frames_cap, 150 if plan.total_frames is None else plan.total_frames + 3)
    report = built.verify(frames)
    assert_exact(report, text)
    # The TL2 parity trick makes the poll jitter-free: every rise-to-rise period is exactly P.
    assert report.period_min == report.period_max == plan.period_us, report.summary()
    return built, report


S = [Servo((1, 0), 0, 100, 14), Servo((1, 5), 2, 0, 250), Servo((0, 3), 1, 120, 60), Servo((2, 7), 2, 10, 240)]


@settings(max_examples=40, **SETTINGS)
@given(programs())
@example(Prog(S, {"a": {"s1_0": 100, "s1_5": 0}, "b": {"s1_0": 114, "s1_5": 250, "s0_3": 180},
                  "c": {"s1_0": 107, "s1_5": 125, "s0_3": 120, "s2_7": 250}},
              sequences=[("q0", [("move", "c", None, None), ("hold", 0)])],
              main=[("move", "a", None, None), ("play", "q0"), ("move", "b", 2, "in-out"), ("play", "q0"),
                    ("repeat", 2, [("repeat", 2, [("move", "a", 1, "in"), ("play", "q0")]), ("hold", 1)])]))
@example(Prog(S[1:], {"a": {"s1_5": 0}, "b": {"s1_5": 250, "s0_3": 120}, "c": {"s0_3": 180, "s2_7": 10}},
              sequences=[("q0", [("move", "b", None, None), ("hold", 0), ("move", "c", 0, "out")]),
                         ("q1", [("repeat", 2, [("play", "q0"), ("hold", 1)]), ("move", "a", None, None)])],
              main=[("hold", 2), ("move", "a", 1, None), ("play", "q1")],
              loop=[("play", "q0"), ("move", "a", None, None)], frame_extra=7))
def test_motion_programs_match_golden_frames(prog):
    check_program(program_text(prog))


def test_runtime_frames_path_is_exercised():
    """A sequence with a move without duration played from poses at different distances:
    its F is found at run time (frames-needed tables, each speed class's largest |delta|) and still matches the plan."""
    text = """\
servo a = P1.0
servo b = P1.1 speed 0.1s/60deg
servo c = P2.6 speed 0.4s/60deg
pose far  { a: 0, b: 250, c: 0 }
pose near { a: 110, b: 130, c: 120 }
pose mid  { a: 125, b: 125, c: 125 }
pose only_b { b: 0 }
sequence go_mid { move mid }
main {
  move far
  play go_mid
  move near in 2s
  play go_mid
  repeat 2 {
    move only_b
    play go_mid
  }
}
"""
    built = build_text(text)
    assert "DMAX0" in built.firmware.unit.text and "dm_rf" in built.firmware.unit.text
    assert built.firmware.unit.fneed_pages
    frames_of_mid = sorted({inst.frames for inst in built.plan.moves if inst.step.pose == "mid"})
    assert len(frames_of_mid) >= 2 and all(f > 1 for f in frames_of_mid)
    assert_exact(built.verify(), text)


def test_runtime_frames_above_255():
    """Run-time F above 255 frames takes the DDA's wide path (Q = 0, REM = |delta|)."""
    text = """\
servo a = P0.4 speed 1.2s/60deg
servo b = P0.5
pose lo { a: 0, b: 0 }
pose hi { a: 250, b: 10 }
pose mid { a: 60, b: 5 }
sequence s { move hi }
main {
  move lo
  play s
  move mid
  play s
}
"""
    built = build_text(text)
    assert max(inst.frames for inst in built.plan.moves) > 255
    assert_exact(built.verify(), text)


def test_eased_moves_exact_on_last_frame_and_within_one_n():
    text = """\
frame 6ms
servo a = P1.0 speed 0.001s/60deg
servo b = P1.1 speed 0.001s/60deg
servo c = P1.2 speed 0.001s/60deg
pose lo { a: 0, b: 250, c: 17 }
pose hi { a: 250, b: 0, c: 18 }
main {
  move lo
  move hi in 300ms ease in
  move lo in 600ms ease out
  move hi in 1s ease in-out
  move lo in 6ms ease in-out
  move hi in 12ms ease in
}
"""
    built = build_text(text)
    assert_exact(built.verify(), text)


@pytest.mark.parametrize("frames", [255, 256, 997, 32767, 32768, 40000, 65535])
def test_linear_dda_for_long_moves(frames):
    """Long linear moves: every frame's N follows floor(|delta| k / F + 1/2), for F up to 65535
    (the DDA's 16-bit error term must not overflow; the first frames show it)."""
    text = f"""\
frame 5300us
servo up = P1.0
servo down = P1.1
servo small = P1.2
servo one = P1.3
pose a {{ up: 0, down: 250, small: 100, one: 200 }}
pose b {{ up: 250, down: 0, small: 107, one: 199 }}
main {{
  move a
  move b in {frames * 5300}us
}}
"""
    built = build_text(text)
    assert built.plan.total_frames == frames + 1
    checked = min(frames + 3, frames // 100 + 20)     # the whole move, or its first three changes of N
    report = built.verify(checked)
    assert_exact(report, text)
    changes = sum(1 for a, b in itertools.pairwise(itertools.islice(expand(built.plan), checked)) if a.n != b.n)
    assert changes >= 3


def test_long_hold_and_repeat_counts_above_255():
    text = """\
servo a = P2.0
pose p { a: 77 }
pose q { a: 78 }
main {
  move p
  hold 1500ms
  repeat 300 { move q; move p }
}
"""
    built = build_text(text)
    assert built.plan.total_frames > 800
    assert_exact(built.verify(), text)


# ============================================================ 3. sorting network, exhaustive on 0-1 inputs

FAST = "speed 0.001s/60deg"
LOW, HIGH = 10, 200


def sort_source(bits: list[int], vectors: list[list[int]], port: int = 1) -> str:
    text = servo_decls([(port, b) for b in bits], options=FAST)
    for k, vec in enumerate(vectors):
        text += pose(f"v{k}", {name((port, b)): v for b, v in zip(bits, vec)})
    return text + "main {\n" + "".join(f"  move v{k} in 6ms\n" for k in range(len(vectors))) + "}\n"


def check_every_frame(text: str, vectors: list[list[int]]):
    """Each vector is one frame, in order: the firmware shows it exactly."""
    text = "frame 6ms\n" + text
    built = build_text(text)
    frames = list(itertools.islice(expand(built.plan), len(vectors)))
    assert [list(fr.n) for fr in frames] == vectors
    report = built.verify(len(vectors) + 2)
    assert_exact(report, text)
    assert report.pulses == len(vectors[0]) * (len(vectors) + 2)


PIN_SETS = {1: [5], 2: [0, 7], 3: [1, 2, 6], 4: [0, 3, 4, 7], 5: [1, 2, 3, 5, 6], 6: [0, 1, 2, 4, 6, 7],
            7: [0, 1, 2, 3, 4, 5, 7], 8: list(range(8))}


@pytest.mark.parametrize("size", range(1, 9))
def test_sorting_all_zero_one_inputs(size):
    """A sorting network is correct iff it sorts every 0-1 vector; each one is a frame here."""
    vectors = [[HIGH if (k >> i) & 1 else LOW for i in range(size)] for k in range(2 ** size)]
    # Start from all-high so the first vector also changes something.
    vectors = [[HIGH] * size] + vectors
    check_every_frame(sort_source(PIN_SETS[size], vectors), vectors)


@pytest.mark.parametrize("size", range(1, 9))
def test_sorting_random_permutations_with_duplicates(size):
    rng = random.Random(1000 + size)
    vectors = []
    for _ in range(40):
        pool = [rng.randint(0, 250) for _ in range(rng.randint(1, size))]
        vec = [rng.choice(pool) for _ in range(size)]
        rng.shuffle(vec)
        vectors.append(vec)
    vectors += [list(range(size)), list(range(250, 250 - size, -1)), [0] * size, [250] * size,
                [250 if i % 2 else 0 for i in range(size)], [i // 2 for i in range(size)]]
    check_every_frame(sort_source(PIN_SETS[size], vectors, port=size % 3), vectors)


@settings(max_examples=20, **SETTINGS)
@given(st.integers(1, 8).flatmap(lambda s: st.tuples(
    st.just(s),
    st.lists(st.lists(st.sampled_from([0, 1, 2, 125, 126, 249, 250]) | st.integers(0, 250), min_size=s, max_size=s),
             min_size=1, max_size=40))))
def test_sorting_hypothesis_vectors(args):
    size, vectors = args
    bits = random.Random(size).sample(range(8), size)
    check_every_frame(sort_source(sorted(bits), vectors, port=2), vectors)


def test_every_n_on_every_port_with_ties_and_neighbours():
    """N = 0..250, one per frame, on all three ports: a line at N, one tied with it, one a DIV above,
    one mirrored (250 - N) and one fixed at 125, so every N meets every kind of neighbour."""
    pins = [(p, b) for p in range(3) for b in (0, 3, 4, 6, 7)]
    roles = {0: "n", 3: "tie", 4: "next", 6: "mirror", 7: "fixed"}

    def values(n: int) -> dict[str, int]:
        by_role = {"n": n, "tie": n, "next": min(250, n + 1), "mirror": 250 - n, "fixed": 125}
        return {name((p, b)): by_role[roles[b]] for p, b in pins}

    text = "frame 10ms\n" + servo_decls(pins, options=FAST) + pose("start", values(0)) + pose("end", values(250))
    text += "main {\n  move start\n  move end in 2500ms\n}\n"
    built = build_text(text)
    golden = list(itertools.islice(expand(built.plan), 251))
    n_index = built.plan.channel_of(name((1, 0))).index
    assert [fr.n[n_index] for fr in golden] == [0] + list(range(1, 251))
    report = built.verify(254)
    assert_exact(report, text)
    assert report.pulses == 254 * len(pins)


def test_many_speed_classes_with_runtime_frames():
    """24 servos in 8 speed classes, moves whose F is found at run time: 16 pages of tables."""
    pins = [(p, b) for p in range(3) for b in range(8)]
    text = "".join(f"servo {name((p, b))} = P{p}.{b} speed {0.1 + 0.01 * ((8 * p + b) % 8):.2f}s/60deg\n"
                   for p, b in pins)
    for k in range(4):
        text += pose(f"a{k}", {name((p, b)): (k * 60 + 7 * b + p) % 251 for p, b in pins})
    text += pose("c", {name(pin): 120 for pin in pins})
    text += "sequence s { move c }\nmain {\n" + "".join(f"  move a{k}\n  play s\n" for k in range(4)) + "}\n"
    built = build_text(text)
    assert len(built.firmware.unit.fneed_pages) == 8
    assert any(inst.step.frames is None for inst in built.plan.moves)
    assert_exact(built.verify(), text)


# ============================================================ 5. reset, untouched pins, late first targets

def test_reset_lines_low_and_other_pins_untouched():
    text = """\
servo a = P0.1
servo b = P1.6
servo c = P1.2
servo idle = P1.4           # declared, never moved
servo late = P2.3
servo never = P2.0          # declared, never moved
pose p { a: 100, b: 0 }
pose q { b: 250, c: 3, late: 42 }
main {
  move p
  hold 30ms
  move q
  hold 50ms
}
"""
    built = build_text(text)
    plan = built.plan
    trace = api.simulate(built.firmware.hex_text, 40 * plan.period_us)
    servo_pins = {(0, 1), (1, 6), (1, 2), (1, 4), (2, 3), (2, 0)}
    for port, bit in sorted(servo_pins):
        low = trace.first_low(port, bit)
        assert low is not None and low <= 20, (port, bit, low)
    for port in range(3):
        for bit in range(8):
            if (port, bit) not in servo_pins:
                assert trace.pin_edges(port, bit) == [], f"P{port}.{bit} is not a servo but changed"
    assert trace.port_writes(3) == [], "P3 has no servos but was written"
    # Declared servos that never move: driven low once at reset, never pulsed.
    for port, bit in [(1, 4), (2, 0)]:
        assert len(trace.pin_edges(port, bit)) == 1
        assert trace.pulses(port, bit) == []
    # A servo without a target gets no pulse before the frame of its first move.
    first = {port_bit: trace.pulses(*port_bit) for port_bit in [(0, 1), (1, 6), (2, 3)]}
    t1 = first[(0, 1)][0][0]
    late_frame = next(j for j, fr in enumerate(expand(plan)) if fr.n[plan.channel_of("late").index] is not None)
    p2_offset = built.firmware.unit.rise_offsets[plan.ports.index(2)]
    assert late_frame > 3
    assert first[(2, 3)][0][0] == t1 + late_frame * plan.period_us + p2_offset
    assert all(w == 500 + 8 * 42 for _, w in first[(2, 3)])
    assert_exact(built.verify(), text)


def test_untouched_port_never_written():
    text = "servo a = P2.2\npose p { a: 9 }\nmain { move p }\n"
    built = build_text(text)
    trace = api.simulate(built.firmware.hex_text, 5 * built.plan.period_us)
    assert trace.port_writes(0) == [] and trace.port_writes(1) == [] and trace.port_writes(3) == []
    assert {w.value | 0x04 for w in trace.port_writes(2)} == {0xFF}
    assert_exact(built.verify(10))


# ============================================================ 8. resources: stack depth

def nested_source(depth: int, with_repeats: bool = False) -> str:
    """A chain of `depth` sequences, each playing the one below (inside a repeat when asked), played
    twice: the innermost move's F differs between the plays, so need_frames runs at the deepest point."""
    # servos on three ports: the least stack (a's motion state, P0's, lies just above it)
    text = ("servo a = P0.0 speed 0.005s/60deg\nservo b = P1.7\nservo c = P2.7\n"
            "pose p { a: 10, b: 50, c: 50 }\npose q { a: 200 }\n")
    text += "sequence q0 {\n  move p\n  move q\n}\n"
    for i in range(1, depth):
        inner = f"repeat 2 {{ play q{i - 1} }}" if with_repeats else f"play q{i - 1}"
        text += f"sequence q{i} {{\n  {inner}\n}}\n"
    return text + f"main {{\n  play q{depth - 1}\n  play q{depth - 1}\n}}\n"


def deepest_that_fits(with_repeats: bool) -> int:
    depth = 1
    while True:
        fe, _ = front_end_text(nested_source(depth + 1, with_repeats))
        if api.generate(fe.plan, fe.source, Reporter(fe.source)) is None:
            return depth
        depth += 1


@pytest.mark.parametrize("with_repeats", [False, True])
def test_deepest_nesting_that_fits_runs_without_stack_overflow(with_repeats):
    """Nest as deep as the stack allows: it compiles and runs (ucsim stops on a stack overflow)."""
    depth = deepest_that_fits(with_repeats)
    assert depth >= (5 if with_repeats else 10)
    text = nested_source(depth, with_repeats)
    built = build_text(text)
    assert built.firmware.unit.stack_bytes <= costs.STACK_BYTES
    assert any(inst.step.frames is None for inst in built.plan.moves), "the run-time F path is not used"
    assert_exact(built.verify(), text)


# ============================================================ frame budget

def worst_case_source(period: int | None) -> str:
    pins = [(p, b) for p in range(3) for b in range(8)]
    speeds = ["0.2", "0.25", "0.3"]
    text = f"frame {period}us\n" if period else ""
    text += "".join(f"servo {name((p, b))} = P{p}.{b} speed {speeds[(8 * p + b) % 3]}s/60deg\n" for p, b in pins)
    text += pose("a", {name(pin): 0 for pin in pins}) + pose("b", {name(pin): 250 for pin in pins})
    text += pose("c", {name((p, b)): 3 + b for p, b in pins})
    text += "sequence q0 {\n  move b\n  move a\n}\n"
    text += "sequence q1 {\n  repeat 2 { play q0 }\n}\n"
    return text + "main {\n  move c\n  play q1\n  move c\n  repeat 2 { play q1 }\n}\n"


def test_worst_case_frames_at_the_minimum_period():
    """24 servos all moving, F found at run time, nested repeats and plays ending together,
    at the shortest period the plan allows: every rise stays in its slot, every pulse exact."""
    fe, _ = front_end_text(worst_case_source(None))
    period = fe.plan.min_period_us
    text = worst_case_source(period)
    built = build_text(text)
    assert built.plan.period_us == built.plan.min_period_us == period
    assert any(inst.step.frames is None for inst in built.plan.moves)
    report = built.verify()
    assert_exact(report, text)
    assert report.period_min == report.period_max == period


HEXAPOD_11 = "target stc89c52rc clock 11.0592MHz\n"


def _hexapod_at(head: str) -> str:
    text = (Path(__file__).resolve().parent.parent / "examples" / "hexapod.servo").read_text()
    return head + "\n".join(line for line in text.splitlines() if not line.startswith(("target ", "frame ")))


def test_a_linear_move_of_known_f_is_set_up_and_first_stepped_in_one_call():
    """`Plan.first_step`: each pin of a linear move whose F is known is set up, gets its DDA terms
    and is stepped for the move's first frame in one call (setup_step). The work between two
    frames is shorter by at least 12 cycles a pin than in two passes, so where that work bounds the
    period (the hexapod at 11.0592 MHz) the reported minimum is shorter, and the firmware verifies
    exactly there, through the first frames of its linear moves, with 1 us less refused."""
    fe, diags = front_end_text(_hexapod_at(HEXAPOD_11))
    plan = fe.plan
    assert plan is not None and plan.first_step and not plan.compact, diags
    two = api.choose_period(plan.program, dataclasses.replace(plan, first_step=False), decide=False)
    one_unit, two_unit = api.codegen.generate(plan), api.codegen.generate(two)
    assert "LCALL   setup_step" in one_unit.text and "setup_step" not in two_unit.text
    pins = len(plan.channels)
    assert one_unit.budget.work <= two_unit.budget.work - 12 * pins
    assert plan.min_period_us < two.min_period_us
    built = build_text(_hexapod_at(HEXAPOD_11 + f"frame {plan.min_period_us}us\n"))
    assert built.plan.first_step and built.plan.min_period_us == built.plan.period_us
    assert "LCALL   setup_step" in built.firmware.unit.text
    linear = [m for m in built.plan.moves if m.step.ease == "linear" and m.step.frames is not None]
    assert linear
    assert_exact(built.verify(400), "hexapod at its minimum")
    less, _ = front_end_text(_hexapod_at(HEXAPOD_11 + f"frame {plan.min_period_us - 1}us\n"))
    assert less.plan is None or less.plan.min_period_us > plan.min_period_us - 1


def test_where_every_move_is_eased_those_take_the_one_call_and_no_linear_path_is_charged():
    """A program whose moves are all eased (F known): their pins are set up and stepped for the
    first frame in one call, no linear DDA code is laid out (so no linear path is charged), and the
    work between frames is shorter than in two passes by at least 9 cycles a pin. It verifies
    exactly at its reported minimum through both moves' first frames (1 us less refused)."""
    head = "target stc89c52rc clock 11.0592MHz\n"
    names = [f"s{i}" for i in range(16)]
    body = ("".join(f"servo {n} = P{1 + i // 8}.{i % 8}\n" for i, n in enumerate(names))
            + "pose lo { " + ", ".join(f"{n}: {10 + 7 * i}" for i, n in enumerate(names)) + " }\n"
            + "pose hi { " + ", ".join(f"{n}: {240 - 9 * i}" for i, n in enumerate(names)) + " }\n"
            + "main {\n  loop {\n    move hi in 1600ms ease in-out\n    move lo in 1600ms ease in\n  }\n}\n")
    fe, diags = front_end_text(head + body)
    plan = fe.plan
    assert plan is not None and not [d.code for d in diags if d.severity not in ("note", "warning")], diags
    assert all(m.step.ease != "linear" for m in plan.moves)      # (no `home`: its set-up is a linear move)
    two = api.choose_period(plan.program, dataclasses.replace(plan, first_step=False), decide=False)
    one_unit, two_unit = api.codegen.generate(plan), api.codegen.generate(two)
    assert "SJMP    se_a" in one_unit.text and "setup_step" not in two_unit.text
    assert "dda_step" not in one_unit.text and "dda_step" not in two_unit.text
    assert one_unit.budget.work <= two_unit.budget.work - 9 * len(names)
    built = build_text(head + f"frame {plan.min_period_us}us\n" + body)
    assert built.plan.min_period_us == built.plan.period_us == plan.min_period_us
    assert_exact(built.verify(sum(m.frames for m in built.plan.moves) + 10), "eased moves at the minimum")
    less, _ = front_end_text(head + f"frame {plan.min_period_us - 1}us\n" + body)
    assert less.plan is None or less.plan.min_period_us > plan.min_period_us - 1
