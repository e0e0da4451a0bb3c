"""Reacting while moving, edges, `on other`, `until`, and power-up (`home`, `stagger`)."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import build_text, front_end_text, simulate_events
from servoc import api, costs, flow, plan as plan_mod, printer, syntax
from servoc.diagnostics import Reporter
from servoc.plan import Choice, expand
from servoc.steps import SelectStep
from servoc.source import SourceFile
from servoc.speed import infeasible

PAN = """\
frame 10ms
servo pan = P2.0
servo tilt = P2.1
input button = P3.2
pose rest  { pan: 122, tilt: 122 }
pose left  { pan: 27, tilt: 108 }
pose right { pan: 216, tilt: 108 }
"""


def lint_codes(text: str) -> list[tuple[str, int]]:
    source = SourceFile("t.servo", text)
    reporter = Reporter(source)
    api.front_end(source, reporter)
    return [(d.code, source.line_col(d.span.start)[0]) for d in reporter.diagnostics]


# ---------------------------------------------------------------- front end

@pytest.mark.parametrize("text", [
    "main {\n  select {\n    on press b {}\n    on release b {}\n    after 1s {}\n    meanwhile {\n      hold 1s\n    }\n  }\n}\n",
    "main {\n  move a in 1s until press b\n  wait release b\n  loop {\n    hold 1s\n  } until b\n}\n",
    "home rest\nstagger 100ms\n",
    "main {\n  select {\n    on \"x\" {}\n    on other {\n      send \"?\"\n    }\n  }\n}\n",
])
def test_new_constructs_print_back_as_written(text):
    source = SourceFile("t.servo", text)
    tree = syntax.parse(source, Reporter(source))
    assert tree is not None
    assert printer.format_program(tree) == text


def test_home_press_and_release_stay_usable_names():
    text = PAN.replace("input button", "input release") + "pose home { pan: 1 }\nhome home\nmain {\n  wait press release\n}\n"
    assert not [c for c, _ in lint_codes(text) if c not in ("inexact-angle", "unused-pose")]


@pytest.mark.parametrize("body, code", [
    ("select { on button { }\n meanwhile { hold 1s }\n meanwhile { hold 1s } }", "bad-select"),
    ("select { meanwhile { hold 1s }\n on button { } }", "bad-select"),
    ("wait press \"a\"", "bad-event"),          # press and release apply to inputs
    ("wait push button", "bad-event"),
    ("wait other", "bad-event"),
    ("select { on other { } }", "no-serial"),
])
def test_errors(body, code):
    codes = [c for c, _ in lint_codes(PAN + "main {\n" + body + "\n}\n")]
    assert code in codes, codes


def test_until_on_a_select_is_a_syntax_error():
    assert "syntax-error" in [c for c, _ in lint_codes(PAN + "main {\n wait button until button\n}\n")]


def test_lint_notes_and_warnings():
    codes = lint_codes(PAN + "main {\n  move rest in 1s\n  loop {\n    wait button\n    move left in 2s\n  }\n}\n")
    assert ("no-home", 9) in codes and ("level-in-loop", 11) in codes
    assert codes.count(("no-home", 9)) == 1
    with_home = lint_codes(PAN + "home rest\nmain {\n  loop {\n    wait press button\n    move left in 2s\n  }\n}\n")
    assert not [c for c, _ in with_home if c in ("no-home", "level-in-loop")]
    assert ("until-no-frame", 9) in lint_codes(PAN + "main {\n  hold 1ms until button\n}\n")


# ---------------------------------------------------------------- the interruption check

def branch_speed_errors(text: str) -> bool:
    return any(c == "infeasible-speed" for c, _ in lint_codes(text))


def _plan(text):
    source = SourceFile("t.servo", text)
    reporter = Reporter(source)
    front = api.front_end(source, reporter)
    return front.plan


def _take(it, n):
    for i, x in enumerate(it):
        if i >= n:
            return
        yield x


def test_interruption_check_scales_with_the_program_not_its_frames():
    """A 10,000-frame meanwhile body is one state per select: planning it takes no longer than a short one."""
    import time
    long = PAN + "main {\n  move rest in 1s\n  select {\n    on button { move rest in 2s }\n    meanwhile {\n      repeat 2500 {\n        move left in 20ms\n        move right in 20ms\n      }\n    }\n  }\n}\n"
    t0 = time.perf_counter()
    p = _plan(long)
    took = time.perf_counter() - t0
    assert p is not None and took < 5
    (st_, hull), = p.cuts
    assert hull[0].lo == 27 and hull[0].hi == 216


# ---------------------------------------------------------------- firmware in ucsim

pytestmark_sim = pytest.mark.toolchain

SWEEP = PAN + """\
home rest
main {
  loop {
    select {
      on press button {
        wait release button
        move rest in 600ms
      }
      meanwhile {
        loop {
          move left in 1s
          move right in 1s
        }
      }
    }
  }
}
"""


def run(text: str, scenario: str, frames: int):
    plan, evs, trace = simulate_events(text, scenario, frames)
    choices, report = api.events_report(plan, trace, frames, evs)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:5]])
    return plan, choices, report


@pytest.mark.toolchain
@pytest.mark.parametrize("at_ms", [500.0, 502.5, 505.0, 507.5, 1010.0, 1505.0])
def test_a_press_cuts_the_sweep_at_every_phase(at_ms):
    # presses early, mid-move, at a frame boundary (P = 10 ms) and right at a move's last frame
    scenario = f"{at_ms / 1000}s button active\n{at_ms / 1000 + 0.3}s button inactive\n"
    plan, choices, report = run(SWEEP, scenario, 250)
    taken = [r for r in report.reactions if "press" in r.branch]
    assert taken, report.reactions
    delay = taken[0].time_us - at_ms * 1000
    assert 0 < delay <= 2 * plan.period_us, delay


@pytest.mark.toolchain
def test_a_held_button_triggers_on_press_once():
    text = PAN + "serial 4800\nmain {\n  move rest in 100ms\n  loop {\n    wait press button\n    send \"p\"\n  }\n}\n"
    plan, evs, trace = simulate_events(text, "0.3s button active\n1.5s button inactive\n1.8s button active\n2s button inactive\n", 230)
    assert "".join(chr(b) for _, b in trace.sent) == "pp"


@pytest.mark.toolchain
def test_on_other_answers_unknown_bytes():
    text = PAN + "serial 4800\nmain {\n  move rest in 100ms\n  loop {\n    select {\n      on \"a\" { send \"A\" }\n      on other { send \"?\" }\n    }\n  }\n}\n"
    plan, evs, trace = simulate_events(text, '0.3s "a"\n0.5s "x"\n0.7s "y" "a"\n', 120)
    assert "".join(chr(b) for _, b in trace.sent) == "A??A"


@pytest.mark.toolchain
@pytest.mark.parametrize("stmt", ["move right in 2s", "hold 2s", "play sweep",
                                  "repeat 3 {\n    move left in 600ms\n    move right in 600ms\n  }",
                                  "loop {\n    move left in 600ms\n    hold 100ms\n    move right in 600ms\n  }"])
def test_until_cuts_each_kind_of_statement(stmt):
    text = PAN + ("sequence sweep {\n  move left in 1s\n  move right in 1s\n}\nhome rest\nmain {\n  "
                  f"{stmt} until button\n  move rest in 500ms\n}}\n")
    plan, choices, report = run(text, "0.8s button active\n1.2s button inactive\n", 200)
    assert choices and choices[0].frames > 0
    assert any(r.branch == "on button" for r in report.reactions)


@pytest.mark.parametrize("stmt, named", [("hold 1s", "`hold 1s`"), ("play sweep", "`play sweep`"),
                                         ("loop { hold 1s }", "`loop { hold 1s }`")])
def test_a_speed_error_after_until_names_the_statement_it_cuts(stmt, named):
    # the servo is where `move left` left it, whatever the cut: the message still names the
    # statement `until` cuts short and its line, as for a cut move
    text = PAN + ("sequence sweep {\n  hold 500ms\n}\nhome rest\nmain {\n  move left in 1s\n"
                  f"  {stmt} until button\n  move right in 100ms\n}}\n")
    _, diags = front_end_text(text)
    errors = [d for d in diags if d.is_error]
    line = text.splitlines().index(f"  {stmt} until button") + 1
    assert errors and all(d.code == "infeasible-speed" for d in errors)
    assert any(f"from where `until button` (line {line}) cuts {named} short" in d.message for d in errors), \
        [d.message for d in errors]


@pytest.mark.toolchain
def test_after_counts_meanwhile_frames():
    text = PAN + "home rest\nmain {\n  select {\n    on button { }\n    after 500ms { move rest in 300ms }\n    meanwhile {\n      move left in 2s\n    }\n  }\n}\n"
    plan, choices, report = run(text, "", 150)
    assert choices in ((), (Choice(1, 50),))      # no event: the golden model takes `after` at its F


@pytest.mark.toolchain
def test_stagger_switches_servos_on_in_declaration_order():
    text = PAN + "home rest\nstagger 50ms\nmain {\n  move left in 400ms\n}\n"
    built = build_text(text)
    p = built.plan
    assert p.startup == ((0, 1), (1, 6))
    report = api.verify(p, built.firmware, 40)
    assert report.ok, report.summary()
    frames = list(_take(expand(p), 8))
    assert frames[0].n == (122, None) and frames[4].n == (122, None) and frames[5].n == (122, 122)
    # the program's first move starts after the last servo's first pulse
    assert frames[6].n[0] != 122


_N = st.integers(min_value=0, max_value=250)      # a bare number in a pose is a raw N


@st.composite
def _cut_programs(draw):
    """A select whose meanwhile body is a few moves and holds of two servos, and a branch moving
    both to a pose in a drawn time: (text, the branch move's line)."""
    poses = [draw(st.tuples(_N, _N)) for _ in range(4)]
    lines = ["frame 10ms", "servo a = P1.0", "servo b = P1.1", "input button = P3.2"]
    lines += [f"pose p{i} {{ a: {x}, b: {y} }}" for i, (x, y) in enumerate(poses)]
    body = []
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.booleans()):
            ease = draw(st.sampled_from(["", " ease in-out", " ease out"]))
            body.append(f"move p{draw(st.integers(1, 2))} in {draw(st.integers(1, 60)) * 10}ms{ease}")
        else:
            body.append(f"hold {draw(st.integers(1, 5)) * 10}ms")
    branch_ms = draw(st.integers(1, 70)) * 10
    lines += ["main {", "  move p0 in 1500ms", "  select {", f"    on button {{ move p3 in {branch_ms}ms }}",
              "    meanwhile {", *(f"      {b}" for b in body), "    }", "  }", "}"]
    return "\n".join(lines) + "\n", lines.index(f"    on button {{ move p3 in {branch_ms}ms }}") + 1


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_cut_programs())
def test_the_interruption_check_flags_exactly_the_moves_too_fast_from_some_frame(case):
    """Brute force: cut the body after each of its frames (and before the first, and while the
    select waits after it), take the positions from the golden frames, and test the branch's move
    from each. The check (per servo the farthest position the body reaches) must flag the move
    exactly when one of those starts is too fast."""
    text, line = case
    p = _plan(text)
    assert p is not None
    select = next(s for s in p.main if isinstance(s, SelectStep))
    move = select.branches[0].body[0]
    body_frames = sum(s.frames for s in select.meanwhile)
    too_fast = False
    for k in range(0, body_frames + 3):
        frames = list(_take(expand(p, (Choice(0, k),)), 700))
        i = next(i for i, f in enumerate(frames) if f.span == move.span)
        start = frames[i - 1].curve
        for ch, n1 in move.targets:
            if infeasible(n1 - start[ch], move.frames, p.class_t_dav_us[p.channels[ch].speed_class], p.period_us):
                too_fast = True
    flagged = ("infeasible-speed", line) in lint_codes(text)
    assert flagged == too_fast, text


