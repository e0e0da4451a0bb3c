"""A fixed-budget fuzz campaign over the command line, run in-process.

Inputs: valid programs built by a hypothesis strategy (servos with options,
groups, poses with `with`, sequences, main with every statement), the same
programs after random mutations (tokens and lines deleted, duplicated and
swapped, characters, keywords and numbers inserted, names replaced, huge
numbers, deep nesting, truncation), and random bytes. Each goes through
`servoc lint`, `servoc plan` and (for a subset) `servoc compile`, in text and
JSON, and must give: no traceback and no internal error (exit 3), exit 0 or 1
with 1 exactly when an error is printed, well-formed diagnostics inside the
file, JSON that parses, and a HEX file written only on success and valid then.
Compiling the same source from two places gives byte-identical HEX and asm.

Every example is derandomized, so a run is the same on every machine.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import subprocess
import sys
import tempfile
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from intelhex import IntelHex

from servoc import cli
from servoc.source import SourceFile
from servoc.units import DEFAULT_T_DAV_US, t_dav_from_speed

# Shrinking is left out (a failing example prints its whole input instead), so the
# time of a failing run stays close to that of a passing one.
FUZZ = dict(deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                   HealthCheck.filter_too_much])

KEYWORDS = ["clock", "ease", "frame", "group", "hold", "in", "limit", "linear", "loop", "main", "move", "out",
            "play", "pose", "repeat", "reverse", "sequence", "servo", "speed", "target", "trim", "with", "in-out"]
ROOT = Path(__file__).resolve().parent.parent


# ============================================================ running the CLI in-process

@dataclass(frozen=True)
class Run:
    rc: int
    out: str
    err: str


def run_cli(args: list[str]) -> Run:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = cli.main(args)
    return Run(rc, out.getvalue(), err.getvalue())


@dataclass(frozen=True)
class Diag:
    line: int
    column: int
    severity: str
    code: str
    message: str


SUMMARY_RE = re.compile(r"^(\d+) errors?, (\d+) warnings?, (\d+) notes?$")


def _no_crash(run: Run, what: str) -> None:
    assert run.rc != 3, f"{what}: internal error\n{run.err}"
    assert "Traceback" not in run.out + run.err, f"{what}: traceback\n{run.err}"
    assert "internal error" not in run.out + run.err, f"{what}: internal error\n{run.err}"
    assert run.rc in (0, 1), f"{what}: exit {run.rc}\n{run.err}"


def _inside(text: str, line: int, column: int, what: str) -> None:
    """LINE and COL (1-based, columns in characters) point into the file or just past a line's end."""
    lines = text.split("\n")
    assert 1 <= line <= len(lines), f"{what}: line {line} outside 1..{len(lines)}"
    assert 1 <= column <= len(lines[line - 1]) + 1, \
        f"{what}: column {column} outside line {line} of length {len(lines[line - 1])}"


def text_diagnostics(run: Run, path: str, text: str, what: str) -> list[Diag]:
    """Parse standard error of a text-format run: every line is a diagnostic header, its source
    line, its caret line, a secondary label's source line and `-` line, its help line or the
    closing summary."""
    header = re.compile(rf"^{re.escape(path)}:(\d+):(\d+): (error|warning|note): (.*) \[([a-z0-9-]+)\]$")
    diags: list[Diag] = []
    if run.err == "":
        return diags
    assert run.err.endswith("\n"), f"{what}: stderr does not end with a newline"
    lines = run.err[:-1].split("\n")
    summary = SUMMARY_RE.match(lines[-1])
    assert summary, f"{what}: no summary line at the end of\n{run.err}"
    caret = False           # the header's own source line and caret are shown: later ones are secondary
    for line in lines[:-1]:
        m = header.match(line)
        if m:
            d = Diag(int(m[1]), int(m[2]), m[3], m[5], m[4])
            _inside(text, d.line, d.column, f"{what}: {line}")
            diags.append(d)
            caret = False
            continue
        src = re.match(r"^ *(\d+) \| ", line)
        if src:
            assert diags, f"{what}: source line {line!r} before any header"
            assert caret or int(src[1]) == diags[-1].line, f"{what}: source line {line!r} after another header"
            continue
        if re.match(r"^ +\| *\^+", line):
            caret = True
            continue
        assert (caret and re.match(r"^ +\| *-+", line)) or line.startswith("     = help: "), \
            f"{what}: unexpected stderr line {line!r}\n{run.err}"
    counts = [sum(d.severity == s for d in diags) for s in ("error", "warning", "note")]
    assert [int(g) for g in summary.groups()] == counts, f"{what}: summary {lines[-1]!r} vs {counts}"
    assert diags, f"{what}: a summary without diagnostics"
    return diags


