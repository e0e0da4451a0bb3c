"""The language reference in docs/*.md: every example in it is checked.

Fenced blocks, by info string:
- `servo`: a complete program that lints with no errors and no warnings;
- `servo wrong=CODE`: a program whose lint reports CODE with the severity the
  docs give for CODE (its `### CODE (severity)` heading), and no other error
  or warning; under a `### CODE (...)` heading, a clean `servo` block (the
  fix) follows it in the same section;
- `text` / `sh`: not run, except a `text` block that shows servoc's output for
  the nearest program block above it, recognised by its first line:
  `prog.servo: ` (the `servoc lint` summary line), `prog.servo:LINE:COL:`
  (`servoc lint` diagnostics as text), `{` (`servoc lint --format json`),
  `frame period P` (the `servoc plan` table) or `frame:` (a frame table: the
  N of the program's one servo in each frame, checked against the planner).

Coverage: every code of the lint registry and of the checker and parser has a
`wrong=` example; every code servoc can report has a heading with its severity.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import itertools
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from servoc import api, cli, costs, units
from servoc.diagnostics import render_short
from servoc.lint import RULES
from servoc.plan import expand
from servoc.syntax import keywords

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
SERVOC = ROOT / "servoc"
KNOWN_INFO = ("servo", "text", "sh")
WRONG_RE = re.compile(r"servo wrong=([a-z0-9-]+)\Z")
HEADING_RE = re.compile(r"#{1,6} ")
CODE_HEADING_RE = re.compile(r"### ([a-z0-9-]+) \((error|warning|note)\)\s*\Z")
REPORT_RE = re.compile(r"\b(error|warning|note)\(\s*\"([a-z0-9-]+)\"")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int               # line of the opening fence, 1-based
    info: str
    text: str
    section: int            # index of the heading above it, counted over the file
    heading: str

    @property
    def id(self) -> str:
        return f"{self.path.name}:{self.line}"

    @property
    def wrong(self) -> str | None:
        m = WRONG_RE.match(self.info)
        return m.group(1) if m else None


def doc_files() -> list[Path]:
    return sorted(DOCS.glob("*.md"))


def read_blocks(path: Path) -> list[Block]:
    blocks: list[Block] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    section, heading = 0, ""
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            start, info = i + 1, line[3:].strip()
            body: list[str] = []
            i += 1
            while i < len(lines) and lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
            assert i < len(lines), f"{path.name}:{start}: unclosed code block"
            blocks.append(Block(path, start, info, "\n".join(body) + "\n", section, heading))
        elif HEADING_RE.match(line):
            section += 1
            heading = line
        i += 1
    return blocks


def all_blocks() -> list[Block]:
    return [b for p in doc_files() for b in read_blocks(p)]


def code_severities() -> dict[str, str]:
    """Code -> severity, from the `### CODE (severity)` headings of the docs."""
    found: dict[str, str] = {}
    for path in doc_files():
        for line in path.read_text(encoding="utf-8").splitlines():
            m = CODE_HEADING_RE.match(line)
            if m:
                assert m.group(1) not in found, f"{m.group(1)} has two headings"
                found[m.group(1)] = m.group(2)
    return found


def reported_codes(*files: str) -> dict[str, str]:
    """Code -> severity of every literal `error("code"`/`warning(`/`note(` call in servoc/FILES."""
    found: dict[str, str] = {}
    for name in files:
        for sev, code in REPORT_RE.findall((SERVOC / name).read_text(encoding="utf-8")):
            assert found.get(code, sev) == sev, f"{code} is reported with two severities"
            found[code] = sev
    return found


CHECKER_FILES = tuple(sorted(str(p.relative_to(SERVOC)) for p in (SERVOC / "check").glob("*.py")))


def layout_codes() -> dict[str, str]:
    """Codes of the firmware's resource errors (servoc/layout.py: `code = "..."` on each LayoutError)."""
    from servoc import layout
    return {cls.code: "error" for cls in layout.LayoutError.__subclasses__()}


def checker_codes() -> dict[str, str]:
    return reported_codes(*CHECKER_FILES, "syntax.py")


def registry_codes() -> dict[str, str]:
    return {code: sev.value for code, (sev, _) in RULES.items()}


BLOCKS = all_blocks()
PROGRAMS = [b for b in BLOCKS if b.info == "servo" or b.wrong]


def lint(text: str, tmp_path: Path):
    """Lint `text` as prog.servo: (diagnostics, plan or None, source)."""
    path = tmp_path / "prog.servo"
    path.write_text(text, encoding="utf-8")
    source, reporter = api.load_source(str(path))
    fe = api.front_end(source, reporter)
    return reporter.sorted(), fe.plan, source