@pytest.mark.toolchain
def test_on_release_starts_its_branch_within_two_frames_of_the_release():
    text = PAN + "home rest\nmain {\n  select {\n    on release button { move left in 300ms }\n  }\n  move right in 1s\n}\n"
    plan, choices, report = run(text, "0.3s button active\n0.72s button inactive\n", 200)
    (taken,) = [r for r in report.reactions if r.branch == "on release button"]
    assert 0 < taken.time_us - 720_000 <= 2 * plan.period_us, taken


@pytest.mark.toolchain
@pytest.mark.parametrize("serial", [False, True])
def test_a_cut_at_the_deepest_nesting_the_stack_allows(serial):
    """Repeats nested as deep as lint allows inside a meanwhile body (with an edge event, and with
    the serial line's RAM and handler on the stack too) compile, one level more is `too-deep`, and
    the program cut at the innermost level runs with every pulse exact."""
    # on P0.0 and P0.1: their motion state is the first above the stack (0xA0..)
    head = PAN.replace("P2.0", "P0.0").replace("P2.1", "P0.1") + ("serial 4800\n" if serial else "") + "home rest\n"
    probe = _plan(head + "main {\n  select {\n    on press button { }\n    meanwhile {\n      hold 10ms\n    }\n  }\n}\n")
    depth = costs.max_nesting(serial, True, flow.select_ram(probe), len(probe.ports))
    inner = "move left in 500ms\nmove right in 500ms\n"
    for _ in range(depth - probe.nesting):          # the select's own frame is on the stack too
        inner = f"repeat 2 {{\n{inner}}}\n"
    text = head + f"main {{\n  select {{\n    on press button {{ move rest in 500ms }}\n    meanwhile {{\n{inner}}}\n  }}\n}}\n"
    assert not [c for c, _ in lint_codes(text) if c == "too-deep"]
    deeper = text.replace("meanwhile {\n", "meanwhile {\nrepeat 2 {\n", 1).replace("\n  }\n}\n", "\n}\n  }\n}\n")
    assert ("too-deep" in [c for c, _ in lint_codes(deeper)])
    bytes_in = '1.2s "z" "z"\n' if serial else ""            # the serial handler runs at the deepest level too
    plan, choices, report = run(text, bytes_in + "1.5s button active\n1.7s button inactive\n", 260)
    assert plan.nesting == depth and any(r.branch == "on press button" for r in report.reactions)


