"""servoc.diagnostics: the header, caret display, help line, summary and JSON."""

from __future__ import annotations

import json

from servoc.diagnostics import (SHOWN_COLUMNS, Diagnostic, Label, Reporter, Severity, render_full, render_short, summary,
                                to_json)
from servoc.source import NO_SPAN, SourceFile, Span

TEXT = "servo arm = P1.0\npose up { arm: 120 }\nmain {\n  move up in 20ms\n}\n"


def diag(span: Span, severity=Severity.ERROR, label: str = "", help: str = "", code: str = "test-code",
         message: str = "something is wrong") -> Diagnostic:
    return Diagnostic(code, severity, message, span, label, help)


def at(text: str, needle: str, occurrence: int = 0) -> Span:
    start = -1
    for _ in range(occurrence + 1):
        start = text.index(needle, start + 1)
    return Span(start, start + len(needle))


def test_header_and_caret_under_the_span():
    src = SourceFile("arm.servo", TEXT)
    d = diag(at(TEXT, "move up in 20ms"), label="too fast", help="use `in 300ms`")
    assert render_full(d, src) == (
        "arm.servo:4:3: error: something is wrong [test-code]\n"
        "   4 |   move up in 20ms\n"
        "     |   ^^^^^^^^^^^^^^^ too fast\n"
        "     = help: use `in 300ms`")


def test_render_short_is_the_spec_format():
    src = SourceFile("arm.servo", TEXT)
    assert render_short(diag(at(TEXT, "120"), Severity.WARNING), src) == \
        "arm.servo:2:16: warning: something is wrong [test-code]"


def test_caret_width_is_the_span_width():
    src = SourceFile("arm.servo", TEXT)
    out = render_full(diag(at(TEXT, "arm", 1)), src).splitlines()
    assert out[0].startswith("arm.servo:2:11: ")
    assert out[1] == "   2 | pose up { arm: 120 }"
    assert out[2] == "     |           ^^^"
    assert len(out) == 3      # no help line without help


def test_empty_span_gets_one_caret():
    src = SourceFile("arm.servo", TEXT)
    start = TEXT.index("20ms")
    out = render_full(diag(Span(start, start)), src).splitlines()
    assert out[0].startswith("arm.servo:4:14: ")
    assert out[2] == "     |" + " " * 14 + "^"


def test_tabs_keep_the_caret_aligned():
    text = "main {\n\tmove\tup\n}\n"
    src = SourceFile("t.servo", text)
    out = render_full(diag(at(text, "up")), src).splitlines()
    # a tab is one column, shown as one space
    assert out[0].startswith("t.servo:2:7: ")
    assert out[1] == "   2 |  move up"
    assert out[2] == "     |       ^^"
    assert out[1].index("up") == out[2].index("^")


def test_control_characters_are_not_printed():
    text = "pose p { a: 1\x1b[31m }\r\nmain {}\r\n"
    src = SourceFile("t.servo", text)
    out = render_full(diag(at(text, "[31m")), src).splitlines()
    assert "\x1b" not in "".join(out) and "\r" not in "".join(out)
    assert out[1] == "   1 | pose p { a: 1\ufffd[31m }" + " "
    assert out[1].index("[") == out[2].index("^")


def test_span_over_several_lines_underlines_the_first_line():
    text = "sequence s {\n  move p\n}\n"
    src = SourceFile("t.servo", text)
    out = render_full(diag(Span(0, len(text) - 1), label="declared here"), src).splitlines()
    assert out[1] == "   1 | sequence s {"
    assert out[2] == "     | ^^^^^^^^^^^^ declared here"


def test_span_at_end_of_file_without_newline():
    text = "main {\n  move p"
    src = SourceFile("t.servo", text)
    end = len(text)
    out = render_full(diag(Span(end, end)), src).splitlines()
    assert out[0].startswith("t.servo:2:9: ")
    assert out[1] == "   2 |   move p"
    assert out[2] == "     |" + " " * 9 + "^"


def test_span_at_end_of_file_after_newline():
    text = "main {\n"
    src = SourceFile("t.servo", text)
    out = render_full(diag(Span(len(text), len(text))), src).splitlines()
    assert out[0].startswith("t.servo:2:1: ")
    assert out[1] == "   2 | "
    assert out[2] == "     | ^"


def test_span_past_the_end_is_clamped():
    text = "main {"
    src = SourceFile("t.servo", text)
    out = render_full(diag(Span(4, 40)), src).splitlines()
    assert out[0].startswith("t.servo:1:5: ")
    assert out[2] == "     |     ^^"


