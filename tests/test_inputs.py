"""Inputs and serial commands, front end: parsing, checks, the planner's states and branch speed
checks, lint rules, the baud-rate rule, and the refusal to compile (the firmware comes later)."""

from __future__ import annotations

import itertools
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servoc import api, cli, nodes, syntax
from servoc.plan import Choice, expand
from servoc.steps import AfterBranch, OnBranch, SelectStep, SendStep, steps
from servoc.printer import format_program
from servoc.source import SourceFile
from servoc.target import CHIPS, DEFAULT, MHZ, Target, timer1_baud, working_bauds
from servoc.units import DEFAULT_T_DAV_US
from test_editors import has, is_keyword, node, one_token, tokenize  # noqa: F401  (node: a fixture)

HEAD = "serial 4800\ninput button = P3.2\nservo arm = P1.0\npose a { arm: 100 }\npose b { arm: 140 }\n"


def diagnose(text: str):
    src = SourceFile("t.servo", text)
    rep = api.Reporter(src)
    fe = api.front_end(src, rep)
    return fe, rep.sorted(), src


def errors(text: str) -> list[tuple[str, int, int]]:
    _, diags, src = diagnose(text)
    return [(d.code, *src.line_col(d.span.start)) for d in diags if d.is_error]


def found(text: str) -> list[tuple[str, int, int]]:
    _, diags, src = diagnose(text)
    return [(d.code, *src.line_col(d.span.start)) for d in diags if d.severity.value != "note"]


def plan_of(text: str):
    fe, diags, _ = diagnose(text)
    assert fe.plan is not None, [d.message for d in diags]
    return fe.plan


# ---- parsing ------------------------------------------------------------------------------

def test_parses_every_construct():
    text = (HEAD + "main {\n  select {\n    on button { send \"w\" }\n    on \"x\" { }\n    on 12 { move a }\n"
            "    after 2s { send 10 }\n  }\n  wait button\n  wait \"q\"\n  send 255\n}\n")
    rep = api.Reporter(SourceFile("t.servo", text))
    tree = syntax.parse(rep.source, rep)
    assert tree is not None and not rep.diagnostics
    inp = tree.items[1]
    assert isinstance(inp, nodes.InputDecl) and inp.pin.text == "P3.2" and inp.level is None
    assert isinstance(tree.items[0], nodes.SerialDecl) and tree.items[0].baud.value == 4800
    sel, w1, w2, snd = tree.items[-1].body
    assert [type(b).__name__ for b in sel.branches] == ["OnBranch", "OnBranch", "OnBranch", "AfterBranch"]
    assert sel.branches[0].event == nodes.Name("button", sel.branches[0].event.span)
    assert isinstance(sel.branches[1].event, nodes.StringLit) and sel.branches[1].event.text == "x"
    assert sel.branches[2].event.value == 12
    assert sel.branches[3].duration.unit == "s"
    assert isinstance(w1, nodes.WaitStmt) and isinstance(w2.event, nodes.StringLit) and snd.byte.value == 255
    # the printer writes it back so that it parses to the same program
    again = syntax.parse(SourceFile("u", format_program(tree)), api.Reporter(SourceFile("u", "")))
    assert format_program(again) == format_program(tree)
    assert "on \"x\" {}" in format_program(tree) and "input button = P3.2" in format_program(tree)


@pytest.mark.parametrize("word", ["select", "on", "after", "wait", "send", "input", "serial"])
def test_new_keywords_are_reserved(word):
    assert word in syntax.keywords()
    _, diags, src = diagnose(f"servo {word} = P1.0\n")
    assert diags[0].code == "syntax-error" and f"`{word}` is a keyword" in diags[0].message
    assert src.line_col(diags[0].span.start) == (1, 7)


def test_low_high_mode_are_names():
    assert not {"low", "high", "mode"} & syntax.keywords()
    text = ("input button = P3.2 high\nservo mode = P1.0\npose low { mode: 100 }\npose high { mode: 140 }\n"
            "main { wait button; move low; move high in 1s }\n")
    fe, diags, _ = diagnose(text)
    assert fe.plan is not None and not [d for d in diags if d.is_error]
    assert fe.program.inputs[0].active_high


def test_level_must_be_low_or_high():
    assert errors("input b = P3.2 medium\nservo arm = P1.0\npose a { arm: 1 }\nmain { wait b; move a }\n") == \
        [("syntax-error", 1, 16)]


