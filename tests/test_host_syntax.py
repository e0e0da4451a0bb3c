"""The front end of `host ssc32`, the statement `host` and the servo option `channel K`.

Parse (where `host` and `channel` are words and where they are names), the checker's
errors and warnings with their code, line and column, `model.host_channel`, the
printer's round trip, and the language server's completion and hover.

Tests that lint a whole program with a `host` statement need the planner to know the
statement: they are the functions whose name contains `needs_planner`.
"""

from __future__ import annotations

import pytest

from servoc import api, lsp, model, nodes, syntax
from servoc.check import check
from servoc.diagnostics import Reporter
from servoc.printer import format_program
from servoc.source import SourceFile
from test_syntax import parse_ok, parse_text

HOST_PROGRAM = """\
target at89c52 clock 11.0592MHz
serial 9600
host ssc32
input stop = P3.2
servo pan = P1.0
servo tilt = P1.1 channel 5
pose rest { pan: 90deg, tilt: 90deg }
home rest
main {
  host until press stop
  move rest in 1s
}
"""


def syntax_error(text: str) -> tuple[int, int, str, str]:
    tree, rep, src = parse_text(text)
    assert tree is None and len(rep.diagnostics) == 1
    d = rep.diagnostics[0]
    assert d.code == "syntax-error"
    return (*src.line_col(d.span.start), d.message, d.help)


def run(text: str):
    tree, rep, src = parse_text(text)
    assert tree is not None, [d.message for d in rep.diagnostics]
    return check(tree, rep, "t.servo"), rep, src


def ok(text: str) -> model.Program:
    prog, rep, _ = run(text)
    assert prog is not None, [(d.code, d.message) for d in rep.diagnostics]
    return prog


def found(text: str) -> list[tuple[str, str, int, int]]:
    """(severity, code, line, col) of every error and warning, in source order."""
    _, rep, src = run(text)
    return [(d.severity.value, d.code, *src.line_col(d.span.start)) for d in rep.sorted()
            if d.severity.value != "note"]


def message(text: str, code: str) -> str:
    _, rep, _ = run(text)
    [d] = [d for d in rep.diagnostics if d.code == code]
    return d.message + " | " + d.help


def main_body(tree: nodes.Program) -> tuple:
    return next(i for i in tree.items if isinstance(i, nodes.MainDecl)).body


# ---- parse ------------------------------------------------------------------------------

def test_host_declaration_is_a_setting():
    tree = parse_ok("host ssc32\nmain {}\n")
    decl = tree.items[0]
    assert isinstance(decl, nodes.SettingDecl)
    assert (decl.word.text, decl.value.text) == ("host", "ssc32")
    assert (decl.span.start, decl.span.end) == (0, 10)


def test_host_statement_everywhere_a_statement_is():
    text = ('main {\n  host\n  host until press stop\n  select { on "a" {} meanwhile { host } }\n'
            '  repeat 2 { host }\n}\nsequence s { loop { host }; host until "x" }\n')
    tree = parse_ok(text)
    body = main_body(tree)
    assert isinstance(body[0], nodes.HostStmt) and text[body[0].span.start:body[0].span.end] == "host"
    until = body[1]
    assert isinstance(until, nodes.UntilStmt) and isinstance(until.stmt, nodes.HostStmt)
    assert text[until.span.start:until.span.end] == "host until press stop"
    assert isinstance(until.event, nodes.EdgeEvent) and until.event.input.text == "stop"
    meanwhile = body[2].branches[1]
    assert isinstance(meanwhile, nodes.MeanwhileBranch) and isinstance(meanwhile.body[0], nodes.HostStmt)
    assert isinstance(body[3].body[0], nodes.HostStmt)
    seq = next(i for i in tree.items if isinstance(i, nodes.SequenceDecl))
    assert isinstance(seq.body[0].body[0], nodes.HostStmt)
    assert isinstance(seq.body[1], nodes.UntilStmt) and isinstance(seq.body[1].stmt, nodes.HostStmt)