def json_diagnostics(stream: str, path: str, text: str, what: str) -> list[Diag]:
    """Parse the JSON object of `--format json` (the whole of `stream`)."""
    data = json.loads(stream)
    assert stream.endswith("}\n"), f"{what}: the JSON object does not end the stream with a newline"
    assert set(data) == {"diagnostics", "summary"}, f"{what}: {sorted(data)}"
    diags = []
    for item in data["diagnostics"]:
        assert {"file", "line", "column", "end_line", "end_column", "severity", "code", "message",
                "label", "help"} <= set(item), f"{what}: {item}"
        assert item["file"] == path
        assert item["severity"] in ("error", "warning", "note")
        assert re.fullmatch(r"[a-z0-9-]+", item["code"]) and item["message"]
        _inside(text, item["line"], item["column"], f"{what}: {item}")
        _inside(text, item["end_line"], item["end_column"], f"{what}: end of {item}")
        assert (item["end_line"], item["end_column"]) >= (item["line"], item["column"]), f"{what}: {item}"
        diags.append(Diag(item["line"], item["column"], item["severity"], item["code"], item["message"]))
    counts = [sum(d.severity == s for d in diags) for s in ("error", "warning", "note")]
    got = data["summary"]
    assert [got["errors"], got["warnings"], got["notes"]] == counts, f"{what}: {got!r} vs {counts}"
    return diags


def _exit_matches(run: Run, diags: list[Diag], what: str) -> None:
    has_error = any(d.severity == "error" for d in diags)
    assert run.rc == (1 if has_error else 0), f"{what}: exit {run.rc} with errors={has_error}\n{run.err}"


def check_lint_and_plan(path: str, text: str) -> list[Diag]:
    """Run lint and plan in text and JSON; check every output; return lint's diagnostics."""
    results = {}
    for command in ("lint", "plan"):
        what = f"servoc {command}"
        run = run_cli([command, path])
        _no_crash(run, what)
        diags = text_diagnostics(run, path, text, what)
        _exit_matches(run, diags, what)
        if command == "lint":
            if run.rc == 0:
                assert run.out.startswith(f"{path}: ") and run.out.count("\n") == 1, f"{what}: {run.out!r}"
            else:
                assert run.out == "", f"{what}: output after errors: {run.out!r}"
        else:
            assert not any(d.severity == "note" for d in diags), f"{what}: notes are for lint only"
            if run.rc == 0:
                assert run.out.startswith("frame period P = ") and "\ntotal: " in run.out, f"{what}: {run.out!r}"
            else:
                assert run.out == "", f"{what}: output after errors: {run.out!r}"
        jrun = run_cli([command, "--format", "json", path])
        _no_crash(jrun, what + " --format json")
        assert jrun.rc == run.rc, f"{what} --format json: exit {jrun.rc}, text exit {run.rc}"
        # lint prints the JSON on standard output (its only output); plan on standard error,
        # with the same table as `plan --json` on standard output.
        if command == "lint":
            assert jrun.err == "", f"{what} --format json: stderr {jrun.err!r}"
            stream = jrun.out
        else:
            assert jrun.out == run_cli([command, "--json", path]).out, f"{what} --format json: stdout is not the JSON table"
            if jrun.rc == 0:
                assert isinstance(json.loads(jrun.out)["moves"], list), f"{what} --format json: {jrun.out!r}"
            stream = jrun.err
        jdiags = json_diagnostics(stream, path, text, what + " --format json")
        assert jdiags == diags, f"{what}: text and JSON differ\n{diags}\n{jdiags}"
        results[command] = diags
    # The same front end: plan shows lint's diagnostics without the notes.
    assert results["plan"] == [d for d in results["lint"] if d.severity != "note"]
    return results["lint"]


def check_hex(path: str) -> IntelHex:
    """A complete Intel HEX image for the AT89C52's 8 KB of code memory."""
    with open(path, encoding="ascii") as f:
        hex_text = f.read()
    lines = hex_text.splitlines()
    assert lines and lines[-1] == ":00000001FF", "the HEX does not end with the EOF record"
    assert all(re.fullmatch(r":[0-9A-F]{10,}", line) for line in lines), "malformed HEX record"
    image = IntelHex(io.StringIO(hex_text))      # checks every record's length and checksum
    assert image.minaddr() == 0 and image.maxaddr() < 0x2000, (image.minaddr(), image.maxaddr())
    return image


