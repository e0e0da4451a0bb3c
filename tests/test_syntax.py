"""servoc.syntax: text -> nodes.Program, and its syntax-error messages."""

from __future__ import annotations

import re
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servoc import nodes, syntax
from servoc.check import check
from servoc.diagnostics import Reporter
from servoc.source import SourceFile

SPEC_EXAMPLE = Path(__file__).parent / "fixtures" / "spec_example.servo"


def parse_text(text: str):
    src = SourceFile("t.servo", text)
    rep = Reporter(src)
    return syntax.parse(src, rep), rep, src


def parse_ok(text: str) -> nodes.Program:
    tree, rep, _ = parse_text(text)
    assert tree is not None, [d.message for d in rep.diagnostics]
    assert rep.diagnostics == []
    return tree


def syntax_error(text: str):
    """The one diagnostic of a text that does not parse: (line, col, message, help)."""
    tree, rep, src = parse_text(text)
    assert tree is None
    assert len(rep.diagnostics) == 1
    d = rep.diagnostics[0]
    assert d.code == "syntax-error" and d.is_error
    line, col = src.line_col(d.span.start)
    return line, col, d.message, d.help


def snippet(text: str, node) -> str:
    return text[node.span.start:node.span.end]


# ---- the spec's example -----------------------------------------------------

def test_spec_example_parses_into_items_in_order():
    text = SPEC_EXAMPLE.read_text()
    tree = parse_ok(text)
    kinds = [type(i).__name__ for i in tree.items]
    assert kinds == ["TargetDecl", "FrameDecl"] + ["ServoDecl"] * 5 + ["GroupDecl"] + ["PoseDecl"] * 3 + [
        "SequenceDecl", "MainDecl"]
    target, frame = tree.items[0], tree.items[1]
    assert target.chip.text == "at89c52" and target.clock == nodes.Quantity(Fraction(12), "MHz", target.clock.span)
    assert frame.period.value == 6 and frame.period.unit == "ms"


def test_spec_example_servo_options():
    text = SPEC_EXAMPLE.read_text()
    tree = parse_ok(text)
    servos = {i.name.text: i for i in tree.items if isinstance(i, nodes.ServoDecl)}
    knee = servos["knee_l"]
    (speed,) = knee.options
    assert isinstance(speed, nodes.SpeedOption)
    assert (speed.duration.value, speed.duration.unit) == (Fraction(1, 4), "s")
    assert (speed.angle.value, speed.angle.unit) == (60, "deg")
    ankle = servos["ankle_l"]
    trim, limit = ankle.options
    assert isinstance(trim, nodes.TrimOption) and trim.value.value == -2 and trim.value.unit == ""
    assert isinstance(limit, nodes.LimitOption)
    assert (limit.low.value, limit.low.unit, limit.high.value, limit.high.unit) == (20, "deg", 160, "deg")
    assert [type(o) for o in servos["hip_r"].options] == [nodes.ReverseOption]
    assert servos["wrist"].pin.text == "P0.0"


def test_spec_example_spans():
    text = SPEC_EXAMPLE.read_text()
    tree = parse_ok(text)
    servo = next(i for i in tree.items if isinstance(i, nodes.ServoDecl) and i.name.text == "ankle_l")
    assert snippet(text, servo) == "servo ankle_l = P1.2 trim -2 limit 20deg..160deg"
    assert snippet(text, servo.options[0]) == "trim -2"
    assert snippet(text, servo.options[0].value) == "-2"
    lean = next(i for i in tree.items if isinstance(i, nodes.PoseDecl) and i.name.text == "lean")
    assert lean.base.text == "stand"
    assert snippet(text, lean.entries[0]) == "ankle_l: 80deg"
    squat = next(i for i in tree.items if isinstance(i, nodes.SequenceDecl))
    assert [snippet(text, s) for s in squat.body] == ["move crouch in 400ms", "hold 200ms", "move stand"]
    main = tree.items[-1]
    assert snippet(text, main.body[1]) == "repeat 3 { play squat }"
    loop = main.body[2]
    assert isinstance(loop, nodes.LoopStmt)
    assert snippet(text, loop.body[0]) == "move lean in 300ms ease in-out"
    assert loop.body[0].ease == "in-out"
    assert snippet(text, main)[:6] == "main {" and snippet(text, main).endswith("}")