def test_channel_option():
    text = "servo a = P1.0 reverse channel 7 trim 2\n"
    (servo,) = parse_ok(text).items
    assert [type(o).__name__ for o in servo.options] == ["ReverseOption", "ChannelOption", "TrimOption"]
    opt = servo.options[1]
    assert opt.channel.value == 7 and opt.channel.unit == ""
    assert text[opt.span.start:opt.span.end] == "channel 7"


def test_host_channel_and_ssc32_are_no_keywords():
    assert not {"host", "channel", "ssc32"} & syntax.keywords()
    text = ("input host = P3.2\nservo channel = P1.0\nservo ssc32 = P1.1\npose home { channel: 1, ssc32: 2 }\n"
            "group host_g = channel, ssc32\nsequence host_s { move home }\n"
            "main { move home; wait host; host until host; play host_s }\n")
    tree = parse_ok(text)
    assert [i.name.text for i in tree.items[:3]] == ["host", "channel", "ssc32"]
    body = main_body(tree)
    assert isinstance(body[1], nodes.WaitStmt) and body[1].event.text == "host"
    assert isinstance(body[2].stmt, nodes.HostStmt) and body[2].event.text == "host"
    # a pose may be called `host` and moved to
    tree = parse_ok("pose host { a: 1 }\nmain { move host; host }\n")
    move, host = main_body(tree)
    assert isinstance(move, nodes.MoveStmt) and move.pose.text == "host" and isinstance(host, nodes.HostStmt)


def test_home_and_stagger_still_work():
    tree = parse_ok("pose home { a: 1 }\nhome home\nstagger 100ms\nhost ssc32\nmain {}\n")
    words = [i.word.text for i in tree.items if isinstance(i, nodes.SettingDecl)]
    assert words == ["home", "stagger", "host"]


@pytest.mark.parametrize("text,line,col,words", [
    ("main {\n  host ssc32\n}\n", 2, 8, "after `host`, found `ssc32`"),
    ("host\nmain {}\n", 1, 5, "expected the host protocol `ssc32` after `host`"),
    ("servo a = P1.0 channel\n", 1, 23, "a channel number 0..31 such as `3` after `channel`"),
    ("servo a = P1.0 channel -1\n", 1, 24, "negative"),
    ("servo a = P1.0 chanel 3\n", 1, 16, "`reverse` or `channel`"),
    ("main {\n  frame 6ms\n}\n", 2, 3, "`send` or `host`"),
    ("main { select { host } }\n", 1, 17, "a branch"),
])
def test_syntax_errors(text, line, col, words):
    got_line, got_col, msg, _ = syntax_error(text)
    assert (got_line, got_col) == (line, col), msg
    assert words in msg, msg


def test_host_ssc32_in_a_block_says_where_it_goes():
    _, _, _, help_ = syntax_error("main {\n  host ssc32\n}\n")
    assert "`host ssc32` is a declaration" in help_


# ---- the checker: errors and warnings ------------------------------------------------------

def test_a_program_with_host_and_channels_checks():
    prog = ok("serial 4800\nhost ssc32\nservo a = P1.0\nservo b = P2.3 channel 31\nservo c = P0.7\nmain {}\n")
    assert prog.host == "ssc32"
    assert [(s.name, s.channel_option) for s in prog.servos] == [("a", None), ("b", 31), ("c", None)]
    assert [model.host_channel(s) for s in prog.servos] == [0, 31, 23]
    assert prog.host_span.start == len("serial 4800\n")


def test_no_host():
    prog = ok("servo a = P1.0\nmain {}\n")
    assert prog.host is None and prog.servos[0].channel_option is None


def test_host_protocol_is_read_in_either_case():
    assert ok("serial 4800\nhost SSC32\nmain {}\n").host == "ssc32"


