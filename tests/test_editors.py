"""Editor support: the VS Code extension in editors/vscode.

The TextMate grammar is checked with the engine VS Code itself uses
(vscode-textmate on vscode-oniguruma, driven by editors/vscode/test/tokenize.js);
the extension's manifest, its activation (editors/vscode/test/activate.js) and
the `$servoc` problem matcher against real `servoc lint` output.

These tests need Node.js and npm. When editors/vscode/node_modules lacks the
engine, they install it there (`npm ci`, from package-lock.json) first; they
fail, never skip, when node or npm is missing.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from servoc.syntax import keywords

ROOT = Path(__file__).resolve().parent.parent
EDITORS = ROOT / "editors"
EXT = EDITORS / "vscode"
GRAMMAR_PATH = EXT / "syntaxes" / "servo.tmLanguage.json"
PACKAGE = json.loads((EXT / "package.json").read_text(encoding="utf-8"))
NODE_PACKAGES = ("vscode-textmate", "vscode-oniguruma", "vscode-languageclient")

BAD_PROGRAM = "servo a = P1.0\npose p { a: 0 }\npose q { a: 250 }\nhome p\nmain {\n  move p\n  move q in 10ms\n}\n"


# ---------------------------------------------------------------- node and the engine

def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"`{name}` is not on PATH: the editor tests need Node.js (18 or later) and npm "
                    "to run the TextMate engine (Debian/Ubuntu: apt-get install nodejs npm)", pytrace=False)
    return path


@pytest.fixture(scope="session")
def node() -> str:
    """The node executable, with the extension's npm packages installed in editors/vscode/node_modules."""
    node = _tool("node")
    if not all((EXT / "node_modules" / pkg / "package.json").is_file() for pkg in NODE_PACKAGES):
        npm = _tool("npm")
        env = dict(os.environ, npm_config_audit="false", npm_config_fund="false",
                   npm_config_update_notifier="false", npm_config_yes="true")
        proc = subprocess.run([npm, "ci", "--no-audit", "--no-fund"], cwd=EXT, env=env, stdin=subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=600)
        if proc.returncode != 0:
            pytest.fail(f"`npm ci` in {EXT} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}", pytrace=False)
    return node


def _run_node(node: str, script: str, *args: str, stdin: str | None = None) -> str:
    proc = subprocess.run([node, str(EXT / "test" / script), *args], cwd=EXT, input=stdin,
                          stdin=None if stdin is not None else subprocess.DEVNULL,
                          capture_output=True, text=True, encoding="utf-8", timeout=120)
    assert proc.returncode == 0, f"node {script} failed:\n{proc.stderr}"
    return proc.stdout


def tokenize(node: str, text: str) -> list[list[tuple[str, tuple[str, ...]]]]:
    """One list of (token text, scopes) per line of `text`, as VS Code tokenizes it."""
    out = json.loads(_run_node(node, "tokenize.js", stdin=json.dumps({"text": text})))
    return [[(t["text"], tuple(t["scopes"])) for t in line] for line in out]


def tokens_of(line: list[tuple[str, tuple[str, ...]]], text: str, nth: int = 0) -> list[tuple[str, tuple[str, ...]]]:
    """The tokens that make up the `nth` occurrence of `text` in a tokenized line (their edges must be token edges)."""
    whole = "".join(t for t, _ in line)
    start = -1
    for _ in range(nth + 1):
        start = whole.index(text, start + 1)
    end, pos, found = start + len(text), 0, []
    for tok, scopes in line:
        if pos >= start and pos + len(tok) <= end:
            found.append((tok, scopes))
        elif pos < end and pos + len(tok) > start:
            raise AssertionError(f"{text!r} is not a whole number of tokens: {tok!r} {scopes} crosses its edge")
        pos += len(tok)
    return found


def one_token(line, text: str, nth: int = 0) -> tuple[str, ...]:
    """The scopes of `text`, which must be exactly one token."""
    found = tokens_of(line, text, nth)
    assert [t for t, _ in found] == [text], f"{text!r} is split into {found}"
    return found[0][1]


def has(scopes, prefix: str) -> bool:
    return any(s == prefix or s.startswith(prefix + ".") for s in scopes)


def is_keyword(scopes) -> bool:
    return has(scopes, "keyword") or has(scopes, "storage.type")


def assert_number(line, text: str, unit: str = "") -> None:
    """`text` is a number (every token of it constant.numeric), its unit (if any) one token scoped as a unit."""
    found = tokens_of(line, text)
    assert found and all(has(s, "constant.numeric") for _, s in found), (text, found)
    assert not any(has(s, "variable") or has(s, "entity") for _, s in found), (text, found)
    units = [t for t, s in found if has(s, "keyword.other.unit")]
    assert units == ([unit] if unit else []), (text, found)


