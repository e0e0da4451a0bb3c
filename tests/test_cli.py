"""The `servoc` command line, run in-process: commands, exit codes, output formats, fuzzed input."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import string
import subprocess
import sys
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servoc import __version__, cli

SPEC_EXAMPLE = Path(__file__).parent / "fixtures" / "spec_example.servo"

PROGRAM = """frame 10ms
servo arm  = P1.0
servo grip = P1.1 speed 0.3s/60deg
pose rest { arm: 0, grip: 0 }
pose reach { arm: 100, grip: 50 }
main {
  move rest
  move reach in 500ms
  hold 100ms
  move rest
}
"""
# move rest: first targets, 1 frame. move reach in 500ms: 50 frames;
#   arm 100 DAV x 2.467 ms = 246.7 ms of 500 ms = 49%; grip 50 x 3.7 ms = 185 ms = 37%.
# hold 100ms: 10 frames. move rest: arm needs 24.67 -> 25 frames, grip 18.5 -> 19: F = 25;
#   arm 246.7 / 250 = 99%, grip 185 / 250 = 74%. Total 1 + 50 + 10 + 25 = 86 frames.


def run(args: list[str], capsys) -> tuple[int, str, str]:
    rc = cli.main(args)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.fixture
def program(tmp_path) -> Path:
    path = tmp_path / "arm.servo"
    path.write_text(PROGRAM)
    return path


def no_traceback(text: str) -> None:
    assert "Traceback" not in text and "internal error" not in text


# ---- help and version ----------------------------------------------------------------

def test_help_lists_commands_and_examples(capsys):
    rc, out, err = run(["--help"], capsys)
    assert rc == 0
    for command in ("lint", "plan", "compile", "verify"):
        assert re.search(rf"^\s+{command}\s+\S", out, re.M), command
    assert "examples:" in out and "servoc lint " in out and "--format json" in out


def test_subcommand_help(capsys):
    rc, out, _ = run(["plan", "--help"], capsys)
    assert rc == 0 and "--csv" in out and "--emit" in out


def test_version(capsys):
    rc, out, _ = run(["--version"], capsys)
    assert rc == 0 and out.strip() == f"servoc {__version__}"


def test_no_command_is_a_usage_error(capsys):
    rc, out, err = run([], capsys)
    assert rc == 2 and "lint" in out + err


# ---- usage errors exit 2 ---------------------------------------------------------------

def test_missing_file(tmp_path, capsys):
    missing = tmp_path / "nope.servo"
    rc, out, err = run(["lint", str(missing)], capsys)
    assert rc == 2
    assert str(missing) in err and "No such file" in err
    no_traceback(out + err)


def test_directory_as_file(tmp_path, capsys):
    rc, out, err = run(["lint", str(tmp_path)], capsys)
    assert rc == 2 and "is a directory" in err
    no_traceback(out + err)


def test_unknown_subcommand(capsys, program):
    rc, out, err = run(["frobnicate", str(program)], capsys)
    assert rc == 2 and "frobnicate" in err
    no_traceback(out + err)


def test_bad_option(capsys, program):
    rc, out, err = run(["lint", "--bogus", str(program)], capsys)
    assert rc == 2 and "--bogus" in err
    rc, out, err = run(["lint", "--format", "xml", str(program)], capsys)
    assert rc == 2 and "xml" in err


def test_missing_file_from_a_real_process(tmp_path):
    # the installed entry point, to be sure nothing else prints a traceback
    proc = subprocess.run([sys.executable, "-m", "servoc", "lint", str(tmp_path / "nope.servo")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("servoc: error: ") and "nope.servo" in proc.stderr
    no_traceback(proc.stderr)


# ---- lint ---------------------------------------------------------------------------------

def test_lint_clean_program_exits_0(capsys, program):
    rc, out, err = run(["lint", str(program)], capsys)
    assert rc == 0 and err == ""
    assert out == f"{program}: 2 servos on P1, P = 10 ms (frame; shortest " + out.split("shortest ", 1)[1]
    assert out.rstrip().endswith("program 86 frames = 860 ms")


def test_lint_warning_only_exits_0(capsys, tmp_path):
    path = tmp_path / "w.servo"
    path.write_text(PROGRAM.replace("hold 100ms", "hold 2ms"))
    rc, out, err = run(["lint", str(path)], capsys)
    assert rc == 0
    assert f"{path}:9:3: warning: " in err and "[short-hold]" in err
    assert err.rstrip().endswith("0 errors, 1 warning, 0 notes")


def test_lint_error_exits_1(capsys, tmp_path):
    path = tmp_path / "e.servo"
    path.write_text(PROGRAM.replace("in 500ms", "in 100ms"))
    rc, out, err = run(["lint", str(path)], capsys)
    assert rc == 1 and out == ""
    assert err.startswith(f"{path}:8:3: error: servo `arm` cannot move 100 DAV")
    # both servos are too fast in 100 ms, but the move is reported once, for the worse one
    assert err.count("[infeasible-speed]") == 1
    assert err.rstrip().endswith("1 error, 0 warnings, 0 notes")


def test_lint_json(capsys, tmp_path):
    path = tmp_path / "j.servo"
    path.write_text(PROGRAM.replace("in 500ms", "in 100ms").replace("hold 100ms", "hold 2ms"))
    rc, out, err = run(["lint", "--format", "json", str(path)], capsys)
    assert rc == 1
    data = json.loads(out)
    items = data["diagnostics"]
    assert [(d["line"], d["column"], d["severity"], d["code"]) for d in items] == [
        (8, 3, "error", "infeasible-speed"), (9, 3, "warning", "short-hold")]
    for d in items:
        assert d["file"] == str(path)
        assert {"file", "line", "column", "severity", "code", "message"} <= set(d)
        assert d["message"] and d["help"]
    assert items[0]["end_line"] == 8 and items[0]["end_column"] == 3 + len("move reach in 100ms")
    assert data["summary"] == "1 error, 1 warning, 0 notes"


def test_lint_json_clean(capsys, program):
    rc, out, err = run(["lint", "--format", "json", str(program)], capsys)
    assert rc == 0
    assert json.loads(out) == {"diagnostics": [], "summary": "0 errors, 0 warnings, 0 notes"}


def test_invalid_utf8_reports_the_line(capsys, tmp_path):
    path = tmp_path / "bad.servo"
    path.write_bytes(b"servo a = P1.0\npose p { a: 1 }\n  # \xff\xfe\nmain { move p }\n")
    rc, out, err = run(["lint", str(path)], capsys)
    assert rc == 1
    assert err.startswith(f"{path}:3:5: error: ") and "[invalid-utf8]" in err.splitlines()[0]
    no_traceback(out + err)
    rc, out, err = run(["lint", "--format", "json", str(path)], capsys)
    d = json.loads(out)["diagnostics"][0]
    assert (d["line"], d["column"], d["code"]) == (3, 5, "invalid-utf8")


def test_invalid_utf8_after_multibyte_text_counts_characters(capsys, tmp_path):
    path = tmp_path / "bad.servo"
    path.write_bytes("# µs °\n".encode() + b"#  \xc3\n")
    rc, out, err = run(["lint", str(path)], capsys)
    assert rc == 1 and err.startswith(f"{path}:2:4: error: ")


# ---- plan --------------------------------------------------------------------------------

def test_plan_table(capsys, program):
    rc, out, err = run(["plan", str(program)], capsys)
    assert rc == 0 and err == ""
    lines = out.splitlines()
    assert lines[0].startswith("frame period P = 10 ms")
    assert re.match(r"\s*line\s+pose\s+frames\s+ms\s+servos", lines[1])
    rows = [re.split(r"\s{2,}", line.strip(), maxsplit=4) for line in lines[2:-1]]
    assert [r[:4] for r in rows] == [["7", "rest", "1", "10.0"], ["8", "reach", "50", "500.0"],
                                      ["10", "rest", "25", "250.0"]]
    assert rows[0][4] == "arm set, grip set"
    assert rows[1][4] == "arm +100 (49%), grip +50 (37%)"
    assert rows[2][4] == "arm -100 (99%), grip -50 (74%)"
    assert lines[-1] == "total: 86 frames = 860 ms, then the last targets repeat"


def test_plan_csv(capsys, program):
    rc, out, err = run(["plan", "--csv", str(program)], capsys)
    assert rc == 0
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["line", "pose", "frames", "ms", "ease", "servo", "delta", "speed_percent"]
    assert rows[1:] == [
        ["7", "rest", "1", "10", "linear", "arm", "set", ""],
        ["7", "rest", "1", "10", "linear", "grip", "set", ""],
        ["8", "reach", "50", "500", "linear", "arm", "+100", "49"],
        ["8", "reach", "50", "500", "linear", "grip", "+50", "37"],
        ["10", "rest", "25", "250", "linear", "arm", "-100", "99"],
        ["10", "rest", "25", "250", "linear", "grip", "-50", "74"],
    ]


def test_plan_of_a_loop(capsys):
    rc, out, _ = run(["plan", str(SPEC_EXAMPLE)], capsys)
    assert rc == 0 and out.splitlines()[-1] == "total: the program loops forever"
    assert "[in-out]" in out


def test_plan_with_errors_exits_1(capsys, tmp_path):
    path = tmp_path / "e.servo"
    path.write_text(PROGRAM.replace("in 500ms", "in 100ms"))
    rc, out, err = run(["plan", str(path)], capsys)
    assert rc == 1 and out == "" and "[infeasible-speed]" in err


@pytest.mark.parametrize("form, kind", [("ast", "Program"), ("model", "Program"), ("plan", "Plan")])
def test_emit_json(capsys, program, form, kind):
    for command in ("lint", "plan"):
        rc, out, err = run([command, "--emit", form, str(program)], capsys)
        assert rc == 0, err
        data = json.loads(out)
        assert data["kind"] == kind
    if form == "plan":
        assert data["period_us"] == 10000 and data["total_frames"] == 86
        assert [c["servo"]["name"] for c in data["channels"]] == ["arm", "grip"]
    if form == "model":
        assert [s["name"] for s in data["servos"]] == ["arm", "grip"]


def test_emit_with_errors_exits_1(capsys, tmp_path):
    path = tmp_path / "e.servo"
    path.write_text("servo a = P1.0\nmain { move nowhere }\n")
    rc, out, err = run(["lint", "--emit", "plan", str(path)], capsys)
    assert rc == 1 and "[unknown-name]" in err


# ---- never a traceback, whatever the input ---------------------------------------------------

HEADER = r"^{path}:\d+:\d+: (error|warning|note): .+ \[[a-z0-9-]+\]$"
SUMMARY = r"^\d+ errors?, \d+ warnings?, \d+ notes?$"


def _lint_bytes(data: bytes) -> None:
    with tempfile.TemporaryDirectory(prefix="servoc-fuzz-") as tmp:
        path = os.path.join(tmp, "fuzz.servo")
        with open(path, "wb") as f:
            f.write(data)
        out, err = io.StringIO(), io.StringIO()
        with redirect_stdout(out), redirect_stderr(err):
            rc = cli.main(["lint", path])
    out, err = out.getvalue(), err.getvalue()
    assert rc in (0, 1), (rc, out, err)
    no_traceback(out + err)
    header = re.compile(HEADER.format(path=re.escape(path)))
    lines = err.split("\n")
    assert lines[-1] == ""
    headers = 0
    for line in lines[:-1]:
        if line.startswith(path):
            assert header.match(line), line
            headers += 1
        else:
            assert (re.match(r"^ *\d+ \| ", line) or re.match(r"^ +\| ", line) or line.startswith("     = help: ")
                    or re.match(SUMMARY, line)), line
    if rc == 1:
        assert headers >= 1 and ": error: " in err
    else:
        assert out.startswith(path + ": ")


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=string.printable, max_size=300))
def test_random_printable_text_never_crashes(text):
    _lint_bytes(text.encode("utf-8"))


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=300))
def test_random_unicode_text_never_crashes(text):
    _lint_bytes(text.encode("utf-8"))


WORDS = ["servo", "group", "pose", "sequence", "main", "frame", "target", "move", "in", "ease", "hold",
         "repeat", "loop", "play", "with", "speed", "trim", "limit", "reverse", "linear", "out", "in-out",
         "clock", "a", "b", "p", "q", "s", "P1.0", "P0.7", "P2.3", "P3.1", "p1.0", "P1", "P0", "=", ",", ":",
         "{", "}", ";", "\n", "\n", "..", "/", "-", "90deg", "1500us", "300ms", "1s", "0", "122", "250",
         "0.25s", "12MHz", "6ms", "1.5", "999999999999", "#", "\t", "µs", "é"]


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.sampled_from(WORDS), max_size=60))
def test_random_token_soup_never_crashes(words):
    _lint_bytes(" ".join(words).encode("utf-8"))


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=300))
def test_random_bytes_never_crash(data):
    _lint_bytes(data)


def test_valid_prefix_with_random_tail_never_crashes():
    base = SPEC_EXAMPLE.read_bytes()
    for cut in range(0, len(base), 7):
        _lint_bytes(base[:cut])