def cli_output(text: str, tmp_path: Path, *args: str) -> tuple[int, str, str]:
    """Run `servoc ARGS prog.servo` in-process from tmp_path: (exit code, stdout, stderr)."""
    (tmp_path / "prog.servo").write_text(text, encoding="utf-8")
    out, err = io.StringIO(), io.StringIO()
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = cli.main([*args, "prog.servo"])
    finally:
        os.chdir(cwd)
    return rc, out.getvalue(), err.getvalue()


# ---- the blocks ---------------------------------------------------------------

def test_docs_have_programs():
    assert doc_files(), "docs/*.md is missing"
    assert len([b for b in PROGRAMS if b.info == "servo"]) >= 30
    assert len([b for b in PROGRAMS if b.wrong]) >= 39


@pytest.mark.parametrize("block", BLOCKS, ids=[b.id for b in BLOCKS])
def test_info_string_is_known(block: Block):
    assert block.info in KNOWN_INFO or block.wrong, (
        f"{block.id}: info string `{block.info}`; use servo, servo wrong=CODE, text or sh")


@pytest.mark.parametrize("block", PROGRAMS, ids=[b.id for b in PROGRAMS])
def test_program(block: Block, tmp_path: Path):
    diags, _, source = lint(block.text, tmp_path)
    shown = "\n".join(render_short(d, source) for d in diags)
    loud = [d for d in diags if d.severity.value != "note"]
    if block.wrong is None:
        assert not loud, f"{block.id}: expected no errors or warnings, got:\n{shown}"
        return
    code = block.wrong
    severity = code_severities().get(code)
    assert severity, f"{block.id}: `{code}` has no `### {code} (severity)` heading"
    hits = [d for d in diags if d.code == code]
    assert hits, f"{block.id}: expected [{code}], got:\n{shown or '(nothing)'}"
    assert all(d.severity.value == severity for d in hits), f"{block.id}: [{code}] is not a {severity}:\n{shown}"
    others = [d for d in loud if d.code != code]
    assert not others, f"{block.id}: expected only [{code}], also got:\n{shown}"


UNDER_CODES = [b for b in PROGRAMS if CODE_HEADING_RE.match(b.heading)]


@pytest.mark.parametrize("block", UNDER_CODES, ids=[b.id for b in UNDER_CODES])
def test_code_section(block: Block):
    code = CODE_HEADING_RE.match(block.heading).group(1)
    if block.info == "servo":
        return
    assert block.wrong == code, f"{block.id}: a `wrong={block.wrong}` example under {block.heading!r}"
    fixes = [b for b in BLOCKS if b.path == block.path and b.section == block.section
             and b.line > block.line and b.info == "servo"]
    assert fixes, f"{block.id}: no fixed `servo` example follows the wrong one in its section"


# ---- output shown in text blocks ----------------------------------------------

def shown_output(pattern: str) -> list[tuple[Block, Block]]:
    """(text block, the program block above it) for text blocks whose start matches `pattern`."""
    out = []
    for path in doc_files():
        blocks = read_blocks(path)
        for i, b in enumerate(blocks):
            if b.info == "text" and re.match(pattern, b.text):
                program = next((p for p in reversed(blocks[:i]) if p.info == "servo" or p.wrong), None)
                assert program is not None, f"{b.id}: no program block above this output"
                out.append((b, program))
    return out


LINT_LINES = shown_output(r"prog\.servo: ")
LINT_TEXT = shown_output(r"prog\.servo:\d+:\d+: ")
LINT_JSON = shown_output(r"\{")
PLAN_TABLES = shown_output(r"frame period P")
FRAME_TABLES = shown_output(r"frame:")


@pytest.mark.parametrize("pair", LINT_TEXT, ids=[b.id for b, _ in LINT_TEXT])
def test_lint_text(pair, tmp_path: Path):
    shown, program = pair
    rc, _, err = cli_output(program.text, tmp_path, "lint")
    assert rc == (1 if program.wrong and code_severities()[program.wrong] == "error" else 0)
    assert err.rstrip() == shown.text.rstrip(), f"{shown.id}: servoc lint prints\n{err}"


@pytest.mark.parametrize("pair", LINT_JSON, ids=[b.id for b, _ in LINT_JSON])
def test_lint_json(pair, tmp_path: Path):
    shown, program = pair
    _, out, _ = cli_output(program.text, tmp_path, "lint", "--format", "json")
    assert json.loads(out) == json.loads(shown.text), f"{shown.id}: servoc lint --format json prints\n{out}"


@pytest.mark.parametrize("pair", LINT_LINES, ids=[b.id for b, _ in LINT_LINES])
def test_lint_summary_line(pair, tmp_path: Path):
    shown, program = pair
    rc, out, _ = cli_output(program.text, tmp_path, "lint")
    assert rc == 0
    assert out.strip() == shown.text.strip(), f"{shown.id}: servoc lint prints\n{out}"