ALL_FORMS = """\
target stc89c52 clock 11.0592MHz mode 6
frame 6ms
serial 9600
input go = P3.2 low
servo a = P1.0 speed 0.2s/60deg trim +1 limit 10deg..170deg reverse
servo b = P1.1
group g = a,
  b
pose p { a: 10deg, b: 1500us }
pose q = p with {
  a: 20
}
sequence s { move q in 300ms ease in-out; hold 1s }
main {
  send "R"
  select {
    on go { play s }
    on "w" { repeat 2 { move p } }
    after 2s { loop { wait 119 } }
  }
}
"""


def _spanned(node):
    """Every node under `node` that has a span, with its parent."""
    stack = [(node, None)]
    while stack:
        n, parent = stack.pop()
        if isinstance(n, tuple):
            stack += [(c, parent) for c in n]
            continue
        if not hasattr(n, "__dataclass_fields__"):
            continue
        if hasattr(n, "span"):
            yield n, parent
            parent = n
        stack += [(getattr(n, f), parent) for f in n.__dataclass_fields__ if f != "span"]


def test_every_node_spans_its_own_text():
    tree = parse_ok(ALL_FORMS)
    seen = set()
    for n, parent in _spanned(tree):
        text = snippet(ALL_FORMS, n)
        seen.add(type(n).__name__)
        assert text and text == text.strip(), (n, text)
        if parent is not None:
            assert parent.span.start <= n.span.start <= n.span.end <= parent.span.end, (n, parent)
    assert {"TargetDecl", "FrameDecl", "SerialDecl", "InputDecl", "ServoDecl", "SpeedOption", "TrimOption",
            "LimitOption", "ReverseOption", "GroupDecl", "PoseDecl", "Entry", "SequenceDecl", "MainDecl",
            "MoveStmt", "HoldStmt", "RepeatStmt", "LoopStmt", "PlayStmt", "SelectStmt", "OnBranch",
            "AfterBranch", "WaitStmt", "SendStmt", "StringLit", "Name", "Quantity", "Pin"} <= seen
    items = {type(i).__name__ + (i.name.text if hasattr(i, "name") else ""): i for i in tree.items}
    assert snippet(ALL_FORMS, items["TargetDecl"]) == "target stc89c52 clock 11.0592MHz mode 6"
    assert snippet(ALL_FORMS, items["ServoDecla"]).endswith("limit 10deg..170deg reverse")
    assert snippet(ALL_FORMS, items["GroupDeclg"]) == "group g = a,\n  b"
    assert snippet(ALL_FORMS, items["PoseDeclq"]) == "pose q = p with {\n  a: 20\n}"
    seq = items["SequenceDecls"]
    assert [snippet(ALL_FORMS, st) for st in seq.body] == ["move q in 300ms ease in-out", "hold 1s"]
    select = items["MainDecl"].body[1]
    assert snippet(ALL_FORMS, select).startswith("select {") and snippet(ALL_FORMS, select).endswith("}\n  }")
    assert [snippet(ALL_FORMS, b)[:8] for b in select.branches] == ["on go { ", 'on "w" {', "after 2s"]
    assert snippet(ALL_FORMS, select.branches[2].body[0]) == "loop { wait 119 }"


