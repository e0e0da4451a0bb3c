"""servoc.plan: frame counts and golden frames, against values computed by hand from the spec.

Every expected number here comes from the spec's formulas, worked out in the
comments; the property tests at the end recompute them with an independent
reference that shares no code with the planner.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servoc import codegen, api, costs
from servoc.diagnostics import render_short
from servoc.plan import expand, verify_frames
from servoc.steps import HoldStep, MoveStep, Plan, steps
from servoc.source import SourceFile


def plan_of(text: str, errors_ok: bool = False) -> Plan:
    src = SourceFile("t.servo", text)
    rep = api.Reporter(src)
    fe = api.front_end(src, rep)
    errs = [render_short(d, src) for d in rep.diagnostics if d.is_error]
    assert fe.plan is not None, errs
    if not errors_ok:
        assert not errs, errs
    return fe.plan


def track(plan: Plan, servo: str, count: int) -> list:
    """The language's N of one servo in the first `count` frames (the firmware's N is within one)."""
    ch = plan.channel_of(servo).index
    frames = list(itertools.islice(expand(plan), count))
    for f in frames:
        assert f.n[ch] is None if f.curve[ch] is None else abs(f.n[ch] - f.curve[ch]) <= 1
    return [f.curve[ch] for f in frames]


def moves(plan: Plan) -> list[MoveStep]:
    return [s for s in steps(plan) if isinstance(s, MoveStep)]


def holds(plan: Plan) -> list[HoldStep]:
    return [s for s in steps(plan) if isinstance(s, HoldStep)]


# A servo so fast (1 ms per 74 deg = 10 us per DAV) that no move below is infeasible.
FAST = "speed 1ms/74deg"


# ---- F of `move ... in D` and of `hold D` -------------------------------------------

def test_move_frames_for_durations():
    # P = 10 ms. F = max(1, floor(D/P + 1/2)).
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose lo {{ a: 100 }}
pose hi {{ a: 101 }}
main {{
  move lo
  move hi in 40ms
  move lo in 44ms
  move hi in 45ms
  move lo in 4ms
  move hi in 0ms
  move lo in 15ms
  move hi in 14.999ms
  move lo in 1s
}}
""")
    assert plan.period_us == 10_000
    # 40/10 = 4; 4.4 -> 4; 4.5 -> 5 (half up); 0.4 -> 0 -> 1; 0 -> 1; 1.5 -> 2; 1.4999 -> 1; 100
    assert [m.frames for m in moves(plan)] == [1, 4, 4, 5, 1, 1, 2, 1, 100]
    assert plan.total_frames == 1 + 4 + 4 + 5 + 1 + 1 + 2 + 1 + 100


def test_hold_frames():
    plan = plan_of(f"""frame 10ms
servo a = P1.0
pose p {{ a: 100 }}
main {{
  move p
  hold 25ms
  hold 24ms
  hold 4ms
  hold 5ms
  hold 1s
}}
""")
    # floor(D/P + 1/2): 2.5 -> 3; 2.4 -> 2; 0.4 -> 0; 0.5 -> 1; 100
    assert [h.frames for h in holds(plan)] == [3, 2, 0, 1, 100]
    assert plan.total_frames == 1 + 3 + 2 + 0 + 1 + 100
    assert track(plan, "a", 110) == [100] * 110


# ---- linear paths ---------------------------------------------------------------------

def test_linear_path_0_to_10_over_4_frames():
    plan = plan_of("""frame 10ms
servo a = P1.0
pose zero { a: 0 }
pose ten  { a: 10 }
main {
  move zero
  move ten in 40ms
  move zero in 40ms
}
""")
    # k = 1..4: floor(10 k / 4 + 1/2) = 3, 5, 8, 10; back down: 10 - 3, 10 - 5, 10 - 8, 0
    assert track(plan, "a", 9) == [0, 3, 5, 8, 10, 7, 5, 2, 0]
    assert plan.total_frames == 9


