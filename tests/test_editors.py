"""The editor grammar covers the language, and the documented problem matcher reads servoc's diagnostics."""

import json
import re
from pathlib import Path

from servoc import api
from servoc.diagnostics import render_short
from servoc.syntax import keywords

ROOT = Path(__file__).resolve().parent.parent
GRAMMAR = json.loads((ROOT / "editors" / "servo.tmLanguage.json").read_text(encoding="utf-8"))


def _patterns(node):
    if isinstance(node, dict):
        if "match" in node:
            yield node["match"]
        for value in node.values():
            yield from _patterns(value)
    elif isinstance(node, list):
        for value in node:
            yield from _patterns(value)


def test_every_keyword_is_highlighted():
    regexes = [re.compile(p) for p in _patterns(GRAMMAR["repository"])]
    for word in keywords():
        assert any(r.search(f" {word} ") for r in regexes if "P[0-2]" not in r.pattern), word


def test_pins_units_and_comments():
    repo = GRAMMAR["repository"]
    assert re.fullmatch(repo["pin"]["match"], "P2.7") and not re.fullmatch(repo["pin"]["match"], "P3.0")
    m = re.search(repo["quantity"]["match"], "hold 1.5s")
    assert m and m.group(1) == "1.5" and m.group(2) == "s"
    assert re.search(repo["comment"]["match"], "move a  # note").group(0) == "# note"


def test_problem_matcher_reads_diagnostics(tmp_path):
    text = (ROOT / "editors" / "README.md").read_text(encoding="utf-8")
    regex = json.loads(re.search(r"```json\n(.*?)```", text, re.S).group(1))["tasks"][0]["problemMatcher"]["pattern"]["regexp"]
    prog = tmp_path / "fast.servo"
    prog.write_text("servo a = P1.0\npose p { a: 0 }\npose q { a: 250 }\nmain {\n  move p\n  move q in 10ms\n}\n")
    source, reporter = api.load_source(str(prog))
    api.front_end(source, reporter)
    lines = [render_short(d, source) for d in reporter.diagnostics]
    assert lines
    for line in lines:
        m = re.match(regex, line)
        assert m, line
    err = next(re.match(regex, line) for line in lines if ": error: " in line)
    assert (err.group(2), err.group(3), err.group(4), err.group(6)) == ("6", "3", "error", "infeasible-speed")