@pytest.mark.parametrize("text,expected,words", [
    ("serial 4800\nhost ssc_32\nmain {}\n", [("error", "unsupported-host", 2, 6)], "did you mean `host ssc32`?"),
    ("serial 4800\nhost maestro\nmain {}\n", [("error", "unsupported-host", 2, 6)], "servoc speaks `ssc32`"),
    ("serial 4800\nhost 9600\nmain {}\n", [("error", "unsupported-host", 2, 6)], "`serial 9600`"),
])
def test_unknown_protocol(text, expected, words):
    assert found(text) == expected
    assert words in message(text, "unsupported-host")


def test_host_needs_serial():
    text = "servo a = P1.0\nhost ssc32\npose p { a: 1 }\nmain { move p }\n"
    assert found(text) == [("error", "host-needs-serial", 2, 1)]
    said = message(text, "host-needs-serial")
    assert "`host ssc32`" in said and "`serial 9600`" in said
    # with a bad rate, `serial` is still declared: only the rate is wrong
    assert [c for _, c, *_ in found("serial 9600\nhost ssc32\nmain {}\n")] == ["bad-baud"]


def test_host_undeclared_at_every_host_statement():
    text = ("serial 4800\ninput stop = P3.2\nmain {\n  host\n  host until press stop\n"
            "  select { on \"a\" {} meanwhile { host } }\n}\nsequence s { host }\n")
    assert found(text) == [("error", "host-undeclared", 4, 3), ("error", "host-undeclared", 5, 3),
                           ("error", "host-undeclared", 6, 34), ("error", "host-undeclared", 8, 14)]
    _, rep, _ = run(text)
    assert all("add `host ssc32`" in d.help for d in rep.diagnostics)


def test_host_twice_is_a_duplicate_setting():
    assert found("serial 4800\nhost ssc32\nhost ssc32\nmain {}\n") == [("error", "duplicate-setting", 3, 1)]


def test_host_may_come_after_main():
    assert ok("serial 4800\nmain {}\nhost ssc32\n").host == "ssc32"


def test_channel_conflict_at_the_second_servo_naming_the_first():
    text = ("serial 4800\nhost ssc32\nservo pan = P1.0\nservo tilt = P2.0\n"
            "servo wrist = P1.3 channel 8\nservo grip = P0.2 channel 3\nmain {}\n")
    assert found(text) == [("error", "channel-conflict", 5, 20)]
    msg = message(text, "channel-conflict")
    assert "servo `wrist` is on host channel 8, which servo `tilt` already has" in msg
    assert "its pin P2.0 (line 4)" in msg
    # two explicit channels: at the second's option
    text = "serial 4800\nhost ssc32\nservo a = P1.0 channel 9\nservo b = P1.1 trim 1 channel 9\nmain {}\n"
    assert found(text) == [("error", "channel-conflict", 4, 23)]
    # the pin of the second gives the channel the first took with `channel`
    text = "serial 4800\nhost ssc32\nservo a = P1.0 channel 17\nservo b = P0.1\nmain {}\n"
    assert found(text) == [("error", "channel-conflict", 4, 11)]
    assert "`a` has channel 17 from `channel 17`" in message(text, "channel-conflict")


def test_no_channel_conflict_without_host_or_when_channels_differ():
    assert found("servo a = P1.0\nservo b = P2.0 channel 0\nmain {}\n") == [("warning", "channel-unused", 2, 16)]
    # `channel` moves a servo off the channel its pin would give
    ok("serial 4800\nhost ssc32\nservo a = P1.0 channel 8\nservo b = P2.0 channel 0\nmain {}\n")


def test_one_pin_twice_is_a_pin_conflict_only():
    codes = [c for _, c, *_ in found("serial 4800\nhost ssc32\nservo a = P1.0\nservo b = P1.0\nmain {}\n")]
    assert codes == ["pin-conflict"]


def test_channel_unused_warning():
    text = "servo a = P1.0 channel 3\nservo b = P1.1\npose p { a: 1, b: 1 }\nmain { move p }\n"
    prog, rep, _ = run(text)
    assert prog is not None and prog.servos[0].channel_option == 3
    assert found(text) == [("warning", "channel-unused", 1, 16)]
    assert "declares no `host`" in message(text, "channel-unused")