@pytest.mark.parametrize("text, line, col, words", [
    ("main { select { on } }\n", 1, 20, "an input's name (or `press NAME`, `release NAME`), a byte"),
    ("main { send }\n", 1, 13, "a byte such as"),
    ("main { select { move a } }\n", 1, 17, "a branch"),
    ("main { wait \"x }\n", 1, 13, "no closing"),
    ("target \"at89c52\"\n", 1, 8, "no strings"),
])
def test_syntax_errors(text, line, col, words):
    _, diags, src = diagnose(text)
    assert [d.code for d in diags] == ["syntax-error"]
    assert src.line_col(diags[0].span.start) == (line, col) and words in diags[0].message


# ---- checks ------------------------------------------------------------------------------

BODY = "main { wait button; move a }\n"


@pytest.mark.parametrize("decls, expected", [
    ("input button = P1.0\nservo arm = P1.0\n", [("pin-conflict", 1, 16)]),
    ("input button = P3.2\ninput other2 = P3.2\nservo arm = P1.0\n", [("pin-conflict", 2, 16)]),
    ("input button = P3.2\ninput other = P3.3\nservo arm = P1.0\n", [("syntax-error", 2, 7)]),   # reserved
    ("serial 4800\ninput button = P3.0\nservo arm = P1.0\n", [("pin-conflict", 2, 16)]),
    ("serial 4800\ninput button = P3.1\nservo arm = P1.0\n", [("pin-conflict", 2, 16)]),
    ("input button = P3.0\nservo arm = P1.0\n", []),                 # without serial, RXD is a pin
    ("input button = P4.0\nservo arm = P1.0\n", [("bad-pin", 1, 16)]),
    ("input button = p3.2\nservo arm = P1.0\n", [("bad-pin", 1, 16)]),
    ("input button = P3.2\nservo arm = P3.3\n", [("bad-pin", 2, 13)]),  # servos stay on P0-P2
    ("input button = P3.2\nservo arm = P1.0\nsequence button { }\n", [("duplicate-name", 3, 10)]),
])
def test_pin_errors(decls, expected):
    assert errors(decls + "pose a { arm: 100 }\n" + BODY) == expected


@pytest.mark.parametrize("stmt, expected", [
    ("wait nobody", [("unknown-name", "nobody")]),
    ("wait b", [("wrong-kind", "b")]),
    ("wait 256", [("bad-byte", "256")]),
    ("wait 1.5", [("bad-byte", "1.5")]),
    ("wait 10ms", [("bad-byte", "10ms")]),
    ("wait \"\"", [("bad-byte", "\"")]),
    ("wait \"ab\"", [("bad-byte", "\"ab")]),
    ("wait \"\u00e9\"", [("bad-byte", "\"")]),
    ("send button", [("bad-byte", "button")]),
    ("send other", [("bad-byte", "other")]),
    ("send press button", [("bad-byte", "press")]),
    ("send stagger \"k\"", [("bad-byte", "stagger")]),
    ("send 0; send 255; send \"~\"; wait \" \"", []),
    ("select { after 1s { } }", [("bad-select", "select")]),
    ("select { on button { }; after 1s { }; after 2s { } }", [("bad-select", "after 2s")]),
    ("select { after 1s { }; on button { } }", [("bad-select", "after")]),
    ("select { on button { }; after 1deg { } }", [("bad-unit", "1deg")]),
])
def test_event_errors(stmt, expected):
    text = HEAD + "main {\n" + f"  {stmt}\n" + "}\n"
    assert errors(text) == [(code, 7, stmt.index(at) + 3) for code, at in expected]


def test_bytes_and_send_need_serial():
    text = "servo arm = P1.0\npose a { arm: 100 }\nmain {\n  wait \"g\"\n  move a\n  send 1\n}\n"
    assert errors(text) == [("no-serial", 4, 8), ("no-serial", 6, 3)]
    assert errors("serial 4800\n" + text) == []


def test_serial_once():
    assert errors("serial 4800\nserial 2400\nservo arm = P1.0\npose a { arm: 1 }\nmain { move a }\n") == \
        [("duplicate-setting", 2, 1)]


# ---- baud rates ------------------------------------------------------------------------------

def rate(th1: int, smod: int, target: Target) -> Fraction:
    return (1 << smod) * (Fraction(MHZ) / target.cycle_us) / (32 * (256 - th1))