def test_linear_rounds_away_from_the_start():
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose zero {{ a: 0 }}
pose two  {{ a: 2 }}
main {{
  move zero
  move two in 40ms
  move zero in 40ms
}}
""")
    # up: floor(2k/4 + 1/2) = 1, 1, 2, 2; down: 2 - (1, 1, 2, 2) = 1, 1, 0, 0
    assert track(plan, "a", 9) == [0, 1, 1, 2, 2, 1, 1, 0, 0]


def test_linear_with_more_frames_than_steps_and_one_frame():
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose p {{ a: 50 }}
pose q {{ a: 53 }}
main {{
  move p
  move q in 60ms
  move p in 10ms
}}
""")
    # 3 DAV over 6 frames: floor(3k/6 + 1/2) = 1, 1, 2, 2, 3, 3; then 1 frame straight back
    assert track(plan, "a", 8) == [50, 51, 51, 52, 52, 53, 53, 50]


# ---- eased paths ----------------------------------------------------------------------

EASED = f"""frame 10ms
servo a = P1.0 {FAST}
pose zero {{ a: 0 }}
pose full {{ a: 100 }}
main {{
  move zero
  move full in 40ms ease EASE
}}
"""


def test_ease_in():
    plan = plan_of(EASED.replace("EASE", "in"))
    # 100 (k/4)^2 = 6.25, 25, 56.25, 100 -> 6, 25, 56, 100
    assert track(plan, "a", 5) == [0, 6, 25, 56, 100]


def test_ease_out():
    plan = plan_of(EASED.replace("EASE", "out"))
    # 100 (1 - (1 - k/4)^2) = 43.75, 75, 93.75, 100 -> 44, 75, 94, 100
    assert track(plan, "a", 5) == [0, 44, 75, 94, 100]


def test_ease_in_out():
    plan = plan_of(EASED.replace("EASE", "in-out"))
    # 100 (1 - cos(pi k/4)) / 2 = 14.64, 50, 85.36, 100 -> 15, 50, 85, 100
    assert track(plan, "a", 5) == [0, 15, 50, 85, 100]
    frames = list(itertools.islice(expand(plan), 5))
    # the firmware reads round(256 e(k/F)) from its table: 100 x 37 / 256 = 14.45 -> 14, 128 -> 50,
    # 219 -> 85.5 -> 86; intermediate frames may be one off the curve, frame F may not
    assert [f.n[0] for f in frames] == [0, 14, 50, 86, 100]


def test_ease_in_out_at_thirds_is_exact():
    plan = plan_of(EASED.replace("in 40ms", "in 30ms").replace("EASE", "in-out"))
    # cos(pi/3) = 1/2, cos(2 pi/3) = -1/2: e = 1/4, 3/4 exactly -> 25, 75, 100
    assert track(plan, "a", 4) == [0, 25, 75, 100]


def test_eased_rounding_is_half_up():
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose zero {{ a: 0 }}
pose two  {{ a: 2 }}
pose one  {{ a: 1 }}
main {{
  move zero
  move two in 20ms ease in
  move zero in 20ms ease in
  move one in 20ms ease in-out
}}
""")
    # up: 0 + 2 (1/2)^2 = 0.5 -> 1, then 2
    # down: 2 - 2 (1/2)^2 = 1.5 -> 2 (half up, not away from the start), then 0
    # in-out at u = 1/2 is exactly 1/2: 0 + 1/2 -> 1, then 1
    assert track(plan, "a", 7) == [0, 1, 2, 2, 0, 1, 1]


# ---- moves without duration -------------------------------------------------------

TWO_SPEEDS = """frame 10ms
servo a = P1.0
servo b = P1.1 speed 0.3s/60deg
pose start { a: 0, b: 0 }
pose far   { a: 100, b: 100 }
pose mixed { a: 120, b: 50 }
pose only_b { b: 150 }
main {
  move start
  move far
  move start
  move mixed
  move mixed
  move only_b
}
"""


def test_move_without_duration_waits_for_the_slowest_servo():
    plan = plan_of(TWO_SPEEDS)
    # t_DAV: a = 7400/3 us (default), b = 300000 x 0.74 / 60 = 3700 us.
    assert plan.class_t_dav_us[plan.channel_of("b").speed_class] == 3700
    # start: nothing had a target, F = max(1, 0) = 1
    # far:   a 100 x 2466.67 / 10000 = 24.67 -> 25; b 100 x 3700 / 10000 = 37 exactly -> 37
    # start: the same way back: 37
    # mixed: a 120 -> 29.6 -> 30; b 50 -> 18.5 -> 19: 30
    # mixed again: nothing moves, F = max(1, 0) = 1
    # only_b: b 50 -> 150: 100 DAV -> 37; a keeps its target
    assert [m.frames for m in moves(plan)] == [1, 37, 37, 30, 1, 37]
    assert plan.total_frames == 1 + 37 + 37 + 30 + 1 + 37


def test_move_without_duration_servos_arrive_together():
    plan = plan_of(TWO_SPEEDS)
    a = track(plan, "a", 1 + 37)
    b = track(plan, "b", 1 + 37)
    assert a[37] == 100 and b[37] == 100
    # one frame earlier both are still on their way: floor(100 x 36/37 + 1/2) = floor(97.80) = 97
    assert a[36] == 97 and b[36] == 97
    # a is slower than it could be: 100 DAV in 37 frames, linear
    assert a[1:4] == [3, 5, 8]  # floor(100k/37 + 1/2) for k = 1, 2, 3


def test_move_without_duration_in_two_contexts_is_left_to_the_firmware():
    plan = plan_of("""frame 10ms