# ---------------------------------------------------------------- the grammar, tokenized

def test_the_grammar_has_one_source():
    """Other editors read editors/servo.tmLanguage.json; it is the extension's grammar, byte for byte."""
    assert (EDITORS / "servo.tmLanguage.json").read_bytes() == GRAMMAR_PATH.read_bytes(), \
        "copy editors/vscode/syntaxes/servo.tmLanguage.json to editors/servo.tmLanguage.json"
    grammar = json.loads(GRAMMAR_PATH.read_text(encoding="utf-8"))
    assert grammar["scopeName"] == "source.servo" and grammar["fileTypes"] == ["servo"]


def test_every_keyword_is_a_keyword(node):
    words = sorted(keywords())
    lines = tokenize(node, "\n".join(f"{word} " for word in words) + "\nin-out\n")
    for word, line in zip(words + ["in-out"], lines):
        assert is_keyword(one_token(line, word)), (word, line)


def test_names_are_not_keywords(node):
    text = "\n".join([
        "servo mode = P1.0",
        "pose stand { mode: 90deg, low: 1, high: 2 }",
        "group legs = inout, mainloop, servo_2, linear_",
        "main { move stand; play moves }",
    ])
    lines = tokenize(node, text)
    assert has(one_token(lines[0], "mode"), "entity.name")
    assert has(one_token(lines[1], "stand"), "entity.name")
    for word in ("mode", "low", "high"):
        scopes = one_token(lines[1], word)
        assert not is_keyword(scopes) and has(scopes, "variable"), (word, scopes)
    for word in ("legs", "inout", "mainloop", "servo_2", "linear_"):
        scopes = one_token(lines[2], word)
        assert not is_keyword(scopes) and not has(scopes, "constant"), (word, scopes)
    assert has(one_token(lines[3], "stand"), "variable") and has(one_token(lines[3], "moves"), "variable")
    assert is_keyword(one_token(lines[3], "move")) and is_keyword(one_token(lines[3], "play"))


def test_setting_and_edge_words_are_keywords_only_where_the_grammar_expects_them(node):
    lines = tokenize(node, "\n".join([
        "input release = P3.2",
        "pose home { a: 1 }",
        "home home",
        "stagger 100ms",
        "main { wait release release; move home until press release }",
    ]))
    assert not is_keyword(one_token(lines[0], "release")) and not is_keyword(one_token(lines[1], "home"))
    assert is_keyword(one_token(lines[2], "home")) and not is_keyword(one_token(lines[2], "home", nth=1))
    assert is_keyword(one_token(lines[3], "stagger"))
    for word, nth, keyword in (("wait", 0, True), ("release", 0, True), ("release", 1, False),
                               ("until", 0, True), ("press", 0, True), ("release", 2, False), ("home", 0, False)):
        assert is_keyword(one_token(lines[4], word, nth=nth)) == keyword, (word, nth, lines[4])


def test_host_and_channel_are_keywords_only_where_the_grammar_expects_them(node):
    lines = tokenize(node, "\n".join([
        "host ssc32",
        "servo channel = P1.0 channel 3",
        "pose host { channel: 1 }",
        "main { host; move host; host until press stop }",
        "  host",
    ]))
    assert is_keyword(one_token(lines[0], "host")) and not is_keyword(one_token(lines[0], "ssc32"))
    assert has(one_token(lines[0], "ssc32"), "entity.name")
    assert not is_keyword(one_token(lines[1], "channel")) and is_keyword(one_token(lines[1], "channel", nth=1))
    assert not is_keyword(one_token(lines[2], "host")) and not is_keyword(one_token(lines[2], "channel"))
    for nth, keyword in ((0, True), (1, False), (2, True)):
        assert is_keyword(one_token(lines[3], "host", nth=nth)) == keyword, (nth, lines[3])
    assert is_keyword(one_token(lines[4], "host"))


def test_in_out_is_one_token(node):
    lines = tokenize(node, "  move shift_l in 200ms ease in-out\n  move a in 1s ease in\n  move b in 1s ease out # back\n")
    scopes = one_token(lines[0], "in-out")
    assert has(scopes, "keyword"), scopes
    assert has(one_token(lines[0], "in"), "keyword.control")            # the duration's `in`
    assert has(one_token(lines[1], "in", nth=1), "keyword.other.ease-curve")
    assert has(one_token(lines[2], "out"), "keyword.other.ease-curve")
    assert_number(lines[0], "200ms", "ms")