@pytest.mark.parametrize("pair", PLAN_TABLES, ids=[b.id for b, _ in PLAN_TABLES])
def test_plan_table(pair, tmp_path: Path):
    shown, program = pair
    rc, out, _ = cli_output(program.text, tmp_path, "plan")
    assert rc == 0
    assert out.strip() == shown.text.strip(), f"{shown.id}: servoc plan prints\n{out}"


@pytest.mark.parametrize("pair", FRAME_TABLES, ids=[b.id for b, _ in FRAME_TABLES])
def test_frame_table(pair, tmp_path: Path):
    shown, program = pair
    rows = dict(line.split(":", 1) for line in shown.text.splitlines() if ":" in line)
    frames = [int(x) for x in rows["frame"].split()]
    ns = [int(x) for x in rows["N"].split()]
    assert frames == list(range(1, len(ns) + 1))
    _, plan, _ = lint(program.text, tmp_path)
    assert plan is not None and len(plan.channels) == 1
    golden = [f.n[0] for f in itertools.islice(expand(plan), len(ns))]
    assert golden == ns, f"{shown.id}: the planner gives {golden}"
    if plan.total_frames is not None:
        assert plan.total_frames <= len(ns), f"{shown.id}: the table stops before main ends"


def test_output_examples_exist():
    assert LINT_LINES and LINT_TEXT and LINT_JSON and PLAN_TABLES and FRAME_TABLES


# ---- coverage of the diagnostic codes -------------------------------------------

def test_checker_codes_found():
    # The grep must keep seeing the checker's and parser's codes.
    codes = checker_codes()
    assert {"syntax-error", "unknown-name", "bad-unit", "recursion", "empty-port"} <= set(codes)
    assert len(codes) >= 20


def test_every_code_has_a_wrong_example():
    needed = set(registry_codes()) | set(checker_codes())
    shown = {b.wrong for b in PROGRAMS if b.wrong}
    missing = sorted(needed - shown)
    assert not missing, f"codes with no `servo wrong=CODE` example in docs/: {missing}"


def test_every_code_is_documented_with_its_severity():
    actual = {**reported_codes(*CHECKER_FILES, "syntax.py", "api.py"), **layout_codes(), **registry_codes()}
    documented = code_severities()
    missing = sorted(set(actual) - set(documented))
    assert not missing, f"codes with no `### CODE (severity)` heading in docs/: {missing}"
    unknown = sorted(set(documented) - set(actual))
    assert not unknown, f"docs describe codes servoc does not report: {unknown}"
    wrong = {c: (documented[c], actual[c]) for c in actual if documented[c] != actual[c]}
    assert not wrong, f"severity in the docs vs in servoc: {wrong}"


# ---- numbers quoted in the text --------------------------------------------------

def doc_text() -> str:
    return "\n".join(p.read_text(encoding="utf-8") for p in doc_files())


def test_angle_table():
    rows = re.findall(r"^\| `([0-9.]+)deg` \| (\d+) \| (\d+) µs \| ([0-9.]+)° \|$", doc_text(), re.M)
    assert len(rows) >= 5
    for angle, n, width, exact in rows:
        got = units.deg_to_n(units.Fraction(angle))
        assert got == int(n), f"{angle}deg is N {got}"
        assert units.n_to_width_us(got) == int(width)
        assert units.fmt_deg(units.n_to_deg(got)) == exact + "°"


def test_min_period_formula(tmp_path: Path):
    text = doc_text()
    assert (f"Σ span                                        the pulses: span = C(top) + {costs.SPLIT} "
            f"({costs.RISE_STEP} with steps;\n" + " " * 48 + "C(top) - C(bottom') + emit with rises among falls)") in text
    assert f"at a time {costs.STEP} cycles or more from every fall" in text and f"C(top) + {costs.STEP}, so that" in text
    assert f"fixed {costs.ENTRY} cycles before the edge" in text and f"less than {costs.SPLIT} cycles apart" in text
    # the worked example quotes what servoc reports
    (tmp_path / "one.servo").write_text("servo arm = P1.0\npose a { arm: 100 }\nmain { move a }\n", encoding="utf-8")
    source, reporter = api.load_source(str(tmp_path / "one.servo"))
    plan = api.front_end(source, reporter).plan
    assert f"one servo on P1 moved by one pose to N 100: P_min = {plan.min_period_us} µs" in text
    assert units.DEFAULT_PERIOD_FLOOR_US == 5300 and units.DEFAULT_T_DAV_US == units.Fraction(7400, 3)
    assert "2.467 ms" in text