servo a = P1.0
pose p0 { a: 0 }
pose p1 { a: 100 }
pose p2 { a: 200 }
sequence go {
  move p2
}
main {
  move p0
  play go
  move p1
  play go
}
""")
    go = plan.sequence("go").body[0]
    assert isinstance(go, MoveStep) and go.frames is None
    # from 0: 200 x 2466.67 / 10000 = 49.3 -> 50; from 100: 24.67 -> 25
    assert sorted(inst.frames for inst in plan.moves if inst.step == go) == [25, 50]
    # main's own `move p1` from 200: 25 frames, the same in its only context, so fixed
    assert moves(plan)[1].frames == 25
    assert plan.total_frames == 1 + 50 + 25 + 25
    a = track(plan, "a", 102)
    assert a[50] == 200 and a[49] != 200 and a[75] == 100 and a[100] == 200 and a[101] == 200


def test_move_without_duration_in_one_context_gets_a_fixed_f():
    plan = plan_of(TWO_SPEEDS)
    assert all(m.frames is not None for m in moves(plan))


# ---- first target, end of main, totals ---------------------------------------------

def test_first_target_is_set_at_once_and_the_last_frame_repeats():
    plan = plan_of("""frame 10ms
servo a = P1.0
servo b = P1.1
pose pa { a: 50 }
pose pb { a: 60, b: 200 }
main {
  hold 20ms
  move pa in 30ms
  move pb in 40ms
}
""")
    frames = [f.n for f in itertools.islice(expand(plan), 20)]
    ia, ib = plan.channel_of("a").index, plan.channel_of("b").index
    a = [f[ia] for f in frames]
    b = [f[ib] for f in frames]
    # 2 frames without targets (no pulses), `a` jumps to 50 at once and stays for F = 3,
    # then 50 -> 60 over 4 frames while `b` is set to 200 at once.
    assert a[:9] == [None, None, 50, 50, 50, 53, 55, 58, 60]
    assert b[:9] == [None, None, None, None, None, 200, 200, 200, 200]
    assert plan.total_frames == 9
    # after main: the last frame forever
    assert a[9:] == [60] * 11 and b[9:] == [200] * 11


def test_total_frames_with_repeat_and_play():
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose p0 {{ a: 0 }}
pose p1 {{ a: 100 }}
sequence wave {{
  move p1 in 30ms
  hold 20ms
  move p0 in 50ms
}}
main {{
  move p0
  repeat 3 {{ play wave }}
  hold 15ms
  repeat 2 {{
    move p1 in 10ms
    repeat 2 {{ hold 10ms }}
  }}
}}
""")
    # 1 + 3 x (3 + 2 + 5) + 2 + 2 x (1 + 2 x 1) = 1 + 30 + 2 + 6
    assert plan.total_frames == 39
    a = track(plan, "a", 45)
    wave = [33, 67, 100, 100, 100, 80, 60, 40, 20, 0]   # floor(100k/3 + 1/2); 100 - 20k
    assert a[:31] == [0] + wave * 3
    assert a[31:33] == [0, 0]
    assert a[33:39] == [100] * 6
    assert a[39:] == [100] * 6


