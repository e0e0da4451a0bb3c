"""The linter and every diagnostic code: one fixture per code with its full rendered output.

tests/fixtures/lint/<code>.servo is a small program that triggers <code>;
<code>.expected is everything `servoc lint <code>.servo` prints on stderr.
Regenerate the expected files with `SERVOC_REGEN=1 pytest tests/test_lint.py`
and read every changed message before keeping it.
"""

from __future__ import annotations

import math
import os
import re
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servoc import api, cli
from servoc.diagnostics import Severity
from servoc.lint import RULES
from servoc.source import SourceFile

FIXTURES = Path(__file__).parent / "fixtures" / "lint"
REGEN = os.environ.get("SERVOC_REGEN") == "1"

LINT_CODES = [
    "infeasible-speed", "eased-overspeed", "off-grid-width", "inexact-angle", "period-too-short",
    "period-too-long", "short-gap", "short-hold", "empty-loop", "too-long", "unused-servo", "unused-group",
    "unused-pose", "unused-sequence", "unreachable", "p0-pull-up", "too-deep", "duplicate-event", "unused-input",
    "serial-too-fast", "no-home", "level-in-loop", "until-no-frame", "host-ram", "host-takes-bytes", "host-play-waits",
]
FRONT_CODES = [
    "syntax-error", "duplicate-name", "pin-conflict", "bad-pin", "unknown-name", "wrong-kind", "bad-unit",
    "limit-violation", "out-of-range", "bad-limit", "bad-speed", "missing-main", "duplicate-main",
    "duplicate-setting", "late-setting", "bad-frame", "unsupported-target", "bad-count", "recursion",
    "duplicate-target", "duplicate-option", "empty-port", "duplicate-member", "invalid-utf8",
    "bad-baud", "bad-byte", "bad-select", "no-serial", "bad-event", "bad-stagger",
    "unsupported-host", "host-needs-serial", "host-undeclared", "channel-conflict", "channel-unused",
]
CODES = LINT_CODES + FRONT_CODES


def run_cli(args: list[str], capsys) -> tuple[int, str, str]:
    rc = cli.main(args)
    out, err = capsys.readouterr()
    return rc, out, err


def diagnose(text: str, name: str = "t.servo"):
    """The front end's result and diagnostics, but the `no-home` note that every program without `home`
    gets (its own tests are in test_meanwhile.py and its fixture)."""
    src = SourceFile(name, text)
    rep = api.Reporter(src)
    fe = api.front_end(src, rep)
    return fe, [d for d in rep.sorted() if d.code != "no-home"], src


def codes(text: str) -> list[str]:
    return [d.code for d in diagnose(text)[1]]


def where(text: str, code: str) -> list[tuple[int, int]]:
    _, diags, src = diagnose(text)
    return [src.line_col(d.span.start) for d in diags if d.code == code]


# ---- one fixture per code ----------------------------------------------------------------

def test_every_lint_rule_has_a_fixture():
    assert set(RULES) == set(LINT_CODES)
    for code in CODES:
        assert (FIXTURES / f"{code}.servo").is_file(), code
    assert {p.stem for p in FIXTURES.glob("*.servo")} == set(CODES)


@pytest.mark.parametrize("code", CODES)
def test_fixture_renders_as_expected(code, capsys, monkeypatch):
    monkeypatch.chdir(FIXTURES)
    monkeypatch.setenv("NO_COLOR", "1")
    rc, out, err = run_cli(["lint", f"{code}.servo"], capsys)
    expected_file = FIXTURES / f"{code}.expected"
    if REGEN:
        expected_file.write_text(err, encoding="utf-8")
    assert err == expected_file.read_text(encoding="utf-8")
    headers = [line for line in err.splitlines() if re.match(r"\S+\.servo:\d+:\d+: ", line)]
    assert any(h.endswith(f"[{code}]") for h in headers), headers
    has_error = any(": error: " in h for h in headers)
    assert rc == (1 if has_error else 0)
    # every diagnostic the fixture raises explains itself with a help line
    assert err.count("= help: ") == len(headers), err
    if code in RULES:
        severity = RULES[code][0]
        mine = [h for h in headers if h.endswith(f"[{code}]")]
        assert all(f": {severity.value}: " in h for h in mine)
    if rc == 0:
        assert out.startswith(f"{code}.servo: ") and "P = " in out
    else:
        assert out == ""