def check_compile(path: str, text: str, lint_diags: list[Diag]) -> Run:
    """`servoc compile -o OUT.hex --asm OUT.asm` in the program's own empty directory."""
    folder = os.path.dirname(path)
    hex_path, asm_path = os.path.join(folder, "out.hex"), os.path.join(folder, "out.asm")
    before = sorted(os.listdir(folder))
    run = run_cli(["compile", path, "-o", hex_path, "--asm", asm_path])
    what = "servoc compile"
    _no_crash(run, what)
    diags = text_diagnostics(run, path, text, what)
    _exit_matches(run, diags, what)
    lint_shown = [d for d in lint_diags if d.severity != "note"]
    if any(d.severity == "error" for d in lint_diags):
        assert run.rc == 1 and diags == lint_shown
    else:   # the front end passed: only resource errors may be added
        resource = ("too-slow", "too-deep", "rom-overflow", "ram-overflow")
        assert [d for d in diags if d.code not in resource] == lint_shown, (diags, lint_shown)
        assert all(d.severity == "error" for d in diags if d.code in resource)
    after = sorted(os.listdir(folder))
    if run.rc == 1:
        assert run.out == "", f"{what}: output after errors: {run.out!r}"
        assert after == before, f"{what}: files left behind after errors: {sorted(set(after) - set(before))}"
    else:
        assert after == sorted(before + ["out.asm", "out.hex"]), f"{what}: files {after}"
        assert run.out.startswith(f"{hex_path}: ") and run.out.count("\n") == 1, f"{what}: {run.out!r}"
        image = check_hex(hex_path)
        rom = re.search(r"ROM (\d+)/8192 bytes", run.out)
        assert rom and int(rom[1]) == len(image), (run.out, len(image))
        with open(asm_path, encoding="utf-8") as f:
            assert f.read().strip(), f"{what}: empty assembly file"
    return run


def check_emit(path: str, text: str, form: str, lint_diags: list[Diag]) -> None:
    """`servoc lint --emit FORM`: the intermediate form as JSON, or lint's diagnostics and exit 1."""
    what = f"servoc lint --emit {form}"
    run = run_cli(["lint", "--emit", form, path])
    _no_crash(run, what)
    if any(d.severity == "error" for d in lint_diags):
        assert run.rc == 1 and run.out == "", f"{what}: exit {run.rc}, output {run.out[:200]!r}"
        assert text_diagnostics(run, path, text, what) == lint_diags
    else:
        assert run.rc == 0, f"{what}: exit {run.rc}\n{run.err}"
        assert json.loads(run.out)["kind"], f"{what}: no kind"