def test_total_frames_when_later_passes_of_a_repeat_differ():
    plan = plan_of("""frame 10ms
servo a = P1.0
pose p0 { a: 0 }
pose p1 { a: 100 }
pose p2 { a: 200 }
main {
  move p0
  repeat 3 {
    move p2
    move p1
  }
}
""")
    # pass 1: p2 from 0 is 200 x 2466.67 / 10000 = 49.3 -> 50 frames, p1 from 200: 25;
    # passes 2 and 3: p2 from 100: 25, p1: 25. 1 + 75 + 2 x 50 = 176
    assert plan.total_frames == 176
    a = track(plan, "a", 177)
    assert a[50] == 200 and a[75] == 100 and a[100] == 200 and a[125] == 100 and a[175] == 100


def test_loop_has_no_total():
    plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose p0 {{ a: 0 }}
pose p1 {{ a: 90 }}
main {{
  move p0
  loop {{
    move p1 in 30ms
    move p0 in 30ms
  }}
}}
""")
    assert plan.total_frames is None
    a = track(plan, "a", 1 + 6 * 3)
    assert a == [0] + [30, 60, 90, 60, 30, 0] * 3


def test_loop_inside_repeat_or_sequence_has_no_total():
    for main in ("repeat 2 { move p0\n loop { move p1 in 30ms\n move p0 in 30ms } }",
                 "play forever"):
        plan = plan_of(f"""frame 10ms
servo a = P1.0 {FAST}
pose p0 {{ a: 0 }}
pose p1 {{ a: 90 }}
sequence forever {{
  loop {{ move p1 in 30ms; move p0 in 30ms }}
}}
main {{
  {main}
}}
""", errors_ok=True)
        assert plan.total_frames is None, main


def test_reverse_and_trim_reach_the_frames():
    plan = plan_of("""frame 10ms