# ---- infeasible-speed: the boundary -----------------------------------------------------------

def one_ms_program(duration: str, speed: str) -> str:
    # frame 6ms; the arm's t_DAV is exactly 3.01 ms (speed 3.01ms/0.74deg): 100 DAV need 301 ms.
    # `in 300ms` is 50 frames = 300 ms: 1 ms too fast.
    return f"""frame 6ms
servo arm = P1.0 speed {speed}/0.74deg
pose down {{ arm: 20 }}
pose up   {{ arm: 120 }}
home down
main {{
  move down
  hold 100ms
    move up in {duration}
}}
"""


def test_a_move_1ms_too_fast_exits_1_at_the_move(tmp_path, capsys):
    path = tmp_path / "arm.servo"
    path.write_text(one_ms_program("300ms", "3.01ms"))
    rc, out, err = run_cli(["lint", str(path)], capsys)
    assert rc == 1
    head = err.splitlines()[0]
    assert head.startswith(f"{path}:9:5: error: "), err
    assert head.endswith("[infeasible-speed]")
    assert "`arm`" in head and "100 DAV (74°)" in head and "300 ms" in head and "301 ms" in head
    # 51 frames are needed; 303 ms is the shortest whole-ms duration that rounds to 51 frames
    assert "use `in 303ms` or longer" in err


def test_the_same_move_with_time_to_spare_exits_0(tmp_path, capsys):
    for duration, speed in (("306ms", "3.01ms"), ("303ms", "3.01ms"), ("300ms", "3ms")):
        # 303 ms is 50.5 frames, rounded up to 51; at 3 ms per DAV 300 ms is exactly enough
        path = tmp_path / "arm.servo"
        path.write_text(one_ms_program(duration, speed))
        rc, out, err = run_cli(["lint", str(path)], capsys)
        assert rc == 0, (duration, speed, err)
        assert "infeasible-speed" not in err


def test_default_servo_boundary_is_exact():
    # P = 7.4 ms: the default servo needs 150 x 7400/3 us = 370 ms = 50 frames exactly.
    base = "frame 7.4ms\nservo a = P1.0\npose p {{ a: 0 }}\npose q {{ a: 150 }}\nmain {{\n  move p\n  move q in {}\n}}\n"
    assert "infeasible-speed" not in codes(base.format("370ms"))
    assert "infeasible-speed" not in codes(base.format("366.3ms"))    # 49.5 frames -> 50
    assert "infeasible-speed" in codes(base.format("366.2ms"))        # 49.49 -> 49 frames
    assert "infeasible-speed" not in codes(base.replace("150", "151").format("381ms"))
    assert "infeasible-speed" in codes(base.replace("150", "151").format("370ms"))


def test_infeasible_speed_suggestion_is_feasible():
    # the `in ...ms` the help suggests makes the error go away, whatever the numbers
    for delta in (1, 7, 61, 124, 250):
        for p_us in (5300, 6000, 7321, 20000):
            text = (f"frame {p_us}us\nservo a = P1.0\npose p {{ a: 0 }}\npose q {{ a: {delta} }}\n"
                    "main {\n  move p\n  move q in 1ms\n}\n")
            _, diags, _ = diagnose(text)
            if delta * Fraction(7400, 3) <= p_us:      # one frame is enough
                assert "infeasible-speed" not in [d.code for d in diags]
                continue
            d = next(d for d in diags if d.code == "infeasible-speed")
            suggestion = re.search(r"use `in (\d+)ms`", d.help).group(1)
            fixed = text.replace("in 1ms", f"in {suggestion}ms")
            assert "infeasible-speed" not in codes(fixed), (delta, p_us, suggestion)
            # and it is the shortest whole-ms duration that works (never below the need)
            shorter = text.replace("in 1ms", f"in {int(suggestion) - 1}ms")
            need_ms = Fraction(delta * 7400, 3) / 1000
            assert "infeasible-speed" in codes(shorter) or int(suggestion) - 1 < need_ms