@pytest.mark.parametrize("value,code,col", [("32", "out-of-range", 24), ("2.5", "out-of-range", 24),
                                            ("100", "out-of-range", 24), ("3deg", "bad-unit", 24)])
def test_bad_channel(value, code, col):
    text = f"servo a = P1.0 channel {value}\nmain {{}}\n"
    assert found(text) == [("error", code, 1, col)]
    if code == "out-of-range":
        assert f"channel `{value}` is not a whole number 0..31" in message(text, code)


def test_channel_bounds_are_inclusive():
    prog = ok("serial 4800\nhost ssc32\nservo a = P1.0 channel 0\nservo b = P1.1 channel 31\nmain {}\n")
    assert [s.channel_option for s in prog.servos] == [0, 31]


def test_channel_twice_is_a_duplicate_option():
    assert found("servo a = P1.0 channel 3 channel 4\nmain {}\n") == \
        [("warning", "channel-unused", 1, 16), ("error", "duplicate-option", 1, 26)]


# ---- model.host_channel ----------------------------------------------------------------------

@pytest.mark.parametrize("port,bit,channel", [(1, 0, 0), (1, 7, 7), (2, 0, 8), (2, 7, 15), (0, 0, 16),
                                              (0, 7, 23)])
def test_host_channel_defaults(port, bit, channel):
    assert model.host_channel(model.Servo("s", port, bit)) == channel


def test_host_channel_explicit():
    assert model.host_channel(model.Servo("s", 1, 0, channel_option=31)) == 31
    assert model.host_channel(model.Servo("s", 0, 7, channel_option=0)) == 0
    # the firmware's pin order is not the host channel
    servo = model.Servo("s", 0, 3)
    assert servo.channel == 3 and model.host_channel(servo) == 19


def test_host_statement_model():
    stmt = model.Host()
    assert stmt == model.Host() and hash(stmt) == hash(model.Host())
    assert model.HOSTS == ("ssc32",)


# ---- printer ---------------------------------------------------------------------------------

def test_printer_round_trip_of_the_syntax():
    text = ('serial 4800;host ssc32 ; input stop = P3.2\nservo a = P1.0   channel 7 reverse\n'
            'pose p {a:1}\nmain { host until press stop; select { on "a" {} meanwhile { host } }; host }\n')
    printed = format_program(parse_ok(text))
    assert printed == (
        "serial 4800\n"
        "host ssc32\n"
        "\n"
        "input stop = P3.2\n"
        "\n"
        "servo a = P1.0 channel 7 reverse\n"
        "\n"
        "pose p { a: 1 }\n"
        "\n"
        "main {\n"
        "  host until press stop\n"
        "  select {\n"
        "    on \"a\" {}\n"
        "    meanwhile {\n"
        "      host\n"
        "    }\n"
        "  }\n"
        "  host\n"
        "}\n")
    assert format_program(parse_ok(printed)) == printed


def test_printer_round_trip_of_channels_through_the_checker():
    text = ("servo a = P1.0 channel 7\nservo b = P2.1 limit 10..200 channel 0 trim -1\npose p { a: 1, b: 20 }\n"
            "main { move p }\n")
    prog = ok(text)
    printed = format_program(parse_ok(text))
    assert "servo b = P2.1 limit 10..200 channel 0 trim -1\n" in printed
    assert ok(printed) == prog
    assert ok(printed.replace("channel 0", "channel 1")) != prog


def test_printer_round_trip_of_a_host_declaration_through_the_checker():
    text = "serial 4800\nhost ssc32\nservo a = P1.0 channel 3\npose p { a: 1 }\nmain { move p }\n"
    prog = ok(text)
    printed = format_program(parse_ok(text))
    assert ok(printed) == prog and prog.host == "ssc32"


# ---- the language server ----------------------------------------------------------------------

def labels(text: str, offset: int) -> list[str]:
    a = lsp.analyze("file:///t.servo", "t.servo", text)
    return [c.label for c in lsp.completion(a, offset)]