def test_target_chip_clock_and_mode(node):
    lines = tokenize(node, "\n".join([
        "target stc89c52rc clock 11.0592MHz mode 6T   # 6 clocks a cycle",
        "target at89c52 clock 12MHz",
        "target stc89c52 mode 12T",
        "pose mode { arm: 90deg }",
        "servo arm = P1.0",
    ]))
    first = lines[0]
    assert has(one_token(first, "target"), "storage.type")
    chip = one_token(first, "stc89c52rc")
    assert not has(chip, "constant") and has(chip, "entity.name.type"), chip
    assert has(one_token(first, "clock"), "keyword")
    assert_number(first, "11.0592MHz", "MHz")
    assert has(one_token(first, "mode"), "keyword")
    assert_number(first, "6T", "T")
    assert all(has(s, "comment.line") for _, s in tokens_of(first, "# 6 clocks a cycle"))
    chip = one_token(lines[1], "at89c52")
    assert not has(chip, "constant"), chip
    assert_number(lines[1], "12MHz", "MHz")
    assert not any(has(s, "constant.numeric") for t, s in tokens_of(lines[2], "stc89c52"))
    assert has(one_token(lines[2], "mode"), "keyword")
    assert_number(lines[2], "12T", "T")
    # the target ends with its line: on the next one `mode` is a name again
    pose_mode = one_token(lines[3], "mode")
    assert not is_keyword(pose_mode) and has(pose_mode, "entity.name"), pose_mode
    assert has(one_token(lines[4], "P1.0"), "constant.other.pin")


def test_numbers_pins_and_comments(node):
    lines = tokenize(node, "\n".join([
        "servo knee = P1.1 speed 0.25s/60deg limit 40deg..140deg trim -3  # note",
        "pose p { knee: 1500us, hip: 90deg, foot: 100, toe: 20\u00b5s }",
        "servo bad = P3.0",
        "frame 20ms; main { hold 1.5s; repeat 3 { move p } }",
    ]))
    first = lines[0]
    assert has(one_token(first, "P1.1"), "constant.other.pin")
    assert_number(first, "0.25s", "s")
    assert_number(first, "60deg", "deg")
    assert has(one_token(first, "/"), "keyword.operator")
    assert_number(first, "40deg", "deg")
    assert has(one_token(first, ".."), "keyword.operator")
    assert_number(first, "140deg", "deg")
    assert_number(first, "-3")
    comment = tokens_of(first, "# note")
    assert comment and all(has(s, "comment.line.number-sign") for _, s in comment), comment
    second = lines[1]
    assert_number(second, "1500us", "us")
    assert_number(second, "90deg", "deg")
    assert_number(second, "100")
    assert_number(second, "20\u00b5s", "\u00b5s")
    assert has(one_token(lines[2], "P3.0"), "invalid")            # ports are P0 to P2
    assert not has(one_token(lines[2], "P3.0"), "constant.numeric")
    assert_number(lines[3], "20ms", "ms")
    assert_number(lines[3], "1.5s", "s")
    assert_number(lines[3], "3")


def test_the_examples_tokenize_without_stray_scopes(node):
    """In every example, every word is a keyword, a name, a pin, a number or part of a comment."""
    for path in sorted((ROOT / "examples").glob("*.servo")):
        for n, line in enumerate(tokenize(node, path.read_text(encoding="utf-8")), 1):
            for tok, scopes in line:
                if tok.strip() and len(scopes) == 1:
                    raise AssertionError(f"{path.name}:{n}: {tok!r} has no scope but source.servo")
                if has(scopes, "invalid"):
                    raise AssertionError(f"{path.name}:{n}: {tok!r} is marked invalid: {scopes}")


# ---------------------------------------------------------------- the extension

def test_manifest_points_at_files_that_exist():
    assert PACKAGE["name"] == "servoc" and PACKAGE["publisher"] and PACKAGE["engines"]["vscode"].startswith("^")
    assert PACKAGE["license"] == "MIT" and (EXT / "LICENSE").read_bytes() == (ROOT / "LICENSE").read_bytes()
    assert (EXT / PACKAGE["main"]).is_file() and (EXT / "README.md").is_file() and (EXT / ".vscodeignore").is_file()
    assert "vscode-languageclient" in PACKAGE["dependencies"]
    lock = json.loads((EXT / "package-lock.json").read_text(encoding="utf-8"))
    for pkg in NODE_PACKAGES:
        assert f"node_modules/{pkg}" in lock["packages"], pkg
    ignored = (EXT / ".gitignore").read_text(encoding="utf-8").split()
    assert "node_modules/" in ignored and "*.vsix" in ignored

    contributes = PACKAGE["contributes"]
    [language] = contributes["languages"]
    assert language["id"] == "servo" and language["extensions"] == [".servo"]
    config = json.loads((EXT / language["configuration"]).read_text(encoding="utf-8"))
    assert config["comments"]["lineComment"] == "#" and ["{", "}"] in config["brackets"]
    for word in ("P1.0", "90deg", "11.0592MHz", "in-out", "stc89c52rc", "trim"):
        assert re.fullmatch(config["wordPattern"], word), word
    [grammar] = contributes["grammars"]
    assert grammar["language"] == "servo" and grammar["scopeName"] == "source.servo"
    assert (EXT / grammar["path"]).resolve() == GRAMMAR_PATH
    assert contributes["configuration"]["properties"]["servoc.path"]["default"] == "servoc"
    assert [d["type"] for d in contributes["taskDefinitions"]] == ["servoc"]