def test_empty_file():
    src = SourceFile("empty.servo", "")
    out = render_full(diag(Span(0, 0), help="add `main { ... }`"), src)
    assert out == ("empty.servo:1:1: error: something is wrong [test-code]\n"
                   "     = help: add `main { ... }`")


def test_no_span_has_no_source_line():
    src = SourceFile("arm.servo", TEXT)
    out = render_full(diag(NO_SPAN, help="h"), src).splitlines()
    assert out == ["arm.servo:1:1: error: something is wrong [test-code]", "     = help: h"]


def test_line_numbers_above_9999_keep_the_gutter_aligned():
    text = "\n" * 12345 + "move p\n"
    src = SourceFile("t.servo", text)
    out = render_full(diag(at(text, "p")), src).splitlines()
    assert out[1] == "12346 | move p"
    assert out[2] == "      |      ^"


def test_wide_text_before_the_span_counts_characters():
    text = "pose p { a: 1 } # µ°é\nmove x\n"
    src = SourceFile("t.servo", text)
    assert render_short(diag(at(text, "x")), src).startswith("t.servo:2:6: ")
    line1 = render_full(diag(at(text, "é")), src).splitlines()
    assert line1[0].startswith("t.servo:1:21: ")
    assert line1[1].index("é") == line1[2].index("^")


def test_color_only_when_asked():
    src = SourceFile("arm.servo", TEXT)
    d = diag(at(TEXT, "up"), Severity.WARNING, help="h")
    plain = render_full(d, src, color=False)
    painted = render_full(d, src, color=True)
    assert "\x1b[" not in plain
    assert "\x1b[1;33mwarning\x1b[0m" in painted
    assert painted.replace("\x1b[1;33m", "").replace("\x1b[1;34m", "").replace("\x1b[0m", "") == plain


def test_summary_counts_and_plurals():
    assert summary([]) == "0 errors, 0 warnings, 0 notes"
    ds = [diag(NO_SPAN), diag(NO_SPAN, Severity.WARNING), diag(NO_SPAN, Severity.WARNING),
          diag(NO_SPAN, Severity.NOTE)]
    assert summary(ds) == "1 error, 2 warnings, 1 note"


def test_reporter_sorts_by_position_and_knows_errors():
    src = SourceFile("arm.servo", TEXT)
    rep = Reporter(src)
    rep.warning("w", "second", at(TEXT, "main"))
    assert not rep.has_errors
    rep.note("n", "first", at(TEXT, "servo"))
    rep.error("e", "third", at(TEXT, "move"))
    assert rep.has_errors
    assert [d.message for d in rep.sorted()] == ["first", "second", "third"]
    assert [d.severity for d in rep.sorted()] == [Severity.NOTE, Severity.WARNING, Severity.ERROR]


def test_json():
    src = SourceFile("arm.servo", TEXT)
    ds = [diag(at(TEXT, "move up in 20ms"), label="too fast", help="use `in 300ms`", code="infeasible-speed",
               message="servo `arm` cannot move"),
          diag(NO_SPAN, Severity.NOTE)]
    data = json.loads(to_json(ds, src))
    assert data["summary"] == {"errors": 1, "warnings": 0, "notes": 1}
    first, second = data["diagnostics"]
    assert first == {"file": "arm.servo", "line": 4, "column": 3, "end_line": 4, "end_column": 18,
                     "severity": "error", "code": "infeasible-speed", "message": "servo `arm` cannot move",
                     "label": "too fast", "help": "use `in 300ms`"}
    assert (second["line"], second["column"], second["severity"]) == (1, 1, "note")


def test_json_keeps_unicode_and_quotes_valid():
    src = SourceFile("a \"b\".servo", "pose p { a: 90deg }\n")
    data = json.loads(to_json([diag(Span(9, 10), message="N 122 = 90.28° \"x\"")], src))
    assert data["diagnostics"][0]["message"] == "N 122 = 90.28° \"x\""
    assert data["diagnostics"][0]["file"] == "a \"b\".servo"


def test_secondary_labels_render_under_the_primary():
    src = SourceFile("arm.servo", TEXT)
    d = Diagnostic("duplicate-name", Severity.ERROR, "`up` is already declared", at(TEXT, "move up"),
                   secondary=(Label(at(TEXT, "arm", 1), "first declared here"),
                              Label(at(TEXT, "20ms"), "and here")))
    assert render_full(d, src).splitlines() == [
        "arm.servo:4:3: error: `up` is already declared [duplicate-name]",
        "   4 |   move up in 20ms",
        "     |   ^^^^^^^",
        "   2 | pose up { arm: 120 }",
        "     |           --- first declared here",
        "   4 |   move up in 20ms",
        "     |              ---- and here",
    ]