def test_hexapod_period_quoted(tmp_path: Path, monkeypatch):
    source, reporter = api.load_source(str(ROOT / "examples" / "hexapod.servo"))
    plan = api.front_end(source, reporter).plan
    assert plan is not None and plan.nesting == 2 and plan.period_us == max(plan.min_period_us, units.DEFAULT_PERIOD_FLOOR_US)
    assert f"`examples/hexapod.servo`" in doc_text() and \
        f"{plan.min_period_us} µs (its default P is {plan.period_us / 1000:g} ms)" in doc_text()
    # the spans, the pulses, everything a frame does and the ports one after another, as the code has them
    from servoc import codegen, costs
    unit = codegen.generate(plan, source)
    b = unit.budget
    load = costs.frame_load(b)
    apart = codegen.generate(plan, source, stepping=True, stagger=False).min_period_us
    text = " ".join(doc_text().split())
    spans = ", ".join(str(v) for v in b.spans[:-1]) + f" and {b.spans[-1]}"
    assert b.stagger and f"their spans are {spans} cycles (the pulses: {sum(b.spans)})" in text
    assert f"and P_min is {plan.min_period_us} µs" in text and unit.target.cycles(plan.min_period_us) == sum(b.sorts) + b.work + load
    assert f"and falls), {sum(b.sorts) + b.work + load} cycles, binds it" in text
    assert b.frame_falls < sum(b.falls) and f"take the handler longest, {b.frame_falls} cycles, not each port's " \
        f"worst frame apart ({b.falls[0]} + {b.falls[1]} + {b.falls[2]})" in text
    assert b.pair_falls < b.falls[1] + b.falls[2] and \
        f"worst frame together, {b.pair_falls} cycles ({b.falls[1]} + {b.falls[2]} apart)" in text
    assert f"P_min would be {apart} µs, the pulses themselves" in text
    # each port's list charged for the most distinct N its lines fall at in one frame
    motions = codegen.port_motions(plan)
    distinct = [costs.port_load(unit.target, motions[p]).distinct for p in plan.ports]
    monkeypatch.setattr(codegen, "_unread", lambda *args: 0)
    monkeypatch.setattr(codegen, "_budgets", type(codegen._budgets)())     # none kept from the code's own
    every = codegen.generate(plan, source).budget
    saved = sum(every.sorts) - sum(b.sorts)
    assert f"at most {distinct[0]}, {distinct[1]} and {distinct[2]} distinct N" in text and max(distinct) < 8
    assert saved > 0 and f"not 8: {saved} cycles less" in text
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert f"({distinct[0]}, {distinct[1]} and {distinct[2]} of 8: {saved} cycles less)" in readme
    assert costs.frame_cycles(unit.target, every) - costs.frame_cycles(unit.target, b) == saved
    whole = costs.fit_spans(unit.target, dataclasses.replace(b, heads=()), b.tops)[0]     # P1's sort by its rise
    assert b.spans[0] < whole and f"P0's span would be {whole} cycles if P1's sort and list" in text
    assert unit.target.width_cycles(b.bottoms[0]) < b.spans[0] and f"P0's lowest fall, N {b.bottoms[0]}, can come" in text


def test_keyword_list():
    m = re.search(r"\*\*Keywords\*\*[^`]*```text\n(.*?)```", doc_text(), re.S)
    assert m, "the keyword list is missing"
    assert set(m.group(1).split()) == set(keywords()) - {"in-out"}


@pytest.mark.parametrize("levels", [15, 16])
def test_nesting_limit(levels: int, tmp_path: Path):
    # The docs say: with servos on three ports, 15 levels of nested `repeat`s and `play`s fit; lint's
    # too-deep says so first.
    text = ("servo arm = P1.0\nservo leg = P2.0\nservo tail = P0.0\npose a { arm: 100, leg: 100, tail: 100 }\n"
            "pose b { arm: 120, leg: 120, tail: 120 }\nmain {\n" + "repeat 2 {\n" * levels
            + "move a in 100ms\nmove b in 100ms\n" + "}\n" * levels + "}\n")
    assert "| 3 | 46 bytes | 15 | 12 | 5 | 3 |" in doc_text() and costs.max_nesting(ports=3) == 15
    (tmp_path / "prog.servo").write_text(text, encoding="utf-8")
    source, reporter = api.load_source(str(tmp_path / "prog.servo"))
    fe = api.front_end(source, reporter)
    assert fe.plan is not None
    lint_codes = [d.code for d in reporter.diagnostics if d.is_error]
    unit = api.generate(fe.plan, source, reporter)
    codes = [d.code for d in reporter.diagnostics if d.is_error]
    if levels <= 15:
        assert unit is not None and codes == []
    else:
        assert lint_codes == ["too-deep"]
        assert unit is None and codes == ["too-deep", "too-deep"]