def test_extension_starts_the_language_server(node):
    subprocess.run([node, "--check", str(EXT / PACKAGE["main"])], check=True, timeout=60)
    record = json.loads(_run_node(node, "activate.js"))
    [client] = record["clients"]
    assert client["id"] == "servoc" and not record["errors"]
    assert client["serverOptions"]["run"]["command"] == "servoc"
    assert client["serverOptions"]["run"]["args"] == ["lsp"]
    assert {s["language"] for s in client["documentSelector"]} == {"servo"}
    assert sorted(record["commands"]) == sorted(c["command"] for c in PACKAGE["contributes"]["commands"])
    assert record["taskProviders"] == ["servoc"]
    lint = next(t for t in record["tasks"] if t["definition"]["command"] == "lint")
    assert lint["args"] == ["lint", "${file}"] and lint["problemMatchers"] == ["$servoc"]
    assert record["resolved"]["args"] == ["compile", "a.servo", "-o", "a.hex"]
    # servoc.path, with ${workspaceFolder} expanded (the stand-in's folder is /ws)
    record = json.loads(_run_node(node, "activate.js", "${workspaceFolder}/.venv/bin/servoc"))
    assert record["clients"][0]["serverOptions"]["run"]["command"] == "/ws/.venv/bin/servoc"


# ---------------------------------------------------------------- the problem matcher

def _matcher() -> dict:
    [matcher] = PACKAGE["contributes"]["problemMatchers"]
    return matcher


def _lint_lines(tmp_path: Path, file_arg: str) -> list[str]:
    proc = subprocess.run([sys.executable, "-m", "servoc", "lint", file_arg], cwd=tmp_path,
                          stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    return (proc.stdout + proc.stderr).splitlines()


def test_problem_matcher_reads_servoc_lint(node, tmp_path):
    matcher = _matcher()
    assert matcher["name"] == "servoc" and matcher["owner"] == "servoc"
    assert matcher["fileLocation"] == ["autoDetect", "${workspaceFolder}"]
    pattern = matcher["pattern"]
    assert (pattern["file"], pattern["line"], pattern["column"], pattern["severity"], pattern["message"],
            pattern["code"]) == (1, 2, 3, 4, 5, 6)
    (tmp_path / "fast.servo").write_text(BAD_PROGRAM, encoding="utf-8")
    for file_arg in ("fast.servo", str(tmp_path / "fast.servo")):
        output = _lint_lines(tmp_path, file_arg)
        # the regexp as VS Code runs it: a JavaScript RegExp, tried on every line of output
        script = ("const {re, lines} = JSON.parse(require('fs').readFileSync(0, 'utf8'));"
                  "process.stdout.write(JSON.stringify(lines.map((l) => new RegExp(re).exec(l))));")
        proc = subprocess.run([node, "-e", script], input=json.dumps({"re": pattern["regexp"], "lines": output}),
                              capture_output=True, text=True, timeout=60, check=True)
        matches = [m for m in json.loads(proc.stdout) if m]
        assert len(matches) == 1, output
        m = matches[0]
        assert m[1] == file_arg
        assert (m[2], m[3], m[4], m[6]) == ("7", "3", "error", "infeasible-speed")
        assert m[5].startswith("servo `a` cannot move") and not m[5].endswith("]")
        # Python's re reads it the same way
        py = [re.match(pattern["regexp"], line) for line in output]
        assert [list(p.groups()) for p in py if p] == [m[1:7]]


def test_readme_matcher_is_the_extensions(tmp_path):
    """The stand-alone matcher in editors/README.md (for VS Code without the extension) is `$servoc`'s."""
    text = (EDITORS / "README.md").read_text(encoding="utf-8")
    blocks = [json.loads(b) for b in re.findall(r"```json\n(.*?)```", text, re.S)]
    matchers = [t["problemMatcher"] for b in blocks for t in b.get("tasks", [])
                if isinstance(t.get("problemMatcher"), dict)]
    assert matchers, "editors/README.md shows no stand-alone problem matcher"
    for m in matchers:
        assert m["fileLocation"] == _matcher()["fileLocation"] and m["pattern"] == _matcher()["pattern"]
    assert '"relative"' not in text