def test_secondary_label_on_the_primary_line_shares_it():
    src = SourceFile("arm.servo", TEXT)
    d = Diagnostic("c", Severity.WARNING, "m", at(TEXT, "20ms"), label="here",
                   secondary=(Label(at(TEXT, "up", 1), "and here"),))
    assert render_full(d, src).splitlines()[1:] == [
        "   4 |   move up in 20ms",
        "     |              ^^^^ here",
        "     |        -- and here",
    ]


def test_secondary_labels_in_json():
    src = SourceFile("arm.servo", TEXT)
    d = Diagnostic("c", Severity.ERROR, "m", at(TEXT, "move up"), secondary=(Label(at(TEXT, "arm", 1), "first"),))
    (item,) = json.loads(to_json([d], src))["diagnostics"]
    assert item["labels"] == [{"line": 2, "column": 11, "end_line": 2, "end_column": 14, "message": "first"}]
    (plain,) = json.loads(to_json([diag(at(TEXT, "move up"))], src))["diagnostics"]
    assert "labels" not in plain


def test_reporter_takes_secondary_labels():
    rep = Reporter(SourceFile("arm.servo", TEXT))
    rep.error("c", "m", at(TEXT, "up"), secondary=[Label(at(TEXT, "arm"), "x")])
    assert rep.diagnostics[0].secondary == (Label(at(TEXT, "arm"), "x"),)


# ---- long lines are shown as a window around the caret -----------------------------------

def _shown(rendered: str) -> tuple[str, str]:
    """The source line and the caret line of a rendered diagnostic, without their gutters."""
    lines = rendered.splitlines()
    return lines[1].split(" | ", 1)[1], lines[2].split(" | ", 1)[1]


def test_short_lines_are_shown_whole():
    text = "x" * SHOWN_COLUMNS + "\n"
    src = SourceFile("a.servo", text)
    line, caret = _shown(render_full(diag(Span(90, 95)), src))
    assert line == text.rstrip("\n") and caret == " " * 90 + "^^^^^"


def test_a_long_line_is_cut_around_the_caret():
    text = "servo a = P1.0 " + "y" * 1_000_000 + " @oops " + "z" * 1_000_000
    src = SourceFile("big.servo", text)
    at_ = text.index("@oops")
    rendered = render_full(diag(Span(at_, at_ + 5), label="here"), src)
    assert len(rendered) < 600 and rendered.startswith(f"big.servo:1:{at_ + 1}: error: ")
    line, caret = _shown(rendered)
    assert line.startswith("...") and line.endswith("...") and len(line) == SHOWN_COLUMNS + 6
    assert line[caret.index("^"):].startswith("@oops") and caret.endswith("^^^^^ here")


def test_a_caret_near_the_start_of_a_long_line():
    text = "servo a = P1.0 " + "y" * 5000
    src = SourceFile("a.servo", text)
    line, caret = _shown(render_full(diag(at(text, "P1.0")), src))
    assert not line.startswith("...") and line.endswith("...") and len(line) == SHOWN_COLUMNS + 3
    assert caret == " " * 10 + "^^^^"


def test_a_caret_near_the_end_of_a_long_line():
    text = "y" * 5000 + " P1.0"
    src = SourceFile("a.servo", text)
    line, caret = _shown(render_full(diag(at(text, "P1.0")), src))
    assert line.startswith("...") and not line.endswith("...") and line.endswith(" P1.0")
    assert line[caret.index("^"):] == "P1.0" and caret.endswith("^^^^")


def test_a_long_span_is_underlined_to_the_window_end():
    text = "y" * 3000
    src = SourceFile("a.servo", text)
    line, caret = _shown(render_full(diag(Span(100, 2000)), src))
    assert len(caret) <= len(line) and caret.endswith("^") and line.endswith("...")


def test_a_secondary_label_far_away_on_the_same_line_gets_its_own_window():
    text = "pose up { a: 1 } " + " " * 500 + "pose up { a: 2 }"
    src = SourceFile("a.servo", text)
    d = Diagnostic("duplicate-name", Severity.ERROR, "`up` is already declared", at(text, "up", 1),
                   secondary=(Label(at(text, "up"), "first declared here"),))
    lines = render_full(d, src).splitlines()
    assert len(lines) == 5 and lines[1].startswith("   1 | ...") and lines[3].startswith("   1 | pose up")
    assert lines[4].endswith("     -- first declared here")