def test_infeasible_in_a_later_pass_of_a_repeat():
    # first pass: p -> q from q (delta 0); later passes start from r: 200 DAV in 100 ms is too fast
    text = """servo a = P1.0
pose q { a: 0 }
pose r { a: 200 }
main {
  move q
  repeat 2 {
    move q in 100ms
    move r
  }
}
"""
    assert where(text, "infeasible-speed") == [(7, 5)]


def test_infeasible_once_per_move_from_a_sequence_played_twice():
    text = """servo a = P1.0
servo b = P1.1 speed 0.5s/60deg
pose low  { a: 0, b: 0 }
pose mid  { a: 100, b: 100 }
pose high { a: 200, b: 200 }
sequence up {
  move high in 300ms
}
main {
  move low
  play up
  move mid
  play up
}
"""
    _, diags, _ = diagnose(text)
    found = [d for d in diags if d.code == "infeasible-speed"]
    assert len(found) == 1
    # the slower servo from the worse context: b, 200 DAV at 6.17 ms per DAV
    assert "`b`" in found[0].message and "200 DAV" in found[0].message


def test_moves_without_duration_are_never_infeasible():
    text = """servo a = P1.0 speed 5s/10deg
pose p { a: 0 }
pose q { a: 250 }
main {
  move p
  move q
  move p
}
"""
    assert "infeasible-speed" not in codes(text)


def test_first_move_sets_at_once_without_speed_check():
    text = "servo a = P1.0\npose q { a: 250 }\nmain {\n  move q in 1ms\n}\n"
    assert "infeasible-speed" not in codes(text)


# ---- property: infeasible-speed exactly when |delta| t_DAV > F P ------------------------