@pytest.mark.parametrize("target, baud, ok", [
    (DEFAULT, 9600, False), (DEFAULT, 4800, True), (DEFAULT, 2400, True), (DEFAULT, 300, True),
    (DEFAULT, 19200, False),
    (Target(CHIPS["at89c52"], 11_059_200), 9600, True), (Target(CHIPS["at89c52"], 11_059_200), 57600, True),
    (Target(CHIPS["at89c52"], 11_059_200), 115200, False), (Target(CHIPS["at89c52"], 11_059_200), 38400, False),
    (Target(CHIPS["stc89c52rc"], 12 * MHZ, True), 9600, True),       # 6T halves the cycle
    (Target(CHIPS["stc89c52rc"], 12 * MHZ, False), 9600, False),
])
def test_timer1_rate(target, baud, ok):
    th1, smod, actual = timer1_baud(target, baud)
    assert 0 <= th1 <= 255 and smod in (0, 1) and actual == rate(th1, smod, target)
    # no other setting is closer
    best = min(abs(rate(t, s, target) - baud) for t in range(256) for s in (0, 1))
    assert abs(actual - baud) == best
    assert (abs(actual - baud) / baud <= Fraction(2, 100)) == ok


def test_11_0592_makes_9600_exactly():
    assert timer1_baud(Target(CHIPS["at89c52"], 11_059_200), 9600) == (253, 0, 9600)