def test_sends_of_a_meanwhile_body_count_with_the_branch_after_it():
    """A body that ends with three bytes and no frame, then a branch sending two: five bytes with
    no frame between them (seven when the next pass finds its byte queued): the transmit queue is
    sized to hold them (8), and the line sends them within the body's 100 ms."""
    text = ("serial 4800\nframe 20ms\nservo a = P1.0\npose p { a: 100 }\nhome p\nmain {\n  loop {\n    select {\n"
            '      on "x" { send "a"; send "b" }\n      meanwhile {\n        hold 100ms\n        send "1"\n'
            '        send "2"\n        send "3"\n      }\n    }\n  }\n}\n')
    assert flow.send_run(_plan(text)) == 7 and flow.tx_queue(_plan(text)) == 8
    assert "send-overrun" not in [c for c, _ in lint_codes(text)]
    fast = text.replace("serial 4800", "serial 1200").replace("hold 100ms", "hold 20ms")   # 7 bytes: 58 ms
    assert ("send-overrun", 9) in lint_codes(fast)    # at the first send
    cut_early = text.replace('        hold 100ms\n        send "1"\n        send "2"\n        send "3"\n',
                             '        send "1"\n        send "2"\n        hold 100ms\n')
    assert flow.send_run(_plan(cut_early)) == 4       # "1" "2" before the first frame, then "a" "b"


