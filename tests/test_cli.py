"""The `servoc` command line, run in-process: commands, exit codes, output formats, fuzzed input."""

from __future__ import annotations

import csv
import gc
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
home rest
main {
  move reach in 500ms
  hold 100ms
  move rest
}
"""
# home rest: at power-up, 1 frame. move reach in 500ms: 50 frames;
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


@pytest.mark.parametrize("flag", ["--version", "-V"])
def test_version(capsys, flag):
    rc, out, _ = run([flag], capsys)
    assert rc == 0 and out.strip() == f"servoc {__version__}"


def test_help_names_the_tool_overrides(capsys):
    from servoc.toolchain import _TOOLS
    rc, out, _ = run(["--help"], capsys)
    assert rc == 0 and "lsp" in out
    for env, _package in _TOOLS.values():
        assert env in out, env


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
    assert data["summary"] == {"errors": 1, "warnings": 1, "notes": 0}


def test_lint_json_clean(capsys, program):
    rc, out, err = run(["lint", "--format", "json", str(program)], capsys)
    assert rc == 0
    assert json.loads(out) == {"diagnostics": [], "summary": {"errors": 0, "warnings": 0, "notes": 0}}


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
    rows = [re.split(r"\s{2,}", line.strip(), maxsplit=4) for line in lines[2:-2]]
    assert [r[:4] for r in rows] == [["6", "rest", "1", "10.0"], ["8", "reach", "50", "500.0"],
                                      ["10", "rest", "25", "250.0"]]
    assert rows[0][4] == "arm set, grip set"          # the power-up frame: the first pulses set them
    assert lines[-2] == ("power-up: `home rest`, 1 frame = 10 ms before the program's first frame: "
                         "arm at 0 ms, grip at 0 ms")
    assert rows[1][4] == "arm +100 (49%), grip +50 (37%)"
    assert rows[2][4] == "arm -100 (99%), grip -50 (74%)"
    assert lines[-1] == "total: 86 frames = 860 ms, then the last targets repeat"


def test_plan_csv(capsys, program):
    rc, out, err = run(["plan", "--csv", str(program)], capsys)
    assert rc == 0
    rows = list(csv.reader(io.StringIO(out)))
    assert rows[0] == ["line", "pose", "frames", "ms", "ease", "servo", "delta", "speed_percent"]
    assert rows[1:] == [
        ["6", "rest", "1", "10", "linear", "arm", "set", ""],        # the power-up frame, `home rest`
        ["6", "rest", "1", "10", "linear", "grip", "set", ""],
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


# ---- --format json: one document whatever happens ---------------------------------------

def json_doc(stream: str) -> dict:
    """The diagnostics document of a --format json run: the whole stream, one JSON object."""
    data = json.loads(stream)
    assert {"diagnostics", "summary"} <= set(data) and set(data["summary"]) == {"errors", "warnings", "notes"}
    return data


@pytest.mark.parametrize("args, kind, words", [
    (["lint", "--format", "json", "NOPE"], "usage", "No such file"),
    (["plan", "--format=json", "NOPE"], "usage", "No such file"),
    (["verify", "--format", "json", "--frames", "0", "PROG"], "usage", "--frames must be at least 1"),
    (["verify", "--format", "json", "--frames", "x", "PROG"], "usage", "invalid int value"),
    (["lint", "--format", "json", "--bogus", "PROG"], "usage", "--bogus"),
    (["lnt", "--format", "json", "PROG"], "usage", "did you mean `servoc lint`"),
    (["compile", "--format", "json", "PROG", "-o", "PROG"], "usage", "it is the program"),
    (["compile", "--format", "json", "PROG", "-o", "MISSING/x.hex"], "usage", "does not exist"),
])
def test_json_usage_errors(capsys, program, tmp_path, args, kind, words):
    args = [str(program) if a == "PROG" else str(tmp_path / "nope.servo") if a == "NOPE"
            else a.replace("MISSING", str(tmp_path / "missing")) for a in args]
    before = program.read_bytes()
    rc, out, err = run(args, capsys)
    assert rc == 2
    lint = args[0] == "lint"
    data = json_doc(out if lint else err)
    assert (err if lint else out) == ""
    assert data["diagnostics"] == [] and data["summary"] == {"errors": 0, "warnings": 0, "notes": 0}
    assert data["error"]["kind"] == kind and words in data["error"]["message"]
    assert program.read_bytes() == before


def test_json_missing_tool(capsys, program, tmp_path, monkeypatch):
    monkeypatch.setenv("SERVOC_SDAS8051", str(tmp_path / "no-sdas8051"))
    rc, out, err = run(["compile", "--format", "json", str(program), "-o", str(tmp_path / "a.hex")], capsys)
    assert rc == 2 and out == ""
    data = json_doc(err)
    assert data["error"]["kind"] == "missing-tool" and "SERVOC_SDAS8051" in data["error"]["message"]
    assert not (tmp_path / "a.hex").exists()


def test_json_keeps_the_program_diagnostics_with_the_error(capsys, tmp_path, monkeypatch):
    path = tmp_path / "w.servo"
    path.write_text(PROGRAM.replace("hold 100ms", "hold 2ms"))
    monkeypatch.setenv("SERVOC_SDAS8051", str(tmp_path / "no-sdas8051"))
    rc, out, err = run(["compile", "--format", "json", str(path)], capsys)
    data = json_doc(err)
    assert rc == 2 and [d["code"] for d in data["diagnostics"]] == ["short-hold"]
    assert data["summary"] == {"errors": 0, "warnings": 1, "notes": 0} and data["error"]["kind"] == "missing-tool"


def test_json_internal_error(capsys, program, monkeypatch):
    def broken(*_):
        raise RuntimeError("boom")
    monkeypatch.setattr(cli.api, "front_end", broken)
    rc, out, err = run(["plan", "--format", "json", str(program)], capsys)
    assert rc == 3 and out == ""
    data = json_doc(err)
    assert data["error"]["kind"] == "internal" and "boom" in data["error"]["message"]


def _collector_seen_by(monkeypatch, name: str) -> list[bool]:
    """Whether the cyclic collector was on at each call of `cli.api.<name>`."""
    seen: list[bool] = []
    real = getattr(cli.api, name)

    def watched(*args):
        seen.append(gc.isenabled())
        return real(*args)
    monkeypatch.setattr(cli.api, name, watched)
    return seen


def test_the_collector_is_paused_only_while_the_program_is_read(capsys, program, monkeypatch):
    seen = _collector_seen_by(monkeypatch, "front_end")
    assert run(["lint", str(program)], capsys)[0] == 0
    assert seen == [False] and gc.isenabled() and gc.get_freeze_count() == 0

    def broken(*_):
        raise RuntimeError("boom")
    monkeypatch.setattr(cli.api, "front_end", broken)
    assert run(["lint", str(program)], capsys)[0] == 3
    assert gc.isenabled() and gc.get_freeze_count() == 0


def test_the_api_front_end_restores_the_collector(program, monkeypatch):
    seen = _collector_seen_by(monkeypatch, "parse")
    source, reporter = cli.api.load_source(str(program))
    for was in (True, False):
        (gc.enable if was else gc.disable)()
        assert cli.api.front_end(source, reporter).plan is not None
        assert gc.isenabled() == was
    gc.enable()
    assert seen == [False, False]


def test_the_front_end_leaves_no_cycles(program):
    # what the collector is spared must be freed without it: no servoc object in a reference cycle
    gc.collect()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        for path in (program, Path(__file__).resolve().parent.parent / "examples" / "hexapod_serial.servo"):
            source, reporter = cli.api.load_source(str(path))
            assert cli.api.front_end(source, reporter).plan is not None
        del source, reporter
        gc.collect()
        left = [o for o in gc.garbage if type(o).__module__.startswith("servoc")
                or getattr(o, "__module__", None) and str(getattr(o, "__module__")).startswith("servoc")
                or isinstance(o, dict) and "notes" in o]        # codegen's records, pinned by a template
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
    assert left == []


def test_the_period_stage_builds_each_plan_once_and_keeps_nothing_after_it(monkeypatch):
    """Within one period stage an equal plan is built once (the searches meet the same periods):
    the biped example's stage builds twice, at its own P and at its shortest. Nothing is kept after
    the stage: a cost model patched between two front ends is seen by the second."""
    from servoc import codegen, costs
    calls = []
    real = codegen.generate
    monkeypatch.setattr(codegen, "generate", lambda p, *a, **k: calls.append(p.period_us) or real(p, *a, **k))
    path = Path(__file__).resolve().parent.parent / "examples" / "biped.servo"
    first = cli.api.front_end(*cli.api.load_source(str(path))).plan
    assert len(calls) == len(set(calls)) == 2 and cli.api._built is None
    cycles = costs.frame_cycles
    monkeypatch.setattr(costs, "frame_cycles", lambda target, budget: 2 * cycles(target, budget))
    assert cli.api.front_end(*cli.api.load_source(str(path))).plan.min_period_us > first.min_period_us


def test_json_without_a_file_goes_to_stderr(capsys):
    rc, out, err = run(["--format", "json"], capsys)
    assert rc == 2 and out == "" and json_doc(err)["error"]["kind"] == "usage"


def test_json_help_is_still_help(capsys):
    rc, out, err = run(["lint", "--format", "json", "--help"], capsys)
    assert rc == 0 and "--format" in out and err == ""


def test_plan_json_table(capsys, program):
    rc, out, err = run(["plan", "--json", str(program)], capsys)
    assert rc == 0 and err == ""
    data = json.loads(out)
    assert (data["file"], data["period_us"], data["period_is_default"], data["total_frames"]) == \
        (str(program), 10000, False, 86)
    assert data["min_period_us"] <= 10000 and data["dav_deg"] == 0.74
    moves = data["moves"]
    assert [(m["line"], m["pose"], m["frames"], m["ms"], m["ease"]) for m in moves] == [
        (6, "rest", 1, 10.0, "linear"), (8, "reach", 50, 500.0, "linear"), (10, "rest", 25, 250.0, "linear")]
    assert moves[0]["servos"] == [{"servo": "arm", "delta": None, "speed_percent": None},   # the power-up
                                  {"servo": "grip", "delta": None, "speed_percent": None}]
    assert data["startup"] == {"frames": 1, "servos": [{"servo": "arm", "frame": 1, "ms": 0.0},
                                                      {"servo": "grip", "frame": 1, "ms": 0.0}]}
    assert moves[2]["servos"] == [{"servo": "arm", "delta": -100, "speed_percent": 99},
                                  {"servo": "grip", "delta": -50, "speed_percent": 74}]


def test_plan_json_table_and_csv_exclude_each_other(capsys, program):
    rc, out, err = run(["plan", "--json", "--csv", str(program)], capsys)
    assert rc == 2 and "--csv" in err


def test_plan_json_table_of_a_loop(capsys):
    rc, out, _ = run(["plan", "--json", str(SPEC_EXAMPLE)], capsys)
    data = json.loads(out)
    assert rc == 0 and data["total_frames"] is None and "in-out" in {m["ease"] for m in data["moves"]}


@pytest.mark.toolchain
def test_compile_json(capsys, program, tmp_path):
    hex_path, asm_path = tmp_path / "o.hex", tmp_path / "o.asm"
    rc, out, err = run(["compile", "--format", "json", str(program), "-o", str(hex_path), "--asm", str(asm_path)],
                       capsys)
    assert rc == 0 and json_doc(err)["diagnostics"] == []
    data = json.loads(out)
    assert (data["file"], data["hex"], data["asm"]) == (str(program), str(hex_path), str(asm_path))
    assert 0 < data["rom_bytes"] <= data["rom_size"] == 8192 and 0 < data["ram_bytes"] <= data["ram_size"] == 256
    assert data["rom_bytes"] >= data["runtime_bytes"] + data["program_bytes"] + data["data_bytes"] - 64
    assert data["period_us"] == 10000 and data["total_frames"] == 86 and hex_path.stat().st_size > 0


@pytest.mark.toolchain
def test_verify_json(capsys, program):
    rc, out, err = run(["verify", "--format", "json", str(program)], capsys)
    assert rc == 0 and json_doc(err) == {"diagnostics": [], "summary": {"errors": 0, "warnings": 0, "notes": 0}}
    data = json.loads(out)
    assert data["ok"] is True and data["mismatches"] == []
    assert data["frames"] == 86 + 20 and data["pulses"] == 2 * data["frames"] and data["max_error_cycles"] == 0
    assert data["planned_period_us"] == 10000
    assert data["period_us"] == {"min": 10000, "max": 10000, "mean": 10000.0}
    assert 0 <= data["reset_low_us"] <= 20
    assert data["period_cycles"] == data["period_us"] and data["machine_cycle_us"] == 1.0   # 12 MHz: a cycle is a µs


@pytest.mark.toolchain
@pytest.mark.parametrize("clock,cycle_ns", [("clock 11.0592MHz", 1085.069), ("clock 22.1184MHz mode 6T", 271.267)])
def test_verify_json_times_are_in_the_unit_their_name_says(capsys, tmp_path, clock, cycle_ns):
    path = tmp_path / "stc.servo"
    path.write_text(f"target stc89c52rc {clock}\nframe 10ms\nservo arm = P1.0\npose a {{ arm: 90deg }}\n"
                    "main { move a }\n")
    rc, out, _ = run(["verify", "--format", "json", str(path)], capsys)
    data = json.loads(out)
    assert rc == 0 and abs(data["machine_cycle_us"] * 1000 - cycle_ns) < 0.001
    period = data["planned_period_cycles"]
    assert data["period_cycles"]["min"] == period == round(10_000 / data["machine_cycle_us"])
    assert abs(data["period_us"]["min"] - 10_000) <= data["machine_cycle_us"] / 2      # µs, not cycles
    assert data["reset_low_us"] == round(data["reset_low_cycles"] * data["machine_cycle_us"], 3)


@pytest.mark.toolchain
def test_verify_json_lists_every_mismatch(capsys, program, tmp_path):
    other = tmp_path / "other.servo"
    other.write_text(PROGRAM.replace("arm: 100", "arm: 90"))
    hex_path = tmp_path / "other.hex"
    assert run(["compile", str(other), "-o", str(hex_path)], capsys)[0] == 0
    rc, out, err = run(["verify", "--format", "json", str(program), "--hex", str(hex_path)], capsys)
    data = json.loads(out)
    assert rc == 1 and data["ok"] is False and len(data["mismatches"]) > 20
    m = data["mismatches"][0]
    assert set(m) == {"frame", "servo", "pin", "expected_cycles", "measured_cycles", "expected_us", "measured_us", "what"}
    assert m["servo"] == "arm" and m["pin"] == "P1.0" and m["expected_us"] != m["measured_us"]
    rc, text, _ = run(["verify", str(program), "--hex", str(hex_path)], capsys)
    assert f"and {len(data['mismatches']) - 20} more mismatches" in text


def test_init_json(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run(["init", "arm", "--format", "json"], capsys)
    assert rc == 0 and json.loads(out) == {"file": "arm.servo"} and json_doc(err)["diagnostics"] == []
    rc, out, err = run(["init", "arm", "--format", "json"], capsys)
    assert rc == 2 and "already exists" in json_doc(err)["error"]["message"]


# ---- outputs are checked before any work -------------------------------------------------

@pytest.fixture
def no_work(monkeypatch):
    """Compiling or simulating fails the test: the command must stop before."""
    def forbidden(*_):
        raise AssertionError("servoc did the work before checking its outputs")
    monkeypatch.setattr(cli.api, "build", forbidden)
    monkeypatch.setattr(cli.api, "simulate", forbidden)
    monkeypatch.setattr(cli.api, "front_end", forbidden)


@pytest.mark.parametrize("args, words", [
    (["verify", "PROG", "--vcd", "/nonexistent/x.vcd"], "cannot write /nonexistent/x.vcd: /nonexistent does not exist"),
    (["verify", "PROG", "--vcd", "DIR"], "cannot write DIR: it is a directory"),
    (["plan", "PROG", "--plot", "DIR/missing/a.png"], "does not exist (--plot)"),
    (["plan", "PROG", "--plot", "PROG"], "it is the program"),
    (["compile", "PROG", "-o", "DIR"], "it is a directory, not a file (-o)"),
    (["compile", "PROG", "--asm", "DIR/missing/x.asm"], "does not exist (--asm)"),
    (["compile", "PROG", "-o", "PROG"], "cannot write PROG: it is the program, PROG (-o)"),
    (["compile", "PROG", "--asm", "PROG"], "it is the program"),
    (["compile", "PROG", "-o", "DIR/x.hex", "--asm", "DIR/x.hex"], "--asm and -o name the same file"),
    (["compile", "PROG", "-o", "DIR/./x.hex", "--asm", "DIR/x.hex"], "name the same file"),
    (["verify", "PROG", "--hex", "DIR/in.hex", "--vcd", "DIR/in.hex"], "it is the HEX to check"),
    (["verify", "PROG", "--hex", "DIR/missing.hex"], "cannot read an Intel HEX file"),
])
def test_outputs_refused_before_any_work(capsys, program, tmp_path, no_work, args, words):
    (tmp_path / "in.hex").write_text(":00000001FF\n")
    sub = lambda a: a.replace("PROG", str(program)).replace("DIR", str(tmp_path))  # noqa: E731
    before = sorted(p.name for p in tmp_path.iterdir())
    text = program.read_bytes()
    rc, out, err = run([sub(a) for a in args], capsys)
    assert rc == 2 and out == ""
    assert err.startswith("servoc: error: ") and sub(words) in err, err
    no_traceback(err)
    assert program.read_bytes() == text and sorted(p.name for p in tmp_path.iterdir()) == before


def test_default_hex_output_cannot_be_the_source(capsys, tmp_path, no_work):
    path = tmp_path / "prog.hex"            # FILE.hex of `prog.hex` is the file itself
    path.write_text(PROGRAM)
    rc, out, err = run(["compile", str(path)], capsys)
    assert rc == 2 and "it is the program" in err and path.read_text() == PROGRAM


def test_missing_extra_refused_before_simulating(capsys, program, tmp_path, no_work, monkeypatch):
    monkeypatch.setitem(sys.modules, "vcd", None)
    rc, out, err = run(["verify", str(program), "--vcd", str(tmp_path / "a.vcd")], capsys)
    assert rc == 2 and "pip install 'servoc[vcd]'" in err
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    rc, out, err = run(["plan", str(program), "--plot", str(tmp_path / "a.png")], capsys)
    assert rc == 2 and "pip install 'servoc[plot]'" in err and out == ""


# ---- the language server -----------------------------------------------------------------

def test_lsp_without_pygls(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "servoc.lsp", None)       # as if servoc.lsp could not be imported
    rc, out, err = run(["lsp"], capsys)
    assert rc == 2 and out == ""
    assert err == "servoc: error: the language server needs pygls: pip install 'servoc[lsp]'\n"


def test_lsp_is_listed(capsys):
    rc, out, _ = run(["--help"], capsys)
    assert re.search(r"^\s+lsp\s+run the language server on stdin/stdout, for editors", out, re.M)


# ---- the starter program -----------------------------------------------------------------

def test_starter_lints_quietly(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run(["init", "arm"], capsys)
    assert rc == 0 and out == "arm.servo: written. Next: servoc lint arm.servo\n"
    rc, out, err = run(["lint", "arm.servo"], capsys)
    assert rc == 0 and out.startswith("arm.servo: 4 servos on P1")
    assert err.count("[inexact-angle]") <= 1 and err.rstrip().endswith("0 errors, 0 warnings, 1 note")


# ---- the JSON schemas in docs/language.md are what servoc prints ---------------------------

DOCS = Path(__file__).resolve().parent.parent / "docs" / "language.md"


def documented_keys(after: str) -> set[str]:
    """The keys (first column, in backticks) of the first `| key | value |` table after the text `after`."""
    text = DOCS.read_text(encoding="utf-8")
    rest = text[text.index(after):]
    table = re.search(r"^\| key \| value \|\n\|-+\|-+\|\n((?:\|.*\n)+)", rest, re.M)
    assert table, f"no key table after {after!r}"
    keys = set()
    for row in table.group(1).splitlines():
        keys |= set(re.findall(r"`([a-z_\[\].]+)`", row.split(" | ")[0]))
    return keys


def key_paths(data, prefix: str = "") -> set[str]:
    """Every key of a JSON value as a path: `a`, `a.b`, `a[].b` for the objects of a list."""
    paths = set()
    for key, value in data.items():
        paths.add(prefix + key)
        if isinstance(value, dict):
            paths |= key_paths(value, f"{prefix}{key}.")
        elif isinstance(value, list):
            for item in value:
                if isinstance(item, dict):
                    paths |= key_paths(item, f"{prefix}{key}[].")
    return paths


def test_documented_diagnostics_document(capsys, tmp_path):
    documented = documented_keys("The diagnostics document:")
    path = tmp_path / "d.servo"
    path.write_text("servo a = P1.0\npose p { a: 1 }\npose p { a: 2 }\nmain { move p }\n")
    rc, out, _ = run(["lint", "--format", "json", str(path)], capsys)
    got = key_paths(json.loads(out))
    assert rc == 1 and "diagnostics[].labels" in got
    assert {p for p in got if not p.startswith("diagnostics[].labels[].")} <= documented
    rc, _, err = run(["plan", "--format", "json", str(tmp_path / "nope.servo")], capsys)
    got = key_paths(json.loads(err))
    assert rc == 2 and got <= documented
    assert documented == got | {p for p in documented if p.startswith("diagnostics[]")}
    kinds = re.findall(r'`"([a-z-]+)"`', DOCS.read_text(encoding="utf-8").split("| `error.kind` |")[1].split("\n")[0])
    assert set(kinds) == {"usage", "missing-tool", "missing-extra", "cannot-write", "internal"}
    raised = {m.group(1) for line in Path(cli.__file__).read_text().splitlines() if "raise _Stop(" in line
              for m in [re.search(r', "([a-z-]+)"\)( from None)?$', line)] if m}
    assert raised == {"missing-tool", "missing-extra", "cannot-write"} and raised < set(kinds)


def test_documented_plan_table(capsys, program):
    rc, out, _ = run(["plan", "--json", str(program)], capsys)
    assert rc == 0 and key_paths(json.loads(out)) == documented_keys("as CSV with `--csv`, or as JSON")


@pytest.mark.toolchain
def test_documented_compile_and_verify_results(capsys, program, tmp_path):
    rc, out, _ = run(["compile", "--format", "json", str(program), "-o", str(tmp_path / "p.hex")], capsys)
    assert rc == 0 and key_paths(json.loads(out)) == documented_keys("`servoc compile --format json` prints")
    other = tmp_path / "other.servo"
    other.write_text(PROGRAM.replace("arm: 100", "arm: 90"))
    assert run(["compile", str(other), "-o", str(tmp_path / "o.hex")], capsys)[0] == 0
    rc, out, _ = run(["verify", "--format", "json", str(program), "--hex", str(tmp_path / "o.hex")], capsys)
    documented = documented_keys("`servoc verify --format json` prints")
    assert rc == 1 and key_paths(json.loads(out)) == {k for k in documented if not k.startswith("selects[]")}
    assert {"selects[].line", "selects[].event", "selects[].frame"} <= documented     # listed with --events


# ---- flash (the rest is in test_flash.py) --------------------------------------------------

def test_flash_is_listed_with_its_example(capsys):
    rc, out, _ = run(["--help"], capsys)
    assert rc == 0 and re.search(r"^\s+flash\s+compile and write to an STC89 board", out, re.M)
    assert "servoc flash prog.servo --port /dev/ttyUSB0" in out
    rc, out, err = run(["flsh", "x.servo"], capsys)
    assert rc == 2 and "did you mean `servoc flash`" in err


def test_flash_json_usage_error(capsys, tmp_path):
    path = tmp_path / "stc.servo"
    path.write_text("target stc89c52rc\n" + PROGRAM)
    rc, out, err = run(["flash", "--format", "json", str(path)], capsys)
    assert rc == 2 and out == ""
    data = json_doc(err)
    assert data["error"]["kind"] == "usage" and "--port" in data["error"]["message"]
    assert not (tmp_path / "stc.hex").exists()


@pytest.mark.toolchain
def test_documented_flash_result(capsys, program, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "stcgal", None)        # an AT89C52 needs no stcgal
    rc, out, _ = run(["flash", "--format", "json", str(program), "-o", str(tmp_path / "p.hex")], capsys)
    assert rc == 0 and key_paths(json.loads(out)) == documented_keys("`servoc flash --format json`")


@pytest.mark.parametrize("frame, held", [("", "no entry held while a group waits"),
                                         ("frame 20ms\n", "2 entries held while a group waits; Q, QP and VER lines "
                                                           "after a group line read on")])
def test_plan_says_what_host_reads_a_frame_and_holds(capsys, tmp_path, frame, held):
    # the arm at its own period (about 6 bytes a frame) has no holds and stops before a Q after a
    # group line; at 20 ms (about 20) it holds entries and reads on
    text = (Path(__file__).parent.parent / "examples" / "ssc32_arm.servo").read_text()
    path = tmp_path / "arm.servo"
    path.write_text(text.replace("serial 9600", "serial 9600\n" + frame.rstrip("\n")))
    rc, out, err = run(["plan", str(path)], capsys)
    assert rc == 0, err
    line = next(x for x in out.splitlines() if x.startswith("host reading: "))
    assert "at 9600 baud" in line and "its state in internal RAM" in line and held in line