def test_completion_knows_host_channel_and_ssc32():
    text = "serial 4800\nhost \nservo a = P1.0 \nmain {\n  \n}\n"
    assert labels(text, text.index("host ") + 5) == ["ssc32"]
    anywhere = labels(text, text.index("main {\n  ") + 9)
    assert {"host", "channel", "move", "servo"} <= set(anywhere)


def test_hover_on_a_servo_shows_its_host_channel():
    text = ("serial 4800\nhost ssc32\nservo pan = P1.0\nservo tilt = P2.1 channel 5\npose p { pan: 1, tilt: 1 }\n"
            "main { move p }\n")
    a = lsp.analyze("file:///t.servo", "t.servo", text)
    assert a.program is not None and a.program.host == "ssc32"
    pan = lsp.hover(a, text.index("pan =") + 1).contents.value
    tilt = lsp.hover(a, text.index("tilt =") + 1).contents.value
    assert "host channel 0 (`host ssc32`, from its pin P1.0)" in pan
    assert "host channel 5 (`host ssc32`, from its `channel`)" in tilt


# ---- the `host` statement in the model -----------------------------------------------------------

def test_host_statement_in_the_model():
    prog = ok(HOST_PROGRAM)
    assert prog.host == "ssc32"
    (until, move) = prog.main
    assert isinstance(until, model.Select) and until.until and until.meanwhile == (model.Host(),)
    assert isinstance(move, model.Move)
    assert [model.host_channel(s) for s in prog.servos] == [0, 5]
    meanwhile = ok("serial 4800\nhost ssc32\nmain { select { on \"s\" {} meanwhile { host } }; host }\n")
    assert meanwhile.main[0].meanwhile == (model.Host(),) and meanwhile.main[1] == model.Host()


def test_round_trip_with_host_statements():
    prog = ok(HOST_PROGRAM)
    printed = format_program(parse_ok(HOST_PROGRAM))
    assert ok(printed) == prog


def test_host_errors_with_a_host_statement():
    text = "host ssc32\nservo a = P1.0\nservo b = P1.1 channel 0\nmain { host }\n"
    assert found(text) == [("error", "host-needs-serial", 1, 1), ("error", "channel-conflict", 3, 16)]
    assert [c for _, c, *_ in found("serial 4800\nhost ssc16\nmain { host }\n")] == ["unsupported-host"]


def test_the_language_server_reads_a_program_with_host_statements():
    a = lsp.analyze("file:///t.servo", "t.servo", HOST_PROGRAM)
    assert a.tree is not None
    sym = lsp.Symbols(a.tree)
    assert [n.span.start for n in sym.uses("stop")] == [HOST_PROGRAM.index("stop ="),
                                                       HOST_PROGRAM.index("stop\n  move")]
    hover = lsp.hover(a, HOST_PROGRAM.index("press stop") + 7)
    assert hover is not None and "input `stop`" in hover.contents.value


# ---- needs the planner to know the `host` statement ---------------------------------------------

def test_lint_of_a_host_program_is_clean_needs_planner():
    src = SourceFile("t.servo", HOST_PROGRAM)
    rep = Reporter(src)
    fe = api.front_end(src, rep)
    loud = [(d.code, d.message) for d in rep.diagnostics if d.severity.value != "note"]
    assert fe.plan is not None and loud == []


def test_host_until_with_sequences_and_moves_after_it_plans():
    # a `host until` whose HostStep carries the plays of the sequences, in a main whose move after it
    # gets its frames fixed by the plan (walk.rebuild once met HostStep without a body)
    text = ("target at89c52 clock 12MHz\nserial 4800\nhost ssc32\ninput stop = P3.2\nservo a = P1.0\n"
            "pose mid { a: 90deg }\npose low { a: 60deg }\nhome mid\nsequence dip {\n  move low\n  move mid\n}\n"
            "main {\n  host until press stop\n  move low\n}\n")
    source = SourceFile("p.servo", text)
    reporter = Reporter(source)
    fe = api.front_end(source, reporter)
    assert fe.plan is not None and not reporter.has_errors, [d.message for d in reporter.diagnostics]