servo a = P1.0 reverse trim 3
servo b = P1.1 trim -2 limit 10..200
pose p { a: 100, b: 10 }
main {
  move p
}
""")
    # a: 250 - 100 + 3 = 153; b: 10 - 2 = 8
    assert [f.n for f in itertools.islice(expand(plan), 2)] == [(153, 8), (153, 8)]


# ---- the frame period ---------------------------------------------------------------------

def _servos(pins):
    return "".join(f"servo s{p}{b} = P{p}.{b}\n" for p, b in pins)


def test_default_period_is_the_firmware_minimum_never_below_5_3_ms():
    for pins in ([(1, 0)], [(0, 0), (1, 0)], [(0, 0), (1, 0), (2, 0)], [(p, b) for p in range(3) for b in range(8)]):
        text = _servos(pins) + "pose p { " + ", ".join(f"s{p}{b}: 100" for p, b in pins) + " }\n"
        text += "main {\n  move p in 100ms\n}\n"
        plan = plan_of(text, errors_ok=True)
        assert plan.period_is_default
        ports = len({p for p, _ in pins})
        assert plan.ports == tuple(sorted({p for p, _ in pins}))
        assert plan.period_us == max(5300, plan.min_period_us), pins
        assert plan.min_period_us == codegen.generate(plan).min_period_us


def test_explicit_frame_is_the_period():
    plan = plan_of("frame 7321us\nservo a = P1.0\npose p { a: 1 }\nmain { move p }\n")
    assert plan.period_us == 7321 and not plan.period_is_default


def _check_consistent(plan: Plan) -> None:
    """Every F, hold and speed table follows the spec's formulas at the plan's own P."""
    P = plan.period_us
    for m in moves(plan):
        if m.duration_us is not None:
            assert m.frames == max(1, math.floor(m.duration_us / P + Fraction(1, 2))), (m, P)
    for h in holds(plan):
        assert h.frames == math.floor(h.duration_us / P + Fraction(1, 2))
    for cls, t in enumerate(plan.class_t_dav_us):
        assert list(plan.speed_tables[cls]) == [math.ceil(d * t / P) for d in range(251)]


def test_frames_follow_the_period_the_plan_reports():
    # Several ports push the default P above 5.3 ms; every F must use that P.
    base = _servos([(0, 0), (1, 0), (2, 0), (2, 1)])
    poses = ("pose p0 { s00: 10, s10: 10, s20: 10, s21: 10 }\n"
             "pose p1 { s00: 200, s10: 200, s20: 200, s21: 200 }\n"
             "pose p2 { s00: 100, s10: 100, s20: 100, s21: 100 }\n")
    fixed = "main {\n  move p0\n  move p1 in 1s\n  hold 333ms\n  move p0\n}\n"
    runtime = ("sequence go {\n  move p1\n}\n"
               "main {\n  move p0\n  play go\n  move p2 in 1s\n  play go\n  hold 333ms\n}\n")
    for body in (fixed, runtime):
        plan = plan_of(base + poses + body, errors_ok=True)
        _check_consistent(plan)
        assert plan.period_us >= plan.min_period_us
        # the golden frames of each timed move last F frames at this P
        ch = plan.channel_of("s00").index
        got = [f.n[ch] for f in itertools.islice(expand(plan), plan.total_frames)]
        assert got[-1] == (10 if body is fixed else 200)
        assert any(inst.step.frames is None for inst in plan.moves) == (body is runtime)
    frames_fixed = plan_of(base + poses + fixed, errors_ok=True)
    assert [m.frames for m in moves(frames_fixed)][1] == max(
        1, math.floor(Fraction(1_000_000, frames_fixed.period_us) + Fraction(1, 2)))


# ---- property: expand against an independent reference ----------------------------------

DEFAULT_T = Fraction(74, 100) * Fraction(200_000) / 60


def _ease(kind: str, u: Fraction):
    if kind == "in":
        return u * u
    if kind == "out":
        return 1 - (1 - u) ** 2
    cos = {Fraction(0): 1, Fraction(1, 3): Fraction(1, 2), Fraction(1, 2): 0, Fraction(2, 3): Fraction(-1, 2),
           Fraction(1): -1}
    if u in cos:
        return (1 - Fraction(cos[u])) / 2
    return (1 - math.cos(math.pi * u.numerator / u.denominator)) / 2


def _spec_frame(n0: int, n1: int, k: int, f: int, ease: str) -> int:
    d = n1 - n0
    if ease == "linear":
        sgn = (d > 0) - (d < 0)
        return n0 + sgn * math.floor(Fraction(abs(d) * k, f) + Fraction(1, 2))
    x = n0 + d * _ease(ease, Fraction(k, f))
    return math.floor(x + (Fraction(1, 2) if isinstance(x, Fraction) else 0.5))


@st.composite
def programs(draw):
    """A random program and what the reference needs to know about it."""
    count = draw(st.integers(1, 4))
    pins = draw(st.lists(st.tuples(st.sampled_from([1, 2]), st.integers(0, 7)), min_size=count,
                         max_size=count, unique=True))
    servos = {}
    lines = []
    frame = draw(st.one_of(st.none(), st.integers(6000, 20000)))
    if frame is not None:
        lines.append(f"frame {frame}us")
    for i, (port, bit) in enumerate(pins):
        name = f"s{i}"
        opts = []
        t = DEFAULT_T
        if draw(st.booleans()):
            d_ms, a_deg = draw(st.integers(20, 900)), draw(st.integers(10, 120))
            opts.append(f"speed {d_ms}ms/{a_deg}deg")
            t = Fraction(d_ms * 1000) * Fraction(74, 100) / a_deg
        trim = draw(st.integers(-10, 10)) if draw(st.booleans()) else 0
        if trim:
            opts.append(f"trim {trim}")
        lo, hi = 0, 250
        if draw(st.booleans()):
            lo, hi = sorted((draw(st.integers(0, 250)), draw(st.integers(0, 250))))
            opts.append(f"limit {lo}..{hi}")
        rev = draw(st.booleans())
        if rev:
            opts.append("reverse")
        draw(st.randoms()).shuffle(opts)

        def out(p, rev=rev, trim=trim):
            return (250 - p if rev else p) + trim
        allowed = [p for p in range(lo, hi + 1) if 0 <= out(p) <= 250]
        if not allowed:
            opts = [o for o in opts if not o.startswith(("limit", "trim"))]
            lo, hi, trim = 0, 250, 0
            allowed = list(range(251))

            def out(p, rev=rev):
                return 250 - p if rev else p
        servos[name] = dict(t=t, allowed=allowed, out=out, outs=[out(p) for p in allowed])
        lines.append(f"servo {name} = P{port}.{bit} " + " ".join(opts))
    names = list(servos)
    poses = {}
    for j in range(draw(st.integers(1, 4))):
        chosen = draw(st.lists(st.sampled_from(names), min_size=1, unique=True))
        entries, targets = [], {}
        for s in chosen:
            p = draw(st.sampled_from(servos[s]["allowed"]))
            form = draw(st.sampled_from(["n", "deg", "us", "us_off"]))
            if form == "n":
                text = str(p)
            elif form == "deg":       # p x 0.74 deg is exactly N p
                text = f"{p * 74 // 100}.{p * 74 % 100:02d}deg"
            elif form == "us":
                text = f"{500 + 8 * p}us"
            else:                     # off the grid by -4..3 us: still rounds to N p
                r = draw(st.integers(-4, 3))
                text = f"{500 + 8 * p + r}us" if 500 + 8 * p + r > 0 else str(p)
            entries.append(f"{s}: {text}")
            targets[s] = servos[s]["out"](p)
        poses[f"p{j}"] = targets
        lines.append(f"pose p{j} {{ " + ", ".join(entries) + " }")
    def move():
        pose = draw(st.sampled_from(list(poses)))
        dur = draw(st.one_of(st.none(), st.integers(0, 900)))
        ease = draw(st.sampled_from(["linear", "in", "out", "in-out"])) if dur is not None else "linear"
        return ("move", dur, pose, ease)

    stmts = []
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(["move", "move", "hold", "repeat"]))
        if kind == "hold":
            stmts.append(("hold", draw(st.integers(0, 100)), None, None))
        elif kind == "move":
            stmts.append(move())
        else:
            stmts.append(("repeat", draw(st.integers(1, 3)), [move() for _ in range(draw(st.integers(1, 2)))], None))
    text_lines = []
    for s in stmts:
        if s[0] == "hold":
            text_lines.append(f"  hold {s[1]}ms")
        elif s[0] == "move":
            text_lines.append(_move_text(s))
        else:
            text_lines.append(f"  repeat {s[1]} {{\n  " + "\n  ".join(_move_text(m) for m in s[2]) + "\n  }")
    text = "\n".join(lines) + "\nmain {\n" + "\n".join(text_lines) + "\n}\n"
    return text, dict(servos=servos, poses=poses, stmts=stmts, frame=frame)


def _move_text(s) -> str:
    _, dur, pose, ease = s
    if dur is None:
        return f"  move {pose}"
    return f"  move {pose} in {dur}ms" + ("" if ease == "linear" else f" ease {ease}")


def reference_frames(spec, P: int) -> tuple[list[dict], list[tuple]]:
    """Frames per the spec, and each move's (first frame index, F, ease, state before, targets)."""
    state = {s: None for s in spec["servos"]}
    frames, ends = [], []

    def run(stmts):
        nonlocal state
        for s in stmts:
            if s[0] == "hold":
                for _ in range(math.floor(Fraction(s[1] * 1000, P) + Fraction(1, 2))):
                    frames.append(dict(state))
            elif s[0] == "repeat":
                for _ in range(s[1]):
                    run(s[2])
            else:
                _, dur, pose, ease = s
                targets = spec["poses"][pose]
                if dur is None:
                    need = [abs(n1 - state[sv]) * spec["servos"][sv]["t"] / P
                            for sv, n1 in targets.items() if state[sv] is not None]
                    f = max(1, math.ceil(max(need, default=0)))
                else:
                    f = max(1, math.floor(Fraction(dur * 1000, P) + Fraction(1, 2)))
                start = dict(state)
                ends.append((len(frames), f, ease, start, targets))
                for k in range(1, f + 1):
                    for sv, n1 in targets.items():
                        state[sv] = n1 if start[sv] is None else _spec_frame(start[sv], n1, k, f, ease)
                    frames.append(dict(state))
    run(spec["stmts"])
    return frames, ends


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs())
def test_expand_follows_the_spec(case):
    text, spec = case
    plan = plan_of(text, errors_ok=True)
    P = plan.period_us
    if spec["frame"] is not None:
        assert P == spec["frame"]
    ref, segments = reference_frames(spec, P)
    assert plan.total_frames == len(ref)
    got = list(itertools.islice(expand(plan), len(ref) + 3))
    names = {c.index: c.name for c in plan.channels}
    for i, g in enumerate(got):
        want = ref[min(i, len(ref) - 1)] if ref else {}
        as_dict = {names[ch]: n for ch, n in enumerate(g.curve)}
        for n, c in zip(g.n, g.curve):
            assert (n is None) == (c is None) and (n is None or abs(n - c) <= 1), (i, g, text)
        for s, n in as_dict.items():
            assert n == want.get(s), (i, s, n, want.get(s), text)
            if n is not None:
                assert 0 <= n <= 250
                outs = spec["servos"][s]["outs"]
                assert min(outs) <= n <= max(outs), (s, n, text)
    # frame F of every move is exactly the pose
    for start, f, _, _, targets in segments:
        for s, n1 in targets.items():
            assert got[start + f - 1].n[plan.channel_of(s).index] == n1
    # no frame moves a servo further than the formula's largest step for that move
    for start, f, ease, before, targets in segments:
        for s, n1 in targets.items():
            n0 = before[s]
            if n0 is None:
                continue
            ch = plan.channel_of(s).index
            path = [n0] + [got[start + k].curve[ch] for k in range(f)]
            formula = [n0] + [_spec_frame(n0, n1, k, f, ease) for k in range(1, f + 1)]
            bound = max(abs(b - a) for a, b in zip(formula, formula[1:]))
            assert all(abs(b - a) <= bound for a, b in zip(path, path[1:])), (s, path)
            if ease == "linear":
                assert bound <= math.ceil(Fraction(abs(n1 - n0), f))