@st.composite
def speed_programs(draw):
    n = draw(st.integers(1, 3))
    P = draw(st.integers(5300, 20000))
    t = []
    lines = [f"frame {P}us"]
    for i in range(n):
        kind = draw(st.sampled_from(["default", "random", "exact"]))
        if kind == "random":
            d_ms, a_deg = draw(st.integers(10, 1000)), draw(st.integers(1, 180))
            lines.append(f"servo s{i} = P1.{i} speed {d_ms}ms/{a_deg}deg")
            t.append(Fraction(d_ms * 1000) * Fraction(74, 100) / a_deg)
        elif kind == "exact":
            # t_DAV = P / k exactly (P us over k DAV), so |delta| = k F lands on the boundary
            k = draw(st.integers(1, 6))
            lines.append(f"servo s{i} = P1.{i} speed {P}us/{k * 74 // 100}.{k * 74 % 100:02d}deg")
            t.append(Fraction(P, k))
        else:
            lines.append(f"servo s{i} = P1.{i}")
            t.append(Fraction(74, 100) * 200_000 / 60)
    poses = []
    for j in range(draw(st.integers(1, 4))):
        chosen = draw(st.lists(st.integers(0, n - 1), min_size=1, unique=True))
        # round positions make |delta| = k F (the exact boundary) likely with the durations below
        targets = {i: draw(st.one_of(st.integers(0, 250), st.sampled_from([0, 60, 120, 180, 240])))
                   for i in chosen}
        poses.append(targets)
        lines.append(f"pose p{j} {{ " + ", ".join(f"s{i}: {v}" for i, v in targets.items()) + " }")
    lines.append("main {")
    body = []     # (line number, pose index, duration in us or None, repeat count or 0)
    for _ in range(draw(st.integers(1, 6))):
        pose = draw(st.integers(0, len(poses) - 1))
        # durations near the frame rounding boundaries (F - 1/2) P, and anywhere
        dur = draw(st.one_of(st.none(), st.integers(0, 800_000),
                             st.builds(lambda h, e: max(0, h * P // 2 + e), st.integers(0, 120), st.integers(-1, 1)),
                             st.builds(lambda m: m * P, st.sampled_from([10, 12, 15, 20, 24, 30, 40, 60]))))
        text = f"move p{pose}" + ("" if dur is None else f" in {dur}us")
        if draw(st.integers(0, 4)) == 0:
            count = draw(st.integers(2, 3))
            other = draw(st.integers(0, len(poses) - 1))
            lines.append(f"  repeat {count} {{")
            body.append((len(lines) + 1, pose, dur, count, other))
            lines.append(f"    {text}")
            lines.append(f"    move p{other}")
            lines.append("  }")
        else:
            body.append((len(lines) + 1, pose, dur, 0, None))
            lines.append(f"  {text}")
    lines.append("}")
    return "\n".join(lines) + "\n", P, t, poses, body


def expected_infeasible(P, t, poses, body) -> set[int]:
    """Lines of moves that ask some servo for |delta| x t_DAV > F x P, from the spec alone."""
    state: dict[int, int] = {}
    bad: set[int] = set()

    def move(line, pose, dur):
        if dur is not None:
            F = max(1, math.floor(Fraction(dur, P) + Fraction(1, 2)))
            for i, n1 in poses[pose].items():
                if i in state and abs(n1 - state[i]) * t[i] > F * P:
                    bad.add(line)
        state.update(poses[pose])

    for line, pose, dur, count, other in body:
        for _ in range(max(1, count)):
            move(line, pose, dur)
            if count:
                move(line + 1, other, None)
    return bad


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(speed_programs())
def test_infeasible_speed_exactly_when_the_inequality_holds(case):
    text, P, t, poses, body = case
    _, diags, src = diagnose(text)
    assert not [d for d in diags if d.is_error and d.code != "infeasible-speed"], text
    reported = {src.line_col(d.span.start)[0] for d in diags if d.code == "infeasible-speed"}
    assert reported == expected_infeasible(P, t, poses, body), text


# ---- other rules -----------------------------------------------------------------------

def test_eased_overspeed_only_when_the_peak_is_too_fast():
    base = ("frame 10ms\nservo a = P1.0\npose p {{ a: 0 }}\npose q {{ a: 40 }}\n"
            "main {{\n  move p\n  move q in {}\n}}\n")
    # 40 DAV need 98.7 ms; linear in 200 ms steps at most 2 DAV = 4.9 ms < 10 ms per frame
    assert codes(base.format("200ms")) == []
    # in-out over 20 frames: the middle steps are about 40 x pi/2 / 20 = 3.1 -> 3 DAV = 7.4 ms: fine
    assert codes(base.format("200ms ease in-out")) == []
    # ease in over 10 frames: the last step is 40 x (1 - 0.81) = 7.6 -> 8 DAV = 19.7 ms > 10 ms
    _, diags, _ = diagnose(base.format("100ms ease in"))
    assert [d.code for d in diags] == ["eased-overspeed"]
    help_ms = int(re.search(r"`in (\d+)ms`", diags[0].help).group(1))
    assert codes(base.format(f"{help_ms}ms ease in")) == []


def test_eased_overspeed_for_a_servo_slower_than_a_frame_terminates():
    text = ("servo a = P1.0 speed 10s/1deg\npose p { a: 0 }\npose q { a: 2 }\n"
            "main {\n  move p\n  move q in 20s ease in\n}\n")
    _, diags, _ = diagnose(text)
    d = next(d for d in diags if d.code == "eased-overspeed")
    assert "ease linear" in d.help


def test_huge_eased_moves_lint_quickly():
    text = ("frame 6ms\nservo a = P1.0\npose p { a: 0 }\npose q { a: 250 }\n"
            "main {\n  move p\n  move q in 100000s ease in-out\n  move p in 30000s ease out\n}\n")
    assert sorted(set(codes(text))) == ["too-long"]


def test_short_hold_and_empty_loop():
    text = """servo a = P1.0
pose p { a: 10 }
main {
  move p
  loop {
    hold 2ms
  }
}
"""
    assert codes(text) == ["empty-loop", "short-hold"]
    assert where(text, "empty-loop") == [(5, 3)]
    # a hold of at least half a frame is one frame: the loop is not empty
    assert "empty-loop" not in codes(text.replace("2ms", "3ms"))


def test_empty_loop_through_a_sequence():
    text = """servo a = P1.0
pose p { a: 10 }
sequence nothing {
  hold 1ms
}
main {
  move p
  loop { play nothing }
}
"""
    assert "empty-loop" in codes(text)


def test_too_long_repeat_and_hold():
    base = "servo a = P1.0\npose p {{ a: 10 }}\nmain {{\n  move p\n  {}\n}}\n"
    assert codes(base.format("repeat 65535 { hold 10ms }")) == []
    assert codes(base.format("repeat 65536 { hold 10ms }")) == ["too-long"]
    # 65535 frames of 5.3 ms = 347.3355 s
    assert codes(base.format("hold 347335ms")) == []
    assert codes(base.format("hold 347339ms")) == ["too-long"]


def test_unreachable_after_a_sequence_that_loops():
    text = """servo a = P1.0
pose p { a: 10 }
pose q { a: 20 }
sequence forever {
  loop { move p in 100ms; move q in 100ms }
}
main {
  play forever
  move p
  move q
}
"""
    assert where(text, "unreachable") == [(9, 3)]


def test_unused_declarations():
    text = """servo a = P1.0
servo b = P1.1
servo c = P1.2
group g = a, b
group unused_g = c
pose p { g: 10 }
pose unused_p { a: 20 }
sequence unused_s { move unused_p }
main {
  move p
}
"""
    found = {(d.code, d.message) for d in diagnose(text)[1]}
    assert found == {("unused-servo", "servo `c` is never used"),
                     ("unused-group", "group `unused_g` is never used"),
                     ("unused-sequence", "sequence `unused_s` is never used")}


def test_period_rules_name_the_minimum():
    _, diags, _ = diagnose("frame 1ms\nservo a = P1.0\npose p { a: 250 }\nmain { move p }\n")
    d = next(d for d in diags if d.code == "period-too-short")
    plan = diagnose("servo a = P1.0\npose p { a: 250 }\nmain { move p }\n")[0].plan
    shown = re.search(r"at least ([\d.]+) ms", d.message).group(1)
    assert Fraction(shown) * 1000 == plan.min_period_us
    # exactly the minimum is fine; one microsecond less is not
    at_min = f"frame {plan.min_period_us}us\nservo a = P1.0\npose p {{ a: 250 }}\nmain {{ move p }}\n"
    assert "period-too-short" not in codes(at_min)
    below = at_min.replace(f"{plan.min_period_us}us", f"{plan.min_period_us - 1}us")
    assert "period-too-short" in codes(below)
    # 65535 us is the longest period Timer0 counts at 12 MHz
    assert "period-too-long" not in codes(at_min.replace(f"{plan.min_period_us}us", "65535us"))
    assert "period-too-long" in codes(at_min.replace(f"{plan.min_period_us}us", "65536us"))


def test_p0_pull_up_counts_the_servos():
    text = "servo a = P0.0\nservo b = P0.1\nservo c = P1.0\npose p { a: 1, b: 1, c: 1 }\nmain { move p }\n"
    _, diags, _ = diagnose(text)
    notes = [d for d in diags if d.code == "p0-pull-up"]
    assert len(notes) == 1 and "the 2 servos on P0 will float without pull-up resistors" in notes[0].message
    assert notes[0].severity is Severity.WARNING        # compile, verify, flash and the editor show it too


@pytest.mark.parametrize("level", ["", " low", " high"])
def test_p0_pull_up_covers_inputs(level):
    text = f"input b = P0.3{level}\nservo c = P1.0\npose p {{ c: 1 }}\nmain {{ wait b; move p }}\n"
    _, diags, _ = diagnose(text)
    (d,) = [d for d in diags if d.code == "p0-pull-up"]
    assert "the input on P0" in d.message and "`b`" in d.message and d.severity is Severity.WARNING
    _, diags, _ = diagnose(text.replace("P0.3", "P3.3"))
    assert not [d for d in diags if d.code == "p0-pull-up"]


def test_lint_reports_the_period_on_success(tmp_path, capsys):
    path = tmp_path / "ok.servo"
    path.write_text("servo a = P1.0\npose p { a: 1 }\nhome p\nmain { move p }\n")
    rc, out, err = run_cli(["lint", str(path)], capsys)
    assert rc == 0 and err == ""
    assert out == f"{path}: 1 servo on P1, P = 5.3 ms (default; shortest " + out.split("shortest ")[1]
    assert "program 2 frames = 10.6 ms" in out          # the power-up frame and the move


def test_play_after_a_loop_is_linted_not_crashed():
    # the sequence is only named after a never-ending statement; lint still walks it
    text = """servo a = P1.0
pose p { a: 0 }
pose q { a: 100 }
sequence later {
  move q
}
main {
  loop { }
  repeat 2 { play later; move p }
}
"""
    fe, diags, _ = diagnose(text)
    assert [d.code for d in diags] == ["empty-loop", "unreachable"]
    assert [s.name for s in fe.plan.sequences] == ["later"]


def test_infeasible_in_the_second_pass_of_a_loop():
    text = """servo s = P1.0
pose a { s: 0 }
pose c { s: 250 }
main {
  move a
  loop {
    move a in 100ms
    move c in 2s
  }
}
"""
    # pass 1 starts at a (delta 0); every later pass starts at c: 250 DAV in 100 ms
    assert where(text, "infeasible-speed") == [(7, 5)]


def test_no_second_pass_of_a_loop_whose_first_pass_never_ends():
    # `move a in 100ms` runs once, from no target; the inner loop never gives control back
    inner = """servo s = P1.0
pose a { s: 0 }
pose b { s: 10 }
pose c { s: 250 }
sequence forever {
  loop {
    move b in 1s
    move c in 1s
  }
}
main {
  loop {
    move a in 100ms
    BODY
  }
}
"""
    for body in ("loop { move b in 1s; move c in 1s }", "play forever",
                 "repeat 2 { play forever }"):
        text = inner.replace("BODY", body)
        assert "infeasible-speed" not in codes(text), body


@pytest.mark.parametrize("text, help_", [
    ("servo a = P1.0\npose p { a: 1 }\nmain {\n  move p in 1MHz\n}\n", "durations are written in `us`, `ms` or `s`"),
    ("servo a = P1.0\npose p { a: 1 }\nmain {\n  repeat 3ms { move p }\n}\n", "e.g. `repeat 3`"),
    ("servo a = P1.0 speed 1s/1s\npose p { a: 1 }\nmain { move p }\n", "angles are written in `deg`"),
    ("servo a = P1.0\npose p { a: 3MHz }\nmain { move p }\n", "positions are angles (`90deg`)"),
    ("target at89c52 clock 12\nservo a = P1.0\npose p { a: 1 }\nmain { move p }\n", "e.g. `12MHz`"),
    ("frame 6\nservo a = P1.0\npose p { a: 1 }\nmain { move p }\n", "e.g. `6ms`"),
    ("servo a = P1.0 speed 5/60deg\npose p { a: 1 }\nmain { move p }\n", "e.g. `5ms`"),
])
def test_bad_unit_always_says_how_to_write_it(text, help_):
    _, diags, _ = diagnose(text)
    assert [d.code for d in diags] == ["bad-unit"]
    assert help_ in diags[0].help


def test_sequences_played_many_times_lint_quickly():
    # s10 plays s9 six times, ..., s1 plays s0 six times: 6^10 paths, walked once per sequence
    lines = ["servo a = P1.0", "pose p { a: 1 }", "pose q { a: 2 }",
             "sequence s0 { move p in 10ms; move q in 10ms; move p }"]
    lines += [f"sequence s{i} {{ " + "; ".join([f"play s{i - 1}"] * 6) + " }" for i in range(1, 11)]
    fe, diags, _ = diagnose("\n".join(lines + ["main { play s10 }"]) + "\n")
    assert [d.code for d in diags] == []
    assert fe.plan.total_frames == 6 ** 10 * (2 + 2 + 1)


def test_too_deep_points_at_the_first_level_too_many():
    from servoc import costs
    limit = costs.max_nesting(ports=1)
    lines = ["servo a = P1.0", "pose p { a: 1 }", "pose q { a: 2 }", "sequence s0 { move p in 10ms; move q in 10ms }"]
    lines += [f"sequence s{i} {{ play s{i - 1}; play s{i - 1} }}" for i in range(1, 70)]
    text = "\n".join(lines + ["main { play s69 }"]) + "\n"
    _, diags, src = diagnose(text)
    assert [d.code for d in diags] == ["too-deep"]
    # main's play is level 1, s39's play level 2, ... s(40 - limit)'s play is level limit + 1
    line, col = src.line_col(diags[0].span.start)
    assert src.line_text(line).startswith(f"sequence s{70 - limit} {{") and col == len(f"sequence s{70 - limit} {{ ") + 1


def test_the_registered_severity_is_the_one_reported(monkeypatch):
    from servoc import lint
    _, fn = lint.RULES["short-hold"]
    monkeypatch.setitem(lint.RULES, "short-hold", (Severity.NOTE, fn))
    _, diags, _ = diagnose("servo a = P1.0\npose p { a: 1 }\nmain { move p; hold 1ms }\n")
    assert [(d.code, d.severity) for d in diags] == [("short-hold", Severity.NOTE)]


def test_every_rule_has_its_own_module():
    modules = {fn.__module__ for code, (_, fn) in RULES.items() if not code.startswith("unused-")}
    assert len(modules) == len([c for c in RULES if not c.startswith("unused-")])
    assert all(m.startswith("servoc.lint.rules.") for m in modules)


# ---- quiet at scale ------------------------------------------------------------------------

def test_inexact_angles_are_one_note_per_program():
    text = """servo a = P1.0
servo b = P1.1
pose p { a: 90deg, b: 30deg }
pose q = p with { b: 90deg }
pose r { a: 74deg, b: 150deg }
pose s { a: 60deg, b: 1deg }
main { move p; move q; move r; move s }
"""
    _, diags, src = diagnose(text)
    (d,) = [d for d in diags if d.code == "inexact-angle"]
    assert src.line_col(d.span.start) == (3, 10) and d.label == "N 122"
    # 74deg is N 100 exactly; 90deg is written twice; `q` shares `p`'s a: 90deg
    assert d.message == ("5 angles, at 6 positions, are not exactly reachable: 90deg (N 122 = 90.28°), "
                         "30deg (N 41 = 30.34°), 150deg (N 203 = 150.22°) and 2 more")
    assert "`122`" in d.help and "`90.28deg`" in d.help


def test_one_inexact_angle_written_twice():
    _, diags, _ = diagnose("servo a = P1.0\nservo b = P1.1\npose p { a: 90deg, b: 90deg }\nmain { move p }\n")
    (d,) = [d for d in diags if d.code == "inexact-angle"]
    assert d.message == "90deg is not exactly reachable: N 122 = 90.28° (here and at 1 more position)"


def _many_unused(n: int) -> str:
    return ("servo a = P1.0\n" + "".join(f"pose p{i} {{ a: {i % 250} }}\n" for i in range(n))
            + "pose home { a: 0 }\nhome home\nmain { move home }\n")


def test_a_few_unused_declarations_are_reported_one_by_one():
    _, diags, _ = diagnose(_many_unused(5))
    assert [d.message for d in diags if d.code == "unused-pose"] == [f"pose `p{i}` is never used" for i in range(5)]


def test_many_unused_declarations_are_one_warning():
    _, diags, src = diagnose(_many_unused(4300))
    (d,) = [d for d in diags if d.code == "unused-pose"]
    assert d.message == "4300 poses are never used: `p0`, `p1`, `p2`, `p3`, `p4` and 4295 more"
    assert src.line_col(d.span.start) == (2, 1) and d.help == "remove them, or `move` to them"


def test_linting_a_large_program_prints_little(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("NO_COLOR", "1")
    path = tmp_path / "big.servo"
    path.write_text(_many_unused(4300).replace("pose home { a: 0 }", "pose home { a: 90deg, b: 1deg }")
                    .replace("servo a = P1.0", "servo a = P1.0\nservo b = P1.1"))
    rc, out, err = run_cli(["lint", str(path)], capsys)
    assert rc == 0 and len(err.splitlines()) <= 10
    assert err.rstrip().endswith("0 errors, 1 warning, 1 note")