def test_bad_baud_message_at_12mhz():
    text = "serial 9600\nservo arm = P1.0\npose a { arm: 1 }\nmain { move a; send 1 }\n"
    _, diags, src = diagnose(text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "bad-baud" and src.line_col(d.span.start) == (1, 8)
    assert "9600" in d.message and "nearest rates that work at 12 MHz: 4800, 2400" in d.message
    assert "11.0592 MHz crystal makes 9600 exactly" in d.help
    assert errors("target at89c52 clock 11.0592MHz\n" + text) == []
    assert errors("target stc89c52rc mode 6T\n" + text) == []
    assert working_bauds(DEFAULT) == [300, 600, 1200, 2400, 4800]


@pytest.mark.parametrize("baud", ["9600.5", "96ms", "0"])
def test_baud_must_be_a_whole_rate(baud):
    assert errors(f"serial {baud}\nservo arm = P1.0\npose a {{ arm: 1 }}\nmain {{ move a }}\n") == \
        [("bad-baud", 1, 8)]


# ---- the planner ---------------------------------------------------------------------------

def test_select_plan_steps_and_after_frames():
    p = plan_of(HEAD + "frame 20ms\nmain {\n  select {\n    on button { move a }\n    on \"w\" { send \"k\" }\n"
                "    after 1010ms { move b }\n  }\n}\n".replace("frame 20ms\n", ""))
    (sel,) = [s for s in steps(p) if isinstance(s, SelectStep)]
    assert [type(b) for b in sel.branches] == [OnBranch, OnBranch, AfterBranch]
    assert sel.branches[2].frames == int(Fraction(1010_000, p.period_us) + Fraction(1, 2))
    assert sel.branches[1].event.byte == ord("w") and sel.branches[0].event.input == "button"
    assert [s.byte for s in steps(p) if isinstance(s, SendStep)] == [ord("k")]
    assert p.total_frames is None


def states_of(p, pose_step_pose: str) -> set:
    return {tuple(m.n0 for m in inst.motions) for inst in p.moves if inst.step.pose == pose_step_pose}


def test_branches_start_from_every_reachable_state():
    text = ("serial 4800\nservo arm = P1.0\npose a { arm: 100 }\npose b { arm: 140 }\npose c { arm: 200 }\n"
            "sequence walk { move c in 2s }\n"
            "main {\n  move a\n  loop {\n    select {\n      on \"w\" { play walk }\n"
            "      on \"s\" { move b in 2s }\n      on \"x\" { }\n    }\n  }\n}\n")
    p = plan_of(text)
    assert states_of(p, "b") == {(100,), (140,), (200,)}
    assert states_of(p, "c") == {(100,), (140,), (200,)}


def test_repeat_layers_are_exact():
    # after 1 pass of the body the state is b or c; `move a` after the repeat sees only those
    text = ("serial 4800\nservo arm = P1.0\npose a { arm: 100 }\npose b { arm: 140 }\npose c { arm: 200 }\n"
            "main {\n  move a\n  repeat 3 { select { on \"1\" { move b in 2s } on \"2\" { move c in 2s } } }\n"
            "  move a in 2s\n}\n")
    p = plan_of(text.replace("} on", "}\n on").replace("{ select {", "{ select {\n").replace("} } }", "}\n}\n}"))
    assert states_of(p, "b") == {(100,), (140,), (200,)}
    assert {tuple(m.n0 for m in i.motions) for i in p.moves if i.step.pose == "a" and i.step.frames != 1
            and i.step.duration_us} == {(140,), (200,)}


def test_infeasible_speed_names_branch_and_state():
    text = ("serial 4800\nservo arm = P1.0\npose a { arm: 0 }\npose b { arm: 250 }\n"
            "sequence walk { move b }\n"
            "main {\n  move a\n  loop {\n    select {\n      on \"w\" { play walk }\n"
            "      on \"s\" { move a in 300ms }\n    }\n  }\n}\n")
    _, diags, src = diagnose(text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "infeasible-speed" and src.line_col(d.span.start) == (11, 16)
    assert 'after `on "s"` from the end of `walk`' in d.message
    assert d.secondary and src.line_col(d.secondary[0].span.start) == (11, 7)


def test_programs_without_selects_keep_their_messages():
    _, diags, _ = diagnose("servo arm = P1.0\npose a { arm: 0 }\npose b { arm: 250 }\nmain { move a; move b in 10ms }\n")
    (d,) = [d for d in diags if d.is_error]
    assert "after `on" not in d.message and " from " not in d.message and not d.secondary


def test_expand_follows_choices_and_waits_forever():
    text = ("serial 4800\nframe 10ms\nservo arm = P1.0\npose a { arm: 100 }\npose b { arm: 110 }\n"
            "main {\n  move a\n  select {\n    on \"w\" { move b in 30ms; send \"k\" }\n    after 50ms { move a }\n  }\n}\n")
    p = plan_of(text.replace("frame 10ms\n", "") .replace("serial 4800\n", "serial 4800\nframe 10ms\n"))
    none = [f.n[0] for f in itertools.islice(expand(p), 6)]
    assert none == [100] * 6
    got = list(itertools.islice(expand(p, [Choice(0, 2)]), 8))
    assert [f.n[0] for f in got] == [100, 100, 100, 103, 107, 110, 110, 110]
    assert [f.sent for f in got][:7] == [(), (), (), (), (), (), (ord("k"),)]
    after = [f.n[0] for f in itertools.islice(expand(p, [Choice(1)]), 8)]
    assert after == [100] * 8           # 1 + 5 frames of waiting, then `move a` (already there: 1 frame)
    at_last = [f.n[0] for f in itertools.islice(expand(p, [Choice(0, 5)]), 8)]
    assert at_last == [100] * 6 + [103, 107]   # the F-th look: its events come before `after`
    at_once = [f.n[0] for f in itertools.islice(expand(p, [Choice(0, 0)]), 5)]
    assert at_once == [100, 103, 107, 110, 110]  # the event was there as the select was reached: no frame of its own
    for late in (Choice(0, 6), Choice(0, -1)):  # past F; and a wait of less than nothing
        with pytest.raises(ValueError):
            list(itertools.islice(expand(p, [late]), 10))


# ---- lint -----------------------------------------------------------------------------------

def test_lint_rules():
    assert ("unused-input", 2, 1) in found(HEAD + "main { move a }\n")
    dup = HEAD + "main {\n  select {\n    on button { }\n    on button { move a }\n  }\n}\n"
    assert ("duplicate-event", 9, 8) in found(dup)
    same_byte = HEAD + "main {\n  wait button\n  select {\n    on \"A\" { }\n    on 65 { move a }\n  }\n}\n"
    assert ("duplicate-event", 10, 8) in found(same_byte)
    never = (HEAD + "main {\n  select {\n    on button { loop { move a in 1s; move b in 1s } }\n"
             "    after 1s { loop { move b in 1s; move a in 1s } }\n  }\n  move a\n}\n")
    assert ("unreachable", 11, 3) in found(never)
    left = never.replace("after 1s { loop { move b in 1s; move a in 1s } }", "after 1s { }")
    assert not [f for f in found(left) if f[0] == "unreachable"]
    assert ("empty-loop", 7, 3) in found(HEAD + "main {\n  loop { send \"k\" }\n}\n")
    assert not [f for f in found(HEAD + "main {\n  loop { wait button; send \"k\" }\n}\n") if f[0] == "empty-loop"]


def test_serial_programs_compile_verify_lint_and_plan(tmp_path, capsys):
    path = tmp_path / "p.servo"
    path.write_text(HEAD + "main {\n  move a\n  wait button\n  move b in 1s\n  send \"k\"\n}\n", encoding="utf-8")
    for command in ("compile", "verify"):
        rc = cli.main([command, str(path)])
        out, err = capsys.readouterr()
        assert rc == 0 and err == "" and "Traceback" not in out
    assert "OK (partial:" in out and "0 bytes sent checked" in out     # the button never comes: nothing is sent
    assert "never reached (`move b in 1s`)" in out and "waiting at the select at line 8 for `on button`" in out
    assert cli.main(["lint", str(path)]) == 0
    assert "runs as its events come" in capsys.readouterr().out
    assert cli.main(["plan", str(path)]) == 0
    out = capsys.readouterr().out
    assert "wait button" in out and 'send "k"' in out
    path.write_text("servo arm = P1.0\npose a { arm: 100 }\ninput b = P3.2\nmain {\n  move a\n  wait b\n}\n")
    assert cli.main(["compile", str(path)]) == 0        # inputs and selects are built; serial is not
    assert "error" not in capsys.readouterr().err


# ---- hypothesis: the speed lint flags exactly the moves too fast from some reachable state --------

POSES = {"p0": 0, "p1": 60, "p2": 125, "p3": 250}
DURS = [None, "20ms", "150ms", "400ms", "700ms"]


@st.composite
def programs(draw):
    """main: a first move, then a loop of a select whose branches each hold 0-2 moves."""
    move = st.tuples(st.sampled_from(sorted(POSES)), st.sampled_from(DURS))
    first = draw(move)
    branches = draw(st.lists(st.lists(move, max_size=2), min_size=1, max_size=3))
    return first, branches, draw(st.booleans())


def _text(first, branches, with_after) -> tuple[str, list[list[int]]]:
    """The program, and the line of each move of each branch."""
    lines = ["serial 4800", "frame 10ms", "servo arm = P1.0"] + [f"pose {n} {{ arm: {v} }}" for n, v in POSES.items()]
    lines += ["main {", f"  move {first[0]}" + (f" in {first[1]}" if first[1] else ""), "  loop {", "    select {"]
    heads = [f'on "{i}"' for i in range(len(branches))]
    if with_after and len(heads) > 1:        # a select needs an `on`
        heads[-1] = "after 100ms"
    where = []
    for head, body in zip(heads, branches):
        lines.append(f"      {head} {{")
        where.append([])
        for pose, dur in body:
            lines.append(f"        move {pose}" + (f" in {dur}" if dur else ""))
            where[-1].append(len(lines))
        lines.append("      }")
    lines += ["    }", "    hold 10ms", "  }", "}"]
    return "\n".join(lines) + "\n", where


def _too_fast_lines(first, branches, where) -> set[int]:
    """Independently: the positions the select can be reached in (a search over the branches: each
    pass of the loop runs one), then every timed branch move checked from each of them."""
    period = 10_000

    def frames(dur):
        return max(1, int(Fraction(int(dur[:-2]) * 1000, period) + Fraction(1, 2)))
    states, todo = {POSES[first[0]]}, [POSES[first[0]]]
    while todo:
        s = todo.pop()
        for body in branches:
            n = body[-1] if body else None
            end = s if n is None else POSES[n[0]]
            if end not in states:
                states.add(end)
                todo.append(end)
    bad = set()
    for body, lines in zip(branches, where):
        for s in states:
            n = s
            for (pose, dur), line in zip(body, lines):
                if dur is not None and abs(POSES[pose] - n) * DEFAULT_T_DAV_US > frames(dur) * period:
                    bad.add(line)
                n = POSES[pose]
    return bad


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs())
def test_speed_lint_flags_exactly_the_moves_too_fast_from_a_reachable_state(prog):
    first, branches, with_after = prog
    text, where = _text(first, branches, with_after)
    expected = _too_fast_lines(first, branches, where)   # the first move sets the servo at once: never too fast
    got = {line for code, line, _ in found(text) if code == "infeasible-speed"}
    assert got == expected, text


def test_the_expectation_can_flag():
    # the independent expectation is not trivially empty: from p0, `move p3 in 20ms` is too fast
    text, where = _text(("p0", None), [[("p3", "20ms")]], False)
    assert _too_fast_lines(("p0", None), [[("p3", "20ms")]], where) == {where[0][0]}
    assert {line for code, line, _ in found(text) if code == "infeasible-speed"} == {where[0][0]}


# ---- editors -----------------------------------------------------------------------------------

def test_textmate_grammar_knows_inputs(node):
    lines = tokenize(node, 'input pir = P3.2 high\npose low { arm: 1 }\nmain { select { on "w" { send 10 } } }\n')
    assert is_keyword(one_token(lines[0], "input")) and has(one_token(lines[0], "P3.2"), "constant.other.pin")
    assert is_keyword(one_token(lines[0], "high"))
    assert not is_keyword(one_token(lines[1], "low"))
    for word in ("select", "on", "send"):
        assert is_keyword(one_token(lines[2], word)), word
    assert has(one_token(lines[2], '"w"'), "string")