@pytest.mark.toolchain
def test_a_meanwhile_body_that_sends_verifies():
    text = ("serial 4800\nframe 20ms\nservo a = P1.0\npose p { a: 100 }\npose q { a: 140 }\nhome p\nmain {\n  loop {\n"
            '    select {\n      on "x" { send "a"; move p in 200ms }\n      meanwhile {\n        loop {\n'
            '          move q in 200ms\n          send "1"\n          move p in 200ms\n          send "2"\n'
            "        }\n      }\n    }\n  }\n}\n")
    plan, evs, trace = simulate_events(text, '0.9s "x"\n1.95s "x"\n', 150)
    choices, report = api.events_report(plan, trace, 150, evs)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:5]])
    sent = "".join(chr(b) for _, b in trace.sent)
    assert sent.count("a") == 2 and set(sent) <= set("12a"), sent


@pytest.mark.toolchain
def test_stagger_without_home_switches_on_the_first_move_servos():
    text = PAN + "stagger 50ms\nmain {\n  loop {\n    move rest in 300ms\n    move left in 1s\n  }\n}\n"
    built = build_text(text)
    p = built.plan
    assert p.startup == ((0, 1), (1, 6)) and len(p.power_up) == 3       # pan, 4 frames' hold, tilt
    frames = list(_take(expand(p), 40))
    assert frames[0].n == (122, None) and frames[4].n == (122, None) and frames[5].n == (122, 122)
    assert all(f.n == (122, 122) for f in frames[6:36])     # `move rest` then holds there for its 30 frames
    assert frames[36].n != (122, 122)
    report = api.verify(p, built.firmware, 60)
    assert report.ok, report.summary()
    assert build_text(PAN + "stagger 50ms\nmain {\n  hold 100ms\n  move rest in 300ms\n}\n").plan.startup == ()


def test_a_home_pose_that_leaves_servos_out_is_noted_at_the_move_that_sets_them():
    # `home` names pan only: tilt has no position at power-up, and the first move sets it at once
    text = "frame 10ms\nservo pan = P2.0\nservo tilt = P2.1\npose p { pan: 122 }\npose q { pan: 100, tilt: 90 }\n"
    _, diags = front_end_text(text + "home p\nmain {\n  move q in 1s\n}\n")
    (d,) = [d for d in diags if d.code == "no-home"]
    assert "`tilt` has no position yet (the `home` pose `p` leaves it out)" in d.message
    assert "`pan`" not in d.message and "add it to the pose `p`" in d.help
    _, diags = front_end_text(text.replace("{ pan: 122 }", "{ pan: 122, tilt: 60 }") + "home p\nmain {\n  move q in 1s\n}\n")
    assert not [d for d in diags if d.code == "no-home"]