def exercise(data: bytes, compile_: bool = False, emit: tuple[str, ...] = (), name: str = "fuzz.servo") -> list[Diag]:
    """Every check on one input file; returns lint's diagnostics."""
    with tempfile.TemporaryDirectory(prefix="servoc-fuzz-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "wb") as f:
            f.write(data)
        text = SourceFile.from_bytes(path, data)[0].text
        try:
            diags = check_lint_and_plan(path, text)
            for form in emit:
                check_emit(path, text, form, diags)
            if compile_:
                check_compile(path, text, diags)
        except AssertionError as exc:
            shown = data.decode("utf-8", errors="backslashreplace")
            raise AssertionError(f"{exc}\n--- input ({len(data)} bytes):\n{shown[:6000]}") from None
    return diags


# ============================================================ valid programs

SPEEDS = [  # (option text, t_DAV in us); None = the default servo
    (None, DEFAULT_T_DAV_US),
    ("0.1s/60deg", t_dav_from_speed(Fraction(100_000), Fraction(60))),
    ("250ms/60deg", t_dav_from_speed(Fraction(250_000), Fraction(60))),
    ("0.15s/45deg", t_dav_from_speed(Fraction(150_000), Fraction(45))),   # the default's t_DAV, written otherwise
]
FRAME_SETTINGS = [None, None, "12ms", "15ms", "12500us", "0.02s", "16.5ms"]
FRAME_MAX_US = 20_000
TARGETS = [None, None, "target at89c52", "target AT89S52 clock 12MHz", "target stc89c52 clock 12000kHz",
           "target at89c52 clock 12000000Hz"]


@dataclass
class Servo:
    name: str
    port: int
    bit: int
    t_dav: Fraction
    lo: int          # the N a pose may give it: within its limit, and within 0..250 after reverse and trim
    hi: int
    decl: str


@dataclass
class Gen:
    """What the valid-program strategy has declared so far."""
    servos: list[Servo] = field(default_factory=list)
    groups: dict[str, list[str]] = field(default_factory=dict)       # name -> servo names
    poses: dict[str, dict[str, int]] = field(default_factory=dict)   # name -> servo -> N (after `with`)
    sequences: list[str] = field(default_factory=list)
    counter: int = 0

    def fresh(self, draw) -> str:
        self.counter += 1
        base = draw(st.sampled_from(["hip", "Knee", "_a", "x", "wrist2", "pan_tilt", "B", "p0", "P1x", "seq"]))
        return f"{base}_{self.counter}"

    def servo(self, name: str) -> Servo:
        return next(s for s in self.servos if s.name == name)


def fmt_us(us: int, draw) -> str:
    """A whole number of microseconds in a random time unit, exactly."""
    forms = [f"{us}us", f"{us}\u00b5s"]
    if us % 1000 == 0:
        forms.append(f"{us // 1000}ms")
    elif us % 10 == 0:
        forms.append(f"{us // 1000}.{us % 1000:03d}".rstrip("0") + "ms")
    whole, frac = divmod(us, 1_000_000)
    forms.append(f"{whole}.{frac:06d}".rstrip("0").rstrip(".") + "s" if frac else f"{whole}s")
    return draw(st.sampled_from(forms))


def fmt_position(n: int, draw) -> str:
    """A position that converts to exactly N: raw, an exact or inexact angle, an on- or off-grid width."""
    kind = draw(st.sampled_from(["raw", "raw", "deg", "deg_inexact", "us", "us_off", "ms"]))
    if kind == "raw":
        return str(n)
    if kind == "deg":                   # N x 0.74 deg is exact
        v = 74 * n
        return f"{v // 100}.{v % 100:02d}deg" if v % 100 else f"{v // 100}deg"
    if kind == "deg_inexact":           # within 0.36 deg of N x 0.74: still N
        v = 74 * n + draw(st.integers(0 if n == 0 else -36, 36))
        return f"{v // 100}.{v % 100:02d}deg"
    width = 500 + 8 * n
    if kind == "us":
        return f"{width}us"
    if kind == "us_off":                # rounds half up back to N (with a warning)
        return f"{width + draw(st.integers(0 if n == 0 else -4, 0 if n == 250 else 3))}us"
    return f"{width // 1000}.{width % 1000:03d}".rstrip("0").rstrip(".") + "ms"


def _servo_decl(draw, g: Gen, port: int, bit: int) -> Servo:
    name = g.fresh(draw)
    speed_text, t_dav = draw(st.sampled_from(SPEEDS))
    trim = draw(st.sampled_from([0, 0, 0, -3, 2, 5, -7]))
    reverse = draw(st.booleans())
    options = []
    if speed_text:
        options.append(f"speed {speed_text}")
    if trim or draw(st.integers(0, 4)) == 0:
        options.append(f"trim {draw(st.sampled_from(['+', '']))}{trim}" if trim >= 0 else f"trim {trim}")
    lo, hi = (max(0, trim), min(250, 250 + trim)) if reverse else (max(0, -trim), min(250, 250 - trim))
    if draw(st.integers(0, 2)) == 0:
        a = draw(st.integers(0, 200))
        b = draw(st.integers(a + 10, 250))
        # The bound's own N is what counts: write it in a unit that gives exactly that N.
        options.append(f"limit {fmt_position(a, draw)}..{fmt_position(b, draw)}")
        lo, hi = max(lo, a), min(hi, b)
    if reverse:
        options.append("reverse")
    options = draw(st.permutations(options))
    gap = draw(st.sampled_from([" ", " ", "\t", "  "]))
    decl = f"servo{gap}{name} = P{port}.{bit}" + "".join(f"{gap}{o}" for o in options)
    return Servo(name, port, bit, t_dav, lo, hi, decl)


def _entries(draw, g: Gen, pose: dict[str, int], allow_empty: bool) -> list[str]:
    """Pose entries over disjoint sets of servos, each with a position every servo it names accepts."""
    candidates = [(s.name, [s.name]) for s in g.servos] + list(g.groups.items())
    candidates += [(f"P{p}", [s.name for s in g.servos if s.port == p]) for p in range(3)
                   if any(s.port == p for s in g.servos)]
    chosen = draw(st.lists(st.sampled_from(candidates), min_size=0 if allow_empty else 1, max_size=5))
    covered: set[str] = set()
    entries = []
    for target, names in chosen:
        if not names or covered & set(names):
            continue
        lo = max(g.servo(n).lo for n in names)
        hi = min(g.servo(n).hi for n in names)
        if lo > hi:
            continue
        n = draw(st.one_of(st.integers(lo, hi), st.sampled_from([lo, hi])))
        covered |= set(names)
        for s in names:
            pose[s] = n
        entries.append(f"{target}: {fmt_position(n, draw)}")
    return entries


def _pose_text(draw, name: str, entries: list[str], base: str | None) -> str:
    head = f"pose {name} = {base} with" if base else f"pose {name}"
    if not entries:
        return f"{head} {{ }}"
    if draw(st.booleans()):
        return f"{head} {{ " + ", ".join(entries) + draw(st.sampled_from(["", ","])) + " }"
    sep = draw(st.sampled_from([",\n  ", "\n  ", ",\n\n  "]))
    return f"{head} {{\n  " + sep.join(entries) + draw(st.sampled_from(["", ","])) + "\n}"


def _duration_us(g: Gen, pose: str, extra: int) -> int:
    """A duration no servo of the pose can find too short, from any pose at any frame period used here:
    the widest delta it could have at its top speed, plus more than half the longest frame."""
    need = max((abs(n - m) * g.servo(s).t_dav
                for s, n in g.poses[pose].items()
                for m in [p[s] for p in g.poses.values() if s in p]), default=Fraction(0))
    return math.ceil(need) + FRAME_MAX_US // 2 + 1 + extra


def _stmt(draw, g: Gen, depth: int, max_depth: int, callable_seqs: list[str]) -> list[str]:
    """One statement as lines (a repeat spans several)."""
    kinds = ["move", "move", "move_in", "move_in", "hold"]
    kinds += ["repeat"] if depth < max_depth else []
    kinds += ["play"] if callable_seqs else []
    kind = draw(st.sampled_from(kinds))
    poses = sorted(g.poses)
    if kind == "move":
        return [f"move {draw(st.sampled_from(poses))}"]
    if kind == "move_in":
        pose = draw(st.sampled_from(poses))
        us = _duration_us(g, pose, draw(st.integers(0, 400_000)))
        us = draw(st.sampled_from([us, -(-us // 1000) * 1000, -(-us // 100_000) * 100_000]))
        ease = draw(st.sampled_from(["", "", " ease linear", " ease in", " ease out", " ease in-out"]))
        return [f"move {pose} in {fmt_us(us, draw)}{ease}"]
    if kind == "hold":
        return [f"hold {fmt_us(draw(st.integers(1, 1_000_000)), draw)}"]
    if kind == "play":
        return [f"play {draw(st.sampled_from(callable_seqs))}"]
    body = _block(draw, g, depth + 1, max_depth, callable_seqs, 1, 3)
    count = draw(st.integers(1, 3))
    if draw(st.booleans()):
        return [f"repeat {count} {{ " + "; ".join(body) + " }"]
    return [f"repeat {count} {{"] + ["  " + line for line in body] + ["}"]


def _block(draw, g: Gen, depth: int, max_depth: int, callable_seqs: list[str], lo: int, hi: int) -> list[str]:
    lines: list[str] = []
    for _ in range(draw(st.integers(lo, hi))):
        lines += _stmt(draw, g, depth, max_depth, callable_seqs)
    return lines


def _join_block(draw, head: str, lines: list[str]) -> str:
    if draw(st.integers(0, 3)) == 0 and all("{" not in line for line in lines):
        return f"{head} {{ " + "; ".join(lines) + " }"
    return f"{head} {{\n" + "\n".join("  " + line for line in lines) + "\n}"


@st.composite
def valid_programs(draw, min_servos: int = 1) -> str:
    """A program that `servoc lint` accepts without errors (warnings and notes allowed)."""
    g = Gen()
    pins = draw(st.lists(st.tuples(st.integers(0, 2), st.integers(0, 7)), min_size=min_servos, max_size=7,
                         unique=True))
    for port, bit in pins:
        g.servos.append(_servo_decl(draw, g, port, bit))
    decls = [s.decl for s in g.servos]
    for _ in range(draw(st.integers(0, 2))):
        members = draw(st.lists(st.sampled_from([s.name for s in g.servos] + list(g.groups)
                                                + [f"P{p}" for p in {s.port for s in g.servos}]),
                                min_size=1, max_size=4))
        servos: list[str] = []
        for m in members:
            found = g.groups.get(m) or ([s.name for s in g.servos if f"P{s.port}" == m]
                                        if m.startswith("P") and m[1:].isdigit() else [m])
            servos += [s for s in found if s not in servos]
        name = g.fresh(draw)
        g.groups[name] = servos
        decls.append(f"group {name} = " + draw(st.sampled_from([", ", ",\n    "])).join(members))
    for i in range(draw(st.integers(1, 4))):
        name = g.fresh(draw)
        pose: dict[str, int] = {}
        entries = _entries(draw, g, pose, allow_empty=i > 0)
        g.poses[name] = pose
        decls.append(_pose_text(draw, name, entries, None))
    for _ in range(draw(st.integers(0, 2))):
        name = g.fresh(draw)
        base = draw(st.sampled_from(sorted(g.poses)))
        pose = dict(g.poses[base])
        entries = _entries(draw, g, pose, allow_empty=True)
        g.poses[name] = pose
        decls.append(_pose_text(draw, name, entries, base))
    # Settings go before every sequence and main: at the top or among the declarations.
    settings_ = [t for t in (draw(st.sampled_from(TARGETS)),) if t]
    frame = draw(st.sampled_from(FRAME_SETTINGS))
    if frame:
        settings_.append(f"frame {frame}")
    for s in settings_:
        decls.insert(draw(st.integers(0, len(decls))), s)
    sequences = []
    for _ in range(draw(st.integers(0, 3))):
        name = g.fresh(draw)
        lines = _block(draw, g, 0, 1, list(g.sequences), 1, 4)
        sequences.append(_join_block(draw, f"sequence {name}", lines))
        g.sequences.append(name)
    main = _block(draw, g, 0, 2, list(g.sequences), 1, 5)
    if draw(st.booleans()):
        # The body takes frames for sure (a loop whose body takes none is an error): a move somewhere in it.
        body = [_stmt(draw, g, 1, 2, list(g.sequences)) for _ in range(draw(st.integers(0, 2)))]
        body.insert(draw(st.integers(0, len(body))), [f"move {draw(st.sampled_from(sorted(g.poses)))}"])
        main += ["loop {"] + ["  " + line for stmt in body for line in stmt] + ["}"]
    items = decls + sequences + [_join_block(draw, "main", main)]
    # main may come before the sequences it plays (names may be used before their declaration).
    if sequences and draw(st.booleans()):
        items = decls + [items[-1]] + sequences
    text = ""
    for item in items:
        text += item + draw(st.sampled_from(["\n", "\n", "\n\n", "  # a comment\n", ";\n", "\n# note: ;{}\n"]))
    if draw(st.integers(0, 5)) == 0:
        text = text.replace("\n", "\r\n")
    if draw(st.integers(0, 7)) == 0:
        text = "\ufeff" + text
    if draw(st.integers(0, 5)) == 0:
        text = text.rstrip("\r\n")      # no newline at the end of the file
    return text


# ============================================================ mutations

TOKEN_RE = re.compile(r"\s+|#[^\n]*|[A-Za-z_][A-Za-z0-9_]*|[0-9]+(?:\.[0-9]+)?[A-Za-z_\u00b5]*|\.\.|.", re.S)
UNITS = ["", "deg", "us", "\u00b5s", "\u03bcs", "ms", "s", "MHz", "kHz", "Hz", "DEG", "Ms", "x", "deg_"]
HUGE = ["99999999999999999999999999", "1" + "0" * 59, "1" + "0" * 60, "1" + "0" * 400, "0." + "0" * 300 + "1",
        "123456789012345678901234567890.5", "4294967296", "65536", "65535", "65535.5", "256", "251", "0", "0.0",
        "00000000000000000000000000000000000000000000000000000000000000000001"]
INSERTS = KEYWORDS + ["{", "}", ";", ",", ":", "=", "..", "/", "+", "-", "#", "\n", "P0", "P1", "P2", "P3",
                      "P1.0", "p2.7", "P9.9", "P0.8", "P00.01", "in-out", "\ufeff", "\x00", "\t", "\r", "\u2028"]


def _tokens(text: str) -> list[str]:
    return TOKEN_RE.findall(text)


def _solid(tokens: list[str]) -> list[int]:
    return [i for i, t in enumerate(tokens) if not t.isspace()]


def _number(draw) -> str:
    value = draw(st.one_of(st.integers(0, 300).map(str), st.sampled_from(HUGE),
                           st.decimals(0, 100000, places=3, allow_nan=False, allow_infinity=False).map(str)))
    return value + draw(st.sampled_from(UNITS))


def mutate_once(draw, text: str) -> str:
    op = draw(st.sampled_from([
        "delete_token", "duplicate_token", "swap_tokens", "delete_line", "duplicate_line", "swap_lines",
        "insert_char", "insert_word", "insert_number", "truncate", "replace_name", "huge_number",
        "replace_unit", "nest_repeats", "nest_braces", "chain", "join_lines", "insert_line"]))
    tokens = _tokens(text)
    solid = _solid(tokens)
    lines = text.split("\n")
    pos = draw(st.integers(0, len(text)))
    if op == "delete_token" and solid:
        del tokens[draw(st.sampled_from(solid))]
    elif op == "duplicate_token" and solid:
        i = draw(st.sampled_from(solid))
        tokens.insert(i, tokens[i] + draw(st.sampled_from([" ", ""])))
    elif op == "swap_tokens" and len(solid) > 1:
        i, j = draw(st.sampled_from(solid)), draw(st.sampled_from(solid))
        tokens[i], tokens[j] = tokens[j], tokens[i]
    elif op == "delete_line" and lines:
        del lines[draw(st.integers(0, len(lines) - 1))]
        return "\n".join(lines)
    elif op == "duplicate_line" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        lines.insert(draw(st.integers(0, len(lines))), lines[i])
        return "\n".join(lines)
    elif op == "swap_lines" and len(lines) > 1:
        i, j = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines) - 1))
        lines[i], lines[j] = lines[j], lines[i]
        return "\n".join(lines)
    elif op == "insert_line":
        line = " ".join(draw(st.lists(st.sampled_from(INSERTS + ["move", "pose", "90deg", "1s"]), max_size=6)))
        lines.insert(draw(st.integers(0, len(lines))), line)
        return "\n".join(lines)
    elif op == "join_lines":
        return text.replace("\n", draw(st.sampled_from([" ", ";", ""])), draw(st.integers(1, 3)))
    elif op == "insert_char":
        ch = draw(st.one_of(st.characters(codec="utf-8", exclude_categories=("Cs",)),
                            st.sampled_from(list("{}();:,.=#\"'\\/-+*@$%^&!?<>[]`~|") + ["\x00", "\x1b", "\r"])))
        return text[:pos] + ch + text[pos:]
    elif op == "insert_word":
        return text[:pos] + draw(st.sampled_from([" ", ""])) + draw(st.sampled_from(INSERTS)) + " " + text[pos:]
    elif op == "insert_number":
        return text[:pos] + " " + _number(draw) + " " + text[pos:]
    elif op == "truncate":
        return text[:pos]
    elif op == "replace_name":
        names = [i for i, t in enumerate(tokens) if re.fullmatch(r"[A-Za-z_]\w*", t)]
        if names:
            existing = sorted({tokens[i] for i in names})
            tokens[draw(st.sampled_from(names))] = draw(st.one_of(
                st.sampled_from(existing), st.sampled_from(KEYWORDS + ["P0", "P1", "P2", "P3", "main"]),
                st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,12}", fullmatch=True)))
    elif op in ("huge_number", "replace_unit"):
        numbers = [i for i, t in enumerate(tokens) if t[:1].isdigit()]
        if numbers:
            i = draw(st.sampled_from(numbers))
            value, unit = re.match(r"([0-9]+(?:\.[0-9]+)?)(.*)", tokens[i]).groups()
            if op == "huge_number":
                tokens[i] = draw(st.sampled_from(HUGE)) + (unit if draw(st.booleans()) else draw(st.sampled_from(UNITS)))
            else:
                tokens[i] = value + draw(st.sampled_from(UNITS))
    elif op == "nest_repeats":
        depth = draw(st.sampled_from([1, 2, 5, 12, 13, 99, 100, 101, 180]))
        stmt_lines = [i for i, line in enumerate(lines) if re.match(r"\s*(move|hold|play)\b", line)]
        if stmt_lines:
            i = draw(st.sampled_from(stmt_lines))
            word = draw(st.sampled_from(["repeat 2", "loop", "repeat 1"]))
            lines[i] = f"{word} {{ " * depth + lines[i].strip() + " }" * depth
            return "\n".join(lines)
    elif op == "nest_braces":
        depth = draw(st.sampled_from([1, 3, 50, 101, 1000]))
        return text[:pos] + draw(st.sampled_from(["{", "}", "{ "])) * depth + text[pos:]
    elif op == "chain":
        return text + "\n" + chain_text(draw(st.sampled_from(["play", "with", "group"])),
                                        draw(st.sampled_from([2, 13, 14, 120, 400])),
                                        draw(st.booleans()))
    return "".join(tokens)


def chain_text(kind: str, length: int, reverse: bool) -> str:
    """A chain of `length` declarations, each using the next (or, reversed, the previous) one."""
    if kind == "play":
        decls = [f"sequence c{i} {{ play c{i + 1} }}" for i in range(length)] + [f"sequence c{length} {{ hold 10ms }}"]
    elif kind == "with":
        decls = [f"pose c{i} = c{i + 1} with {{ }}" for i in range(length)] + [f"pose c{length} {{ }}"]
    else:
        decls = [f"group c{i} = c{i + 1}" for i in range(length)] + [f"group c{length} = P1"]
    if not reverse:
        decls.reverse()
    return "\n".join(decls) + "\n"


@st.composite
def mutated_programs(draw) -> bytes:
    text = draw(valid_programs())
    for _ in range(draw(st.integers(1, 4))):
        text = mutate_once(draw, text)
    data = text.encode("utf-8")
    if draw(st.integers(0, 9)) == 0:      # a byte that is not UTF-8 somewhere
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.sampled_from([b"\xff", b"\xc3", b"\xe2\x82", b"\xed\xa0\x80", b"\xc0\xaf"])) + data[at:]
    return data


# ============================================================ the campaign

@settings(max_examples=70, **FUZZ)
@given(valid_programs())
def test_valid_programs_lint_clean(text):
    diags = exercise(text.encode("utf-8"), emit=("ast", "model", "plan"))
    errors = [d for d in diags if d.severity == "error"]
    assert not errors, f"a valid program has errors: {errors}\n--- source:\n{text}"


@settings(max_examples=220, **FUZZ)
@given(mutated_programs(), st.sampled_from(["ast", "model", "plan"]))
def test_mutated_programs(data, form):
    exercise(data, emit=(form,))


@settings(max_examples=150, **FUZZ)
@given(st.one_of(st.binary(max_size=400),
                 st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=300)
                 .map(lambda t: t.encode("utf-8"))))
def test_random_bytes(data):
    exercise(data)


@settings(max_examples=15, **FUZZ)
@given(valid_programs())
def test_compile_valid_programs(text):
    diags = exercise(text.encode("utf-8"), compile_=True)
    assert not any(d.severity == "error" for d in diags)


@settings(max_examples=10, **FUZZ)
@given(mutated_programs())
def test_compile_mutated_programs(data):
    exercise(data, compile_=True)


@pytest.mark.parametrize("kind", ["play", "with", "group"])
@pytest.mark.parametrize("reverse", [False, True])
def test_long_chains_of_declarations(kind, reverse):
    """Chains far deeper than Python's recursion limit: diagnostics, never a crash."""
    head = "servo a = P1.0\npose p { a: 100 }\n"
    use = {"play": "main { move p; play c0 }\n", "with": "main { move p; move c0 }\n",
           "group": "pose q { c0: 7 }\nmain { move p; move q }\n"}[kind]
    text = head + chain_text(kind, 1200, reverse) + use
    diags = exercise(text.encode("utf-8"), compile_=True)
    if kind == "play":
        assert [d.code for d in diags if d.severity == "error"] == ["too-deep"]
    else:
        assert not any(d.severity == "error" for d in diags), diags


def test_long_but_valid_pose_chain_compiles():
    """Keyframes as a chain of `with` poses, declared last-first: a real program, not just no crash."""
    n = 1500
    text = "servo a = P1.0 speed 0.01s/60deg\n"
    text += "".join(f"pose k{i} = k{i + 1} with {{ a: {i % 250} }}\n" for i in range(n)) + f"pose k{n} {{ a: 0 }}\n"
    text += "main {\n" + "".join(f"  move k{i}\n" for i in range(n, n - 40, -1)) + "}\n"
    diags = exercise(text.encode("utf-8"), compile_=True)
    assert not any(d.severity == "error" for d in diags)


@pytest.mark.parametrize("where", ["hex_in_missing_folder", "asm_in_missing_folder", "hex_is_a_folder"])
def test_unwritable_output_is_a_usage_error(tmp_path, where):
    """An output that cannot be written: exit 2 with the path, no traceback, no HEX anywhere."""
    src = tmp_path / "prog.servo"
    src.write_text("servo a = P1.0\npose p { a: 100 }\nmain { move p }\n", encoding="utf-8")
    (tmp_path / "folder").mkdir()
    hex_path, asm_path = str(tmp_path / "prog.hex"), None
    if where == "hex_in_missing_folder":
        hex_path = str(tmp_path / "missing" / "prog.hex")
    elif where == "asm_in_missing_folder":
        asm_path = str(tmp_path / "missing" / "prog.asm")
    else:
        hex_path = str(tmp_path / "folder")
    run = run_cli(["compile", str(src), "-o", hex_path] + (["--asm", asm_path] if asm_path else []))
    assert run.rc == 2 and "Traceback" not in run.err and "internal error" not in run.err, run.err
    assert run.err.startswith(f"servoc: error: cannot write {asm_path or hex_path}: "), run.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "prog.servo"]
    assert list((tmp_path / "folder").iterdir()) == []