def test_braces_open_at_once_are_limited():
    ok = "main {" + "loop {" * (syntax.MAX_NESTING - 1) + "}" * syntax.MAX_NESTING
    parse_ok(ok)
    text = "main {" + "select { on x {" * (syntax.MAX_NESTING // 2) + "}}" * (syntax.MAX_NESTING // 2) + "}"
    _, col, message, _ = syntax_error(text)
    assert "nested too deeply" in message
    braces = [i for i, c in enumerate(text) if c == "{"]
    assert len(braces) > syntax.MAX_NESTING and col == braces[syntax.MAX_NESTING] + 1   # the first one too many


# ---- lexical details --------------------------------------------------------

def test_semicolons_blank_lines_and_comments():
    text = "\n\n# only a comment\nservo a = P1.0 ; servo b = P1.1 # two on a line\n\n\nmain { ; move p ; hold 1s ;\n\n}\n"
    tree = parse_ok(text)
    assert [type(i) for i in tree.items] == [nodes.ServoDecl, nodes.ServoDecl, nodes.MainDecl]
    assert [type(s) for s in tree.items[2].body] == [nodes.MoveStmt, nodes.HoldStmt]


def test_pose_entries_commas_newlines_trailing_comma():
    text = "pose p {\n  a: 1,\n  b: 2\n\n  c: 3,\n}\npose e {}\npose f {\n}\n"
    tree = parse_ok(text)
    p, e, f = tree.items
    assert [x.target.text for x in p.entries] == ["a", "b", "c"]
    assert e.entries == () and f.entries == ()


def test_group_list_may_continue_after_comma():
    tree = parse_ok("group g = a,\n  b, c\n")
    assert [m.text for m in tree.items[0].members] == ["a", "b", "c"]


def test_numbers_are_exact_fractions():
    tree = parse_ok("frame 0.1ms\n")
    assert tree.items[0].period.value == Fraction(1, 10)
    assert isinstance(tree.items[0].period.value, Fraction)


def test_micro_sign_is_us_and_options_in_any_order():
    tree = parse_ok("servo a = P1.0 reverse limit 10..20 trim +3 speed 100ms/30deg\npose p { a: 1500µs }\n")
    servo, pose = tree.items
    assert [type(o).__name__ for o in servo.options] == ["ReverseOption", "LimitOption", "TrimOption", "SpeedOption"]
    assert servo.options[2].value.value == 3
    assert pose.entries[0].position.unit == "us"


def test_move_forms():
    tree = parse_ok("main {\n move a\n move a in 1s\n move a in 1s ease linear\n move a in 2s ease out\n}")
    moves = tree.items[0].body
    assert [(m.duration is None, m.ease) for m in moves] == [(True, None), (False, None), (False, "linear"),
                                                            (False, "out")]


def test_statement_block_on_one_line_and_nested():
    tree = parse_ok("sequence s { repeat 2 { loop { play t } } }")
    rep = tree.items[0].body[0]
    assert isinstance(rep, nodes.RepeatStmt) and rep.count.value == 2
    assert isinstance(rep.body[0], nodes.LoopStmt)
    assert isinstance(rep.body[0].body[0], nodes.PlayStmt)


def test_lowercase_pin_is_left_to_the_checker():
    tree = parse_ok("servo a = p1.0\n")
    assert tree.items[0].pin.text == "p1.0"


def test_keyword_set():
    kws = syntax.keywords()
    for word in ("servo", "group", "pose", "sequence", "main", "frame", "target", "clock", "speed", "trim",
                 "limit", "reverse", "with", "move", "in", "ease", "hold", "repeat", "loop", "play",
                 "linear", "out"):
        assert word in kws


@pytest.mark.parametrize("word", ["main", "servo", "move", "in", "loop", "linear", "out", "with", "clock"])
def test_keywords_cannot_be_names(word):
    line, col, message, _ = syntax_error(f"servo {word} = P1.0\n")
    assert (line, col) == (1, 7)
    assert f"`{word}` is a keyword" in message


def test_keyword_as_reference_is_a_syntax_error():
    line, col, message, _ = syntax_error("main {\n  play loop\n}\n")
    assert (line, col) == (2, 8)
    assert "`loop` is a keyword" in message


def test_names_that_contain_keywords_are_fine():
    tree = parse_ok("servo mainloop = P1.0\nservo in_out = P1.1\npose moves { mainloop: 1 }\n")
    assert [i.name.text for i in tree.items] == ["mainloop", "in_out", "moves"]


# ---- syntax errors ----------------------------------------------------------

ERRORS = [
    # (text, line, col, words the message must contain)
    ("pose p { a: }\n", 1, 13, "expected a position such as `90deg`, `1500us` or a raw N after `:`"),
    ("frame 6ms 7ms\n", 1, 11, "expected a newline or `;` after the statement"),
    ("}\n", 1, 1, "unexpected `}`"),
    ("servo a = hip\n", 1, 11, "a pin such as `P1.0`"),
    ("servo a = P1.0 fast\n", 1, 16, "a servo option"),
    ("pose p { a 90deg }\n", 1, 12, "expected `:`"),
    ("pose p { a: -5 }\n", 1, 13, "negative"),
    ("main {\n  move p 300ms\n}\n", 2, 10, "expected `in` before the duration"),
    ("main {\n  move p in 300ms ease fast\n}\n", 2, 24, "an easing"),
    ("main {\n  hold\n}\n", 2, 7, "a duration such as `300ms`"),
    ("main {\n  move p in 1s\n", 2, 15, "the `}` that closes the block opened at line 1"),
    ("frame\n", 1, 6, "a frame period"),
    ("main {\n  repeat { }\n}\n", 2, 10, "a repeat count"),
    ('target "at89c52"\n', 1, 8, "no strings"),
    ("pose p { a: .5 }\n", 1, 13, "unexpected `.`"),
    ("servo a = P1.0 speed 0.25s 60deg\n", 1, 28, "`/`"),
    ("servo a = P1.0 limit 10deg 20deg\n", 1, 28, "`..`"),
    ("target at89c52 clock\n", 1, 21, "a clock frequency"),
    ("mainloop {\n}\n", 1, 1, "a declaration"),
    ("main {\n  frame 6ms\n}\n", 2, 3, "a statement"),
    ("servo a = P1.0\x00\n", 1, 15, "U+0000"),
    ("pose p { a: 1 } }\n", 1, 17, "`}`"),
    ("group g = a b\n", 1, 13, "expected `,`"),
    ("pose p = q { a: 1 }\n", 1, 12, "`with`"),
    ("main { play }\n", 1, 13, "the name of a sequence"),
]


@pytest.mark.parametrize("text,line,col,words", ERRORS)
def test_syntax_error_position_and_message(text, line, col, words):
    got_line, got_col, message, _ = syntax_error(text)
    assert (got_line, got_col) == (line, col), message
    assert words in message


def _terminal_names() -> set[str]:
    return {t.name for t in syntax._parser().terminals} | {"$END", "_NL"}


def assert_human(message: str) -> None:
    assert "__ANON" not in message and "$END" not in message
    assert "Token(" not in message and "Tree(" not in message
    terminals = _terminal_names()
    outside_quotes = re.sub(r"`[^`]*`", "", message)     # quoted user text may be anything
    for word in re.findall(r"[A-Z_$][A-Z0-9_]+", outside_quotes):
        assert word not in terminals, f"lark terminal name {word!r} in {message!r}"


@pytest.mark.parametrize("text", [e[0] for e in ERRORS])
def test_messages_have_no_lark_names(text):
    _, _, message, help_ = syntax_error(text)
    assert_human(message)
    assert_human(help_)


def test_too_many_digits_is_a_syntax_error():
    line, col, message, _ = syntax_error("servo a = P1.0 trim 1" + "0" * 5000 + "\n")
    assert (line, col) == (1, 21)
    assert "too many digits" in message


def test_deep_nesting_is_refused_not_a_crash():
    text = "main {" + "loop {" * 5000 + "}" * 5001
    _, _, message, _ = syntax_error(text)
    assert "nested" in message


def test_byte_order_mark_and_crlf_are_whitespace():
    tree = parse_ok("\ufeffservo a = P1.0\r\nmain {\r\n  move p\r\n}\r\n")
    assert [type(i) for i in tree.items] == [nodes.ServoDecl, nodes.MainDecl]


def test_moderate_nesting_parses():
    depth = syntax.MAX_NESTING - 1
    tree = parse_ok("main {" + "loop {" * depth + "}" * (depth + 1))
    assert isinstance(tree.items[0].body[0], nodes.LoopStmt)


def test_unclosed_deep_nesting_is_one_error():
    _, _, message, _ = syntax_error("main {" * 3000)
    assert_human(message)


# ---- nothing raises ---------------------------------------------------------

def _never_raises(text: str) -> None:
    src = SourceFile("t.servo", text)
    rep = Reporter(src)
    tree = syntax.parse(src, rep)
    if tree is None:
        assert [d.code for d in rep.diagnostics] == ["syntax-error"]
        d = rep.diagnostics[0]
        assert 0 <= d.span.start <= d.span.end <= len(text)
        assert_human(d.message)
    else:
        check(tree, rep, "t.servo")


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet=st.characters(min_codepoint=0, max_codepoint=0x7F), max_size=200))
def test_random_ascii_never_raises(text):
    _never_raises(text)


@settings(max_examples=100, deadline=None)
@given(st.text(max_size=200))
def test_random_unicode_never_raises(text):
    _never_raises(text)


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=200))
def test_random_bytes_never_raise(data):
    _never_raises(data.decode("utf-8", errors="replace"))


TOKENS = ["servo", "group", "pose", "sequence", "main", "frame", "target", "clock", "speed", "trim", "limit",
          "reverse", "with", "move", "in", "ease", "hold", "repeat", "loop", "play", "linear", "out", "in-out",
          "a", "b", "P1", "P1.0", "p2.3", "90deg", "1500us", "0.25s", "12MHz", "3", "-", "..", "/", ":", ",",
          "=", "{", "}", ";", "\n", " ", "#c\n", "1.5", "9" * 80]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from(TOKENS), max_size=40))
def test_random_token_soup_never_raises(tokens):
    _never_raises(" ".join(tokens))
