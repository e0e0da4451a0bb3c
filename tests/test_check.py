"""servoc.check: nodes.Program -> model.Program, and every error it reports."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from servoc import model, units, target
from servoc.check import check
from servoc.diagnostics import Reporter
from servoc.source import SourceFile
from servoc.syntax import parse

SPEC_EXAMPLE = Path(__file__).parent / "fixtures" / "spec_example.servo"


def run(text: str):
    src = SourceFile("t.servo", text)
    rep = Reporter(src)
    tree = parse(src, rep)
    assert tree is not None, [d.message for d in rep.diagnostics]
    return check(tree, rep, "t.servo"), rep, src


def ok(text: str) -> model.Program:
    prog, rep, _ = run(text)
    assert prog is not None, [(d.code, d.message) for d in rep.diagnostics]
    assert not rep.has_errors
    return prog


def errors(text: str) -> list[tuple[str, int, int]]:
    """(code, line, col) of every error, in source order; the model must be None."""
    prog, rep, src = run(text)
    assert prog is None
    return [(d.code, *src.line_col(d.span.start)) for d in rep.sorted() if d.is_error]


def messages(text: str, code: str) -> list[str]:
    _, rep, _ = run(text)
    return [d.message + " | " + d.help for d in rep.diagnostics if d.code == code]


def targets(prog: model.Program, pose: str) -> dict[str, int]:
    return {t.servo: t.n for t in next(p for p in prog.poses if p.name == pose).targets}


MAIN = "\nmain {\n}\n"


# ---- the spec's example -----------------------------------------------------

def test_spec_example_servos():
    prog = ok(SPEC_EXAMPLE.read_text())
    s = {x.name: x for x in prog.servos}
    assert [x.name for x in prog.servos] == ["hip_l", "knee_l", "ankle_l", "hip_r", "wrist"]
    assert (s["hip_l"].port, s["hip_l"].bit, s["hip_l"].channel) == (1, 0, 8)
    assert s["wrist"].pin == "P0.0" and s["wrist"].channel == 0
    assert s["ankle_l"].trim == -2 and s["ankle_l"].limit == (27, 216)     # 20deg..160deg
    assert s["hip_r"].reverse and not s["hip_l"].reverse
    assert s["hip_l"].t_dav_us == units.DEFAULT_T_DAV_US
    assert s["knee_l"].t_dav_us == units.t_dav_from_speed(Fraction(250_000), Fraction(60)) == Fraction(9250, 3)
    assert prog.frame_us == 6000 and prog.target.chip.name == "at89c52" and prog.target.clock_hz == 12_000_000


def test_spec_example_poses_and_statements():
    prog = ok(SPEC_EXAMPLE.read_text())
    assert targets(prog, "stand") == {"hip_l": 122, "knee_l": 122, "ankle_l": 120, "hip_r": 128, "wrist": 125}
    assert targets(prog, "crouch") == {"hip_l": 162, "knee_l": 61, "ankle_l": 133}
    assert targets(prog, "lean") == {"hip_l": 122, "knee_l": 122, "ankle_l": 106, "hip_r": 128, "wrist": 125}
    assert [g.servos for g in prog.groups] == [("hip_l", "knee_l", "ankle_l")]
    (squat,) = prog.sequences
    move, hold, fast = squat.body
    assert (move.pose, move.duration_us, move.ease) == ("crouch", 400_000, "linear")
    assert hold == model.Hold(200_000)
    assert fast.duration_us is None and fast.pose == "stand"
    first, rep, loop = prog.main
    assert first.duration_us == 1_000_000 and first.targets == next(p for p in prog.poses if p.name == "stand").targets
    assert rep == model.Repeat(3, (model.Play("squat"),))
    assert [(m.pose, m.duration_us, m.ease) for m in loop.body] == [("lean", 300_000, "in-out"),
                                                                   ("stand", 300_000, "in-out")]
    assert prog.references == {"hip_l", "knee_l", "ankle_l", "hip_r", "wrist", "leg_l", "stand", "crouch",
                               "lean", "squat"}


def test_spec_example_spans():
    text = SPEC_EXAMPLE.read_text()
    prog = ok(text)
    stand = next(p for p in prog.poses if p.name == "stand")
    hip_r = next(t for t in stand.targets if t.servo == "hip_r")
    assert text[hip_r.span.start:hip_r.span.end] == "hip_r: 90deg"
    move = prog.sequences[0].body[0]
    assert text[move.span.start:move.span.end] == "move crouch in 400ms"
    servo = prog.servos[2]
    assert text[servo.span.start:servo.span.end] == "servo ankle_l = P1.2 trim -2 limit 20deg..160deg"
    assert text[prog.main_span.start:prog.main_span.start + 4] == "main"
    assert text[prog.frame_span.start:prog.frame_span.end] == "frame 6ms"


# ---- positions --------------------------------------------------------------

@pytest.mark.parametrize("position,n", [
    ("0deg", 0), ("45deg", 61), ("90deg", 122), ("180deg", 243), ("185deg", 250), ("60deg", 81),
    ("0.74deg", 1), ("0.37deg", 1), ("0.36deg", 0),
    ("500us", 0), ("1500us", 125), ("2500us", 250), ("1.5ms", 125), ("0.0015s", 125),
    ("0", 0), ("100", 100), ("250", 250),
])
def test_position_to_n(position, n):
    prog = ok(f"servo a = P1.0\npose p {{ a: {position} }}" + MAIN)
    (t,) = prog.poses[0].targets
    assert t.n == n and t.position.n == n


def test_position_value_and_unit_are_kept():
    prog = ok("servo a = P1.0\nservo b = P1.1\nservo c = P1.2\npose p { a: 1.5ms, b: 45deg, c: 7 }" + MAIN)
    a, b, c = (t.position for t in prog.poses[0].targets)
    assert (a.value, a.unit, a.n) == (1500, "us", 125)
    assert (b.value, b.unit, b.n) == (45, "deg", 61)
    assert (c.value, c.unit, c.n) == (7, "n", 7)


def test_off_grid_width_rounds_half_up():
    # the warning itself is the linter's `off-grid-width` rule (tests/test_lint.py)
    prog, rep, src = run("servo a = P1.0\npose p { a: 1502us, }" + MAIN)   # (1502-500)/8 = 125.25
    assert prog is not None and targets(prog, "p") == {"a": 125} and rep.diagnostics == []
    prog, rep, _ = run("servo a = P1.0\npose p { a: 1504us }" + MAIN)      # 125.5 -> 126
    assert targets(prog, "p") == {"a": 126} and rep.diagnostics == []
    prog, rep, _ = run("servo a = P1.0\npose p { a: 1508us }" + MAIN)      # on the grid
    assert targets(prog, "p") == {"a": 126} and rep.diagnostics == []


def test_reverse_then_trim():
    prog = ok("servo a = P1.0 reverse trim 3\nservo b = P1.1 trim 3 reverse\nservo c = P1.2 trim -5\n"
              "pose p { a: 100, b: 100, c: 100 }" + MAIN)
    assert targets(prog, "p") == {"a": 153, "b": 153, "c": 95}


def test_limit_is_inclusive_and_checked_before_reverse_and_trim():
    prog = ok("servo a = P1.0 limit 20deg..160deg reverse trim 4\npose lo { a: 27 }\npose hi { a: 216 }" + MAIN)
    assert targets(prog, "lo") == {"a": 250 - 27 + 4}
    assert targets(prog, "hi") == {"a": 250 - 216 + 4}
    assert prog.servos[0].limit == (27, 216)


def test_limit_bounds_in_any_position_unit():
    prog = ok("servo a = P1.0 limit 1000us..2ms\nservo b = P1.1 limit 5..245" + MAIN)
    assert prog.servos[0].limit == (63, 188) and prog.servos[1].limit == (5, 245)


def test_limit_violation():
    text = "servo a = P1.0 limit 20deg..160deg\npose p {\n  a: 161deg\n}\npose q { a: 26 }" + MAIN
    assert errors(text) == [("limit-violation", 3, 3), ("limit-violation", 5, 10)]
    (msg, _) = messages(text, "limit-violation")
    assert "`a`" in msg and "20deg..160deg" in msg


def test_out_of_range_after_trim_at_the_pose_entry():
    text = "servo a = P1.0 trim 3\nservo b = P1.1 trim -1\npose p { a: 248, b: 0 }\npose q { a: 185deg }" + MAIN
    assert errors(text) == [("out-of-range", 3, 10), ("out-of-range", 3, 18), ("out-of-range", 4, 10)]


def test_out_of_range_position_without_limit():
    assert errors("servo a = P1.0\npose p { a: 2600us }" + MAIN) == [("out-of-range", 2, 10)]
    assert errors("servo a = P1.0 reverse\npose p { a: 251 }" + MAIN) == [("out-of-range", 2, 10)]


# ---- targets: servos, groups, ports, `with` -----------------------------------

def test_targets_in_servo_declaration_order():
    prog = ok("servo z = P2.7\nservo a = P0.0\nservo m = P1.3\npose p { m: 3, a: 2, z: 1 }" + MAIN)
    assert [t.servo for t in prog.poses[0].targets] == ["z", "a", "m"]


def test_groups_of_groups_flatten_in_declaration_order():
    prog = ok("servo a = P1.0\nservo b = P1.1\nservo c = P1.2\ngroup g1 = c, a\ngroup g2 = b, g1, a\n"
              "pose p { g2: 10 }" + MAIN)
    assert [g.servos for g in prog.groups] == [("a", "c"), ("a", "b", "c")]
    assert targets(prog, "p") == {"a": 10, "b": 10, "c": 10}


def test_port_target_means_every_servo_on_the_port():
    prog = ok("servo a = P1.0\nservo w = P0.3\nservo b = P1.7\npose p { P1: 90deg, w: 5 }" + MAIN)
    assert targets(prog, "p") == {"a": 122, "w": 5, "b": 122}
    assert {"a", "b", "w"} <= prog.references


def test_pose_with_copies_and_overrides():
    prog = ok("servo a = P1.0\nservo b = P1.1\nservo c = P1.2\npose base { a: 1, b: 2 }\n"
              "pose more = base with { b: 20, c: 30 }\npose same = more with {}" + MAIN)
    assert targets(prog, "more") == {"a": 1, "b": 20, "c": 30}
    assert targets(prog, "same") == targets(prog, "more")
    assert {"base", "more"} <= prog.references and "same" not in prog.references


def test_names_may_be_used_before_their_declaration():
    prog = ok("main {\n  play s\n}\nsequence s {\n  move p\n}\npose p { g: 1 }\ngroup g = a\nservo a = P1.0\n")
    assert targets(prog, "p") == {"a": 1}
    assert prog.main == (model.Play("s"),)


def test_empty_pose_is_allowed():
    prog = ok("pose nothing {}\nmain {\n  move nothing in 1s\n}\n")
    assert prog.poses[0].targets == () and prog.main[0].targets == ()


def test_references_leave_unused_names_out():
    prog = ok("servo a = P1.0\nservo lonely = P1.1\ngroup g = a\ngroup unused = lonely\npose p { g: 1 }\n"
              "pose q {}\nsequence s {}\nsequence t {\n  play s\n}\nmain {\n  move p\n}\n")
    assert prog.references == {"a", "g", "p", "s"}


def test_speed_and_settings():
    prog = ok("target AT89S52 clock 12000kHz\nframe 5.5ms\nservo a = P1.0 speed 100ms/30deg" + MAIN)
    assert prog.servos[0].t_dav_us == Fraction(100_000) * Fraction(74, 100) / 30
    assert prog.target.chip.name == "at89s52" and prog.target.clock_hz == 12_000_000 and prog.frame_us == 5500
    default = ok(MAIN)
    assert default.frame_us is None and default.target.chip.name == "at89c52"


def test_statements_convert_units():
    prog = ok("pose p {}\nmain {\n  move p in 0.5s ease out\n  hold 250000us\n  repeat 2 {\n    loop {\n"
              "      move p\n    }\n  }\n}\n")
    move, hold, rep = prog.main
    assert move == model.Move("p", (), Fraction(500_000), "out")
    assert hold.duration_us == 250_000
    assert rep.count == 2 and rep.body == (model.Loop((model.Move("p", (), None, "linear"),)),)


# ---- every error code ---------------------------------------------------------

CASES = [
    ("duplicate-name", "servo a = P1.0\npose a {}" + MAIN, [(2, 6)]),
    ("duplicate-name", "servo a = P1.0\nservo P1 = P1.1" + MAIN, [(2, 7)]),
    ("pin-conflict", "servo a = P1.0\nservo b = P1.0" + MAIN, [(2, 11)]),
    ("bad-pin", "servo a = P3.0\nservo b = P1.8\nservo c = p1.0" + MAIN, [(1, 11), (2, 11), (3, 11)]),
    ("unknown-name", "servo hip_l = P1.0\npose p { hip_1: 1 }" + MAIN, [(2, 10)]),
    ("unknown-name", "main {\n  move nowhere\n  play nothing\n}\n", [(2, 8), (3, 8)]),
    ("unknown-name", "group g = a\n" + MAIN, [(1, 11)]),
    ("wrong-kind", "pose p {}\nsequence s {}\nmain {\n  play p\n  move s\n}\n", [(4, 8), (5, 8)]),
    ("wrong-kind", "pose p {}\ngroup g = p\npose q { p: 1 }\npose r = g with {}" + MAIN, [(2, 11), (3, 10), (4, 10)]),
    ("bad-unit", "servo a = P1.0\npose p { a: 1.5 }\nmain {\n  move p in 90deg\n  hold 300\n}\n",
     [(2, 13), (4, 13), (5, 8)]),
    ("bad-unit", "servo a = P1.0 speed 60deg/0.25s\nframe 6" + MAIN, [(1, 22), (1, 28), (2, 7)]),
    ("bad-unit", "servo a = P1.0 trim 2deg\npose p { a: 90rad }" + MAIN, [(1, 21), (2, 13)]),
    ("bad-unit", "target at89c52 clock 12ms\nmain {\n  repeat 2s {}\n}\n", [(1, 22), (3, 10)]),
    ("limit-violation", "servo a = P1.0 limit 10..20\npose p { a: 21 }" + MAIN, [(2, 10)]),
    ("out-of-range", "servo a = P1.0 trim 1\npose p { a: 250 }" + MAIN, [(2, 10)]),
    ("bad-limit", "servo a = P1.0 limit 160deg..20deg\nservo b = P1.1 limit 0deg..190deg" + MAIN,
     [(1, 16), (2, 28)]),
    ("bad-speed", "servo a = P1.0 speed 0s/60deg\nservo b = P1.1 speed 1s/0deg" + MAIN, [(1, 22), (2, 25)]),
    ("missing-main", "servo a = P1.0\n", [(1, 1)]),
    ("duplicate-main", "main {}\n\nmain {}\n", [(3, 1)]),
    ("duplicate-setting", "frame 6ms\ntarget at89c52\nframe 7ms\ntarget at89c52" + MAIN, [(3, 1), (4, 1)]),
    ("late-setting", "main {}\nframe 6ms\n", [(2, 1)]),
    ("late-setting", "sequence s {}\ntarget at89c52" + MAIN, [(2, 1)]),
    ("bad-frame", "frame 0ms\n" + MAIN, [(1, 7)]),
    ("bad-frame", "frame 1.5us\n" + MAIN, [(1, 7)]),
    ("unsupported-target", "target at89c51" + MAIN, [(1, 8)]),
    ("bad-clock", "target stc89c52 clock 8MHz" + MAIN, [(1, 23)]),
    ("bad-count", "main {\n  repeat 0 {}\n  repeat 1.5 {}\n}\n", [(2, 10), (3, 10)]),
    ("recursion", "sequence a {\n  play a\n}" + MAIN, [(2, 3)]),
    ("recursion", "sequence a {\n  play b\n}\nsequence b {\n  play c\n}\nsequence c {\n  play a\n}" + MAIN,
     [(2, 3)]),
    ("recursion", "servo x = P1.0\ngroup g = x, h\ngroup h = g" + MAIN, [(3, 11)]),
    ("recursion", "pose a = b with {}\npose b = a with {}" + MAIN, [(2, 10)]),
    ("duplicate-target", "servo a = P1.0\nservo b = P1.1\ngroup g = a, b\npose p { a: 1, g: 2 }" + MAIN,
     [(4, 16)]),
    ("duplicate-target", "servo a = P1.0\npose p { a: 1,\n  P1: 2 }" + MAIN, [(3, 3)]),
    ("duplicate-option", "servo a = P1.0 trim 1 reverse trim 2\nservo b = P1.1 reverse reverse" + MAIN,
     [(1, 31), (2, 24)]),
]


@pytest.mark.parametrize("code,text,where", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_error_code_and_position(code, text, where):
    got = errors(text)
    assert [(line, col) for c, line, col in got if c == code] == where, got
    assert all(c == code for c, _, _ in got), got


def test_unknown_name_suggests_a_close_name():
    (msg,) = messages("servo hip_l = P1.0\npose p { hip_1: 1 }" + MAIN, "unknown-name")
    assert "`hip_1`" in msg and "did you mean `hip_l`?" in msg


def test_recursion_names_the_cycle():
    (msg,) = messages("sequence a {\n  play b\n}\nsequence b {\n  play a\n}" + MAIN, "recursion")
    assert "sequence `a` plays itself through `b`" in msg
    (msg,) = messages("sequence a {\n  repeat 2 {\n    play a\n  }\n}" + MAIN, "recursion")
    assert "sequence `a` plays itself" in msg


def test_unknown_chip_lists_the_known_ones_closest_first():
    (msg,) = messages("target at89c2051" + MAIN, "unsupported-target")
    assert "an 8051 without Timer2" in msg
    known = msg.split("256 B RAM): ")[1].split(", ")
    assert sorted(known) == sorted(target.CHIPS) and known[0].startswith("at89c")
    (msg,) = messages("target stc89c53rc" + MAIN, "unsupported-target")
    assert msg.split("256 B RAM): ")[1].startswith("stc89c5")


def test_target_chips_are_case_insensitive():
    for chip, name in (("at89c52", "at89c52"), ("AT89C52", "at89c52"), ("at89s52", "at89s52"),
                       ("STC89C52", "stc89c52rc"), ("stc89c52RC", "stc89c52rc"), ("AT89C55WD", "at89c55wd"),
                       ("STC89C58RD", "stc89c58rd")):
        assert ok(f"target {chip} clock 12MHz" + MAIN).target.chip.name == name


def test_clock_mode_and_timing_errors_name_what_works():
    (msg,) = messages("target at89c52 clock 30MHz" + MAIN, "bad-clock")
    assert "up to 24 MHz" in msg
    (msg,) = messages("target at89s52 mode 6T" + MAIN, "unsupported-target")
    assert "no 6T mode" in msg
    (msg,) = messages("target stc89c52rc clock 8MHz" + MAIN, "bad-clock")
    assert "too slow" in msg and "5.33 machine cycles" in msg and "the lowest clock that works is 10.5 MHz" in msg
    (msg,) = messages("target stc89c52rc clock 4MHz mode 6T" + MAIN, "bad-clock")
    assert "the lowest clock that works is 5.25 MHz" in msg
    assert ok("target stc89c52rc clock 10.5MHz" + MAIN).target.clock_hz == 10_500_000
    eleven = ok("target stc89c52rc clock 11.0592MHz" + MAIN).target
    assert not eleven.grid and eleven.width_cycles(0) == 461 and eleven.width_cycles(250) == 2304
    six = ok("target stc89c52rc clock 6MHz mode 6T" + MAIN).target
    assert six.six_t and six.cycle_us == 1 and six.sim_hz == 12_000_000
    assert ok("servo mode = P1.0\npose low { mode: 3 }\nmain { move low }\n").servos[0].name == "mode"


def test_bad_unit_says_what_was_expected():
    (msg,) = messages("main {\n  hold 90deg\n}\n", "bad-unit")
    assert "`90deg` is an angle where a duration" in msg
    (msg,) = messages("servo a = P1.0 speed 1s/1s" + MAIN, "bad-unit")
    assert "time over an angle" in msg


def test_many_errors_in_one_run():
    text = ("servo a = P1.0\nservo b = P1.0\nservo c = P9.9\npose p { zz: 1 }\nsequence s {\n  play s\n}\n"
            "main {\n  repeat 0 {}\n}\nmain {}\n")
    codes = [c for c, _, _ in errors(text)]
    assert codes == ["pin-conflict", "bad-pin", "unknown-name", "recursion", "bad-count", "duplicate-main"]


def test_huge_numbers_do_not_crash():
    big = "9" * 30
    for text in (f"servo a = P1.0 trim {big}\npose p {{ a: 1 }}" + MAIN,
                 f"servo a = P1.0\npose p {{ a: {big}deg }}" + MAIN,
                 f"frame {big}.{big}s\nmain {{\n  hold {big}s\n  repeat {big} {{}}\n}}\n",
                 f"servo a = P1.0 speed {big}s/0.{big}deg limit 0..{big}" + MAIN):
        src = SourceFile("t.servo", text)
        rep = Reporter(src)
        tree = parse(src, rep)
        assert tree is not None
        check(tree, rep, "t.servo")