def test_sequences_named_after_a_loop_are_planned():
    plan = plan_of(f"""servo a = P1.0 {FAST}
pose p {{ a: 0 }}
pose q {{ a: 100 }}
sequence inner {{ move p }}
sequence outer {{ play inner }}
sequence never {{ move q }}
main {{
  loop {{ move p in 100ms; move q in 100ms }}
  play outer
}}
""")
    assert [s.name for s in plan.sequences] == ["inner", "outer"]
    assert plan.total_frames is None


def test_verify_covers_the_program_or_two_passes_of_its_loop():
    servos = "frame 5ms\nservo a = P1.0 speed 0.01s/60deg\npose p { a: 0 }\npose q { a: 200 }\n"
    # finite: every frame and a tail of 20
    finite = plan_of(servos + "main { move p in 100ms; hold 1s; move q in 1s }\n")
    assert finite.total_frames == 20 + 200 + 200 and verify_frames(finite) == 420 + 20
    # forever: the 20 frames before the loop, two passes of 200 + 200, and the tail
    looping = plan_of(servos + "main { move p in 100ms; loop { move q in 1s; move p in 1s } }\n")
    assert looping.total_frames is None and verify_frames(looping) == 20 + 2 * 400 + 20
    # a short loop is still checked for at least 400 frames
    short = plan_of(servos + "main { move p in 100ms; loop { move q in 50ms; move p in 50ms } }\n")
    assert verify_frames(short) == 400
    # and a very long one is capped
    long_ = plan_of(servos + "main { loop { hold 300s; hold 300s } }\n")
    assert verify_frames(long_) == 20_000