@pytest.mark.parametrize("holds", [1, 2, 3, 5])
def test_every_statement_of_a_meanwhile_body_is_walked_after_equal_holds(holds):
    """The planner walks a meanwhile body statement by statement; each must be walked, however
    many statements before it leave the servos where they were (a walk once answered a later
    statement with an earlier one's result, and its moves went unchecked)."""
    text = ("frame 10ms\nservo a = P1.0\nservo b = P1.1\ninput button = P3.2\n"
            "pose p0 { a: 0, b: 0 }\npose p1 { a: 0, b: 5 }\npose p3 { a: 0, b: 0 }\n"
            "main {\n  move p0 in 1500ms\n  select {\n    on button { move p3 in 10ms }\n"
            f"    meanwhile {{ {'; '.join(['hold 10ms'] * holds)}; move p1 in 10ms }}\n  }}\n}}\n")
    codes = lint_codes(text)
    assert ("infeasible-speed", 12) in codes            # the body's own move, too fast from p0
    assert ("infeasible-speed", 11) in codes            # and the branch's, from where it leaves `b`
    p = _plan(text)
    select = next(s for s in p.main if isinstance(s, SelectStep))
    assert any(m.step is select.meanwhile[-1] for m in p.moves)


def test_verify_frames_counts_each_statement_of_main():
    """Statements of main that leave the state as it was are each counted (holds of 3 s and 5 s),
    up to the select, and 20 frames more."""
    from servoc.plan import verify_frames
    text = ("frame 10ms\nservo a = P1.0\nservo b = P1.1\ninput button = P3.2\npose p0 { a: 0, b: 0 }\n"
            "main {\n  move p0 in 100ms\n  hold 3s\n  hold 5s\n  select { on button { hold 10ms } }\n"
            "  loop { hold 1s }\n}\n")
    assert verify_frames(_plan(text)) == 10 + 300 + 500 + 20


UNDATED = """\
frame 10ms
servo a = P1.0
input b = P3.2
pose lo { a: 20 }
pose hi { a: 220 }
pose mid { a: 120 }
main {
  move lo
  select {
    on b { move mid }
    meanwhile { move hi in 2s }
  }
  hold 100ms
}
"""


@pytest.mark.toolchain
@pytest.mark.parametrize("at_ms, frames", [(15, 25), (505, 13), (1005, 1), (1505, 13), (1995, 25)])
def test_an_undated_move_after_a_cut_takes_the_frames_of_where_the_servo_is(at_ms, frames):
    """`move mid` without a duration after the sweep is cut: the firmware finds F from where `a`
    really is (near `mid`: one frame; at either end: the 25 frames 100 N need at 2.467 ms a DAV
    and 10 ms a frame), never from the farthest state. Every pulse exact in ucsim."""
    plan, choices, report = run(UNDATED, f"{at_ms / 1000}s b active\n", 260)
    start = UNDATED.index("move mid")
    golden = list(itertools.islice(expand(plan, choices), 260))
    assert sum(1 for f in golden if f.span.start == start) == frames


LEVEL_GAP = """\
serial 4800
servo a = P1.0
input go = P3.3
input stop = P3.2
pose mid { a: 90deg }
pose low { a: 60deg }
home mid
sequence q {
  select {
    on press go { move low }
    meanwhile {
      hold 300ms
      move mid in 500ms
    }
  }
}
main {
  play q
  select {
    on press stop { }
    meanwhile { play q }
  }
}
"""


def test_a_select_looks_at_its_level_while_the_levels_above_it_are_empty():
    # q's select has level 1 (q also plays inside a meanwhile body); played first from main, it
    # runs at level 1 while level 0 is empty: frame_w must still look at it every frame (it once
    # stopped at the first empty level, and `go` went unseen)
    from test_verify_observes import problems, watch
    b = build_text(LEVEL_GAP)
    assert sorted(flow.select_slots(b.plan).values()) == [0, 1]
    trace, report = watch(b, "0.1s go active\n", 150)
    assert report.ok, problems(report)
    edges = trace.pin_edges(1, 0)
    widths = [fall - rise for (rise, up), (fall, _) in zip(edges, edges[1:]) if up == 1]
    low = b.plan.program.target.width_cycles(81)                   # 60deg is N 81
    assert widths.index(low) * b.plan.period_us < 300_000          # low within 0.3 s: `go` taken at once