# ============================================================ determinism

def _compile_in(folder: Path, text: str) -> tuple[bytes, bytes]:
    folder.mkdir(parents=True)
    src = folder / "prog.servo"
    src.write_text(text, encoding="utf-8")
    run = run_cli(["compile", str(src), "-o", str(folder / "prog.hex"), "--asm", str(folder / "prog.asm")])
    assert run.rc == 0, run.err
    return (folder / "prog.hex").read_bytes(), (folder / "prog.asm").read_bytes()


@settings(max_examples=6, **FUZZ)
@given(valid_programs())
def test_compile_is_deterministic(text):
    with tempfile.TemporaryDirectory(prefix="servoc-det-") as a, tempfile.TemporaryDirectory(prefix="servoc-det-") as b:
        first = _compile_in(Path(a) / "one", text)
        second = _compile_in(Path(b) / "two" / "deeper", text)
    assert first[0] == second[0], "the HEX depends on where the source is"
    assert first[1] == second[1], "the assembly depends on where the source is"


def test_compile_is_deterministic_across_processes(tmp_path):
    """Separate interpreters with different hash seeds (set and dict order of names): the same bytes."""
    text = (ROOT / "examples" / "biped.servo").read_text(encoding="utf-8")
    outputs = []
    for seed in ("1", "2"):
        folder = tmp_path / f"seed{seed}" / "x"
        folder.mkdir(parents=True)
        (folder / "biped.servo").write_text(text, encoding="utf-8")
        env = dict(os.environ, PYTHONHASHSEED=seed)
        proc = subprocess.run([sys.executable, "-m", "servoc", "compile", "biped.servo", "--asm", "biped.asm"],
                              cwd=folder, env=env, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        outputs.append(((folder / "biped.hex").read_bytes(), (folder / "biped.asm").read_bytes()))
    assert outputs[0] == outputs[1]
