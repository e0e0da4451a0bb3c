"""The language server (`servoc lsp`), driven as an editor drives it: a subprocess
spoken to over pipes by pygls' client.

One server serves the whole module (each test opens its own document); its client
runs on an event loop in a background thread, and every exchange has a timeout,
so a hang fails a test instead of blocking the suite.
"""

from __future__ import annotations

import asyncio
import csv
import io
import sys
import threading
from pathlib import Path

import pytest
from lsprotocol import types as lsp      # pygls is in the test extra: these tests never skip
from pygls.lsp.client import LanguageClient

from servoc import api, cli
from servoc.diagnostics import Reporter
from servoc.lsp import Lines, analyze, hover
from servoc.source import SourceFile

TIMEOUT = 10

# `up` is declared twice: duplicate-name, with a secondary label at the first one.
DUPLICATE = """\
frame 10ms
servo arm = P1.0
servo leg = P1.1 trim 3
pose up { arm: 122, leg: 1500us }
pose down { arm: 0, leg: 100 }
pose up { arm: 10 }
home down
main {
  move up
  move down in 20ms
}
"""
# `move down in 20ms` is far too fast: infeasible-speed.
TOO_FAST = DUPLICATE.replace("pose up { arm: 10 }\n", "")
# and now it is slow enough: no diagnostics at all.
FIXED = TOO_FAST.replace("in 20ms", "in 400ms")


class Editor:
    """A pygls client talking to `servoc.lsp.main()` in a subprocess."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.client = LanguageClient("servoc-tests", "1")
        self.published: dict[str, list[lsp.PublishDiagnosticsParams]] = {}
        self.versions: dict[str, int] = {}

        @self.client.feature(lsp.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        def on_diagnostics(params: lsp.PublishDiagnosticsParams) -> None:
            self.published.setdefault(params.uri, []).append(params)

        self.run(self._start())

    def run(self, coro, timeout: float = TIMEOUT):
        """Run a coroutine on the client's loop; a hang becomes a TimeoutError."""
        future = asyncio.run_coroutine_threadsafe(asyncio.wait_for(coro, timeout), self.loop)
        return future.result(timeout + 2)

    async def _start(self) -> None:
        await self.client.start_io(sys.executable, "-c", "from servoc.lsp import main; main()")
        caps = lsp.ClientCapabilities(
            text_document=lsp.TextDocumentClientCapabilities(rename=lsp.RenameClientCapabilities(prepare_support=True)))
        self.init = await self.client.initialize_async(
            lsp.InitializeParams(process_id=None, root_uri=None, capabilities=caps))
        self.client.initialized(lsp.InitializedParams())

    async def _stop(self) -> str:
        await self.client.shutdown_async(None)
        self.client.exit(None)
        await self.client.stop()
        server = self.client._server
        return (await server.stderr.read()).decode("utf-8", "replace") if server and server.stderr else ""

    def close(self) -> str:
        """Shut the server down as an editor does; returns what it wrote to stderr."""
        try:
            return self.run(self._stop())
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(5)

    # ---- documents

    async def _diagnostics(self, uri: str, version: int) -> list[lsp.Diagnostic]:
        while True:
            for p in self.published.get(uri, []):
                if p.version == version:
                    return list(p.diagnostics)
            await asyncio.sleep(0.01)

    def open(self, name: str, text: str) -> tuple[str, list[lsp.Diagnostic]]:
        """didOpen; returns the document's uri and the diagnostics published for it."""
        uri = (Path("/tmp/servoc-lsp-tests") / name).as_uri()
        self.versions[uri] = 1

        async def go():
            self.client.text_document_did_open(lsp.DidOpenTextDocumentParams(
                text_document=lsp.TextDocumentItem(uri=uri, language_id="servo", version=1, text=text)))
            return await self._diagnostics(uri, 1)

        return uri, self.run(go())

    def change(self, uri: str, text: str) -> list[lsp.Diagnostic]:
        """didChange with the whole new text; returns the diagnostics published for it."""
        self.versions[uri] += 1
        version = self.versions[uri]

        async def go():
            self.client.text_document_did_change(lsp.DidChangeTextDocumentParams(
                text_document=lsp.VersionedTextDocumentIdentifier(uri=uri, version=version),
                content_changes=[lsp.TextDocumentContentChangeWholeDocument(text=text)]))
            return await self._diagnostics(uri, version)

        return self.run(go())

    # ---- requests at a place (0-based line and character)

    def hover(self, uri: str, line: int, character: int) -> lsp.Hover | None:
        return self.run(self.client.text_document_hover_async(lsp.HoverParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character))))

    def definition(self, uri: str, line: int, character: int):
        return self.run(self.client.text_document_definition_async(lsp.DefinitionParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character))))

    def references(self, uri: str, line: int, character: int, with_decl: bool = True):
        return self.run(self.client.text_document_references_async(lsp.ReferenceParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character),
            context=lsp.ReferenceContext(include_declaration=with_decl))))

    def completion(self, uri: str, line: int, character: int):
        return self.run(self.client.text_document_completion_async(lsp.CompletionParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character))))

    def prepare_rename(self, uri: str, line: int, character: int):
        return self.run(self.client.text_document_prepare_rename_async(lsp.PrepareRenameParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character))))

    def rename(self, uri: str, line: int, character: int, new_name: str):
        return self.run(self.client.text_document_rename_async(lsp.RenameParams(
            text_document=lsp.TextDocumentIdentifier(uri=uri), position=lsp.Position(line=line, character=character),
            new_name=new_name)))


@pytest.fixture(scope="module")
def editor():
    ed = Editor()
    yield ed
    stderr = ed.close()
    assert "Traceback" not in stderr, stderr     # refused renames and bad text are answers, not crashes
    assert ed.client._server.returncode == 0


def where(text: str, needle: str, nth: int = 0, into: int = 0) -> tuple[int, int]:
    """0-based line and character of the `nth` occurrence of `needle` (plus `into` characters); ASCII text."""
    at = -1
    for _ in range(nth + 1):
        at = text.index(needle, at + 1)
    at += into
    return text.count("\n", 0, at), at - (text.rfind("\n", 0, at) + 1)


def pos(p: lsp.Position) -> tuple[int, int]:
    return p.line, p.character


# ---------------------------------------------------------------- diagnostics

def test_initialize_advertises_the_features(editor: Editor):
    caps = editor.init.capabilities
    assert editor.init.server_info.name == "servoc"
    assert caps.hover_provider and caps.definition_provider and caps.references_provider
    assert caps.completion_provider is not None
    assert isinstance(caps.rename_provider, lsp.RenameOptions) and caps.rename_provider.prepare_provider


def test_diagnostics_as_you_type(editor: Editor):
    uri, diags = editor.open("typing.servo", DUPLICATE)
    # duplicate-name, with "first declared here" as related information
    assert [d.code for d in diags] == ["duplicate-name"]
    d = diags[0]
    assert d.severity == lsp.DiagnosticSeverity.Error and d.source == "servoc"
    assert (pos(d.range.start), pos(d.range.end)) == ((5, 5), (5, 7))
    assert d.message.startswith("`up` is already declared\nhelp: a pose `up` is declared at line 4")
    assert len(d.related_information) == 1
    rel = d.related_information[0]
    assert rel.message == "first declared here" and rel.location.uri == uri
    assert (pos(rel.location.range.start), pos(rel.location.range.end)) == ((3, 5), (3, 7))

    # the duplicate deleted: now the speed check runs, as `servoc lint` would show it
    diags = editor.change(uri, TOO_FAST)
    assert [d.code for d in diags] == ["infeasible-speed"]
    d = diags[0]
    line, col = where(TOO_FAST, "move down")
    assert (pos(d.range.start), pos(d.range.end)) == ((line, col), (line, col + len("move down in 20ms")))
    assert "cannot move 122 DAV" in d.message and "\nhelp: use `in 305ms` or longer" in d.message
    assert d.related_information is None

    # the same as the command line: code, message and help, line and column
    source = SourceFile("typing.servo", TOO_FAST)
    reporter = Reporter(source)
    api.front_end(source, reporter)
    ((ref,),) = [reporter.sorted()]
    assert d.message == f"{ref.message}\nhelp: {ref.help}"
    assert source.line_col(ref.span.start) == (line + 1, col + 1)

    assert editor.change(uri, FIXED) == []


def test_notes_are_information_and_warnings_warnings(editor: Editor):
    text = FIXED.replace("arm: 122", "arm: 90deg") + "pose spare { arm: 10 }\n"
    _, diags = editor.open("severities.servo", text)
    by_code = {d.code: d for d in diags}
    assert by_code["inexact-angle"].severity == lsp.DiagnosticSeverity.Information
    assert by_code["unused-pose"].severity == lsp.DiagnosticSeverity.Warning


def test_garbage_gives_a_syntax_error_and_the_server_keeps_working(editor: Editor):
    uri, diags = editor.open("garbage.servo", "garbage here {{{\n\x00\x01 }}}")
    assert [d.code for d in diags] == ["syntax-error"]
    assert pos(diags[0].range.start) == (0, 0)
    assert editor.hover(uri, 0, 2) is None
    assert editor.definition(uri, 0, 2) is None
    assert editor.references(uri, 0, 2) is None
    # completion still offers keywords while the text does not parse
    labels = {c.label for c in editor.completion(uri, 1, 0).items}
    assert {"servo", "pose", "main"} <= labels
    # and the server still answers for a good document
    assert editor.change(uri, FIXED) == []
    assert editor.hover(uri, *where(FIXED, "move up")) is not None


def test_columns_are_utf16_code_units(editor: Editor):
    # U+1F600 is one character in the text (and in servoc's spans) but two UTF-16 code units
    _, diags = editor.open("emoji.servo", "servo arm = P1.0 \U0001F600 trim 3\n")
    assert [d.code for d in diags] == ["syntax-error"]
    assert (pos(diags[0].range.start), pos(diags[0].range.end)) == ((0, 17), (0, 19))


def test_an_internal_error_means_no_diagnostics(monkeypatch: pytest.MonkeyPatch):
    def broken(source, reporter):
        raise RuntimeError("a bug in servoc")

    monkeypatch.setattr(api, "front_end", broken)
    a = analyze("file:///x.servo", "x.servo", FIXED)
    assert a.diagnostics == () and a.plan is None
    assert a.tree is not None             # navigation still works on the syntax tree
    assert hover(a, FIXED.index("leg", 20)).contents.value.startswith("**servo `leg`**")


def test_lines_convert_between_offsets_and_positions():
    text = "a\U0001F600b\nµx\n"
    utf16, utf8, utf32 = (Lines(text, enc) for enc in ("utf-16", "utf-8", "utf-32"))
    b = text.index("b")
    x = text.index("x")
    assert pos(utf16.position(b)) == (0, 3) and pos(utf8.position(b)) == (0, 5) and pos(utf32.position(b)) == (0, 2)
    assert pos(utf16.position(x)) == (1, 1) and pos(utf8.position(x)) == (1, 2)
    for lines in (utf16, utf8, utf32):
        for offset in range(len(text) + 1):
            if offset != 2:     # not inside the surrogate pair
                assert lines.offset(lines.position(offset)) == offset
    # a position past the end of a line stays on that line
    assert utf16.offset(lsp.Position(line=0, character=99)) == text.index("\n")


# ---------------------------------------------------------------- hover

def test_hover_on_a_pose_value(editor: Editor):
    uri, _ = editor.open("hover-value.servo", FIXED)
    h = editor.hover(uri, *where(FIXED, "1500us", into=2))
    text = h.contents.value
    # as written: N 125; `leg` has trim 3, so it is sent N 128
    assert "`1500us`** is N 125: pulse 500 + 8 × 125 = 1500 µs, angle 125 × 0.74° = 92.5°" in text
    assert "`leg` (trim +3): sent N 128: pulse 500 + 8 × 128 = 1524 µs, angle 128 × 0.74° = 94.72°" in text
    line, col = where(FIXED, "1500us")
    assert (pos(h.range.start), pos(h.range.end)) == ((line, col), (line, col + 6))


def test_hover_on_a_move(editor: Editor):
    uri, _ = editor.open("hover-move.servo", FIXED)
    text = editor.hover(uri, *where(FIXED, "move down", into=2)).contents.value
    assert "`move down in 400ms`" in text
    assert "F = 40 frames × P 10 ms = 400 ms" in text
    assert "`arm`: -122 DAV (90.28°), 75% of its top speed; it needs 300.933 ms (31 frames)" in text
    assert "`leg`: -25 DAV (18.5°), 15% of its top speed; it needs 61.667 ms (7 frames)" in text
    # the shares are those of `servoc plan`
    source = SourceFile("p.servo", FIXED)
    reporter = Reporter(source)
    table = cli.plan_table(api.front_end(source, reporter).plan, source, csv_out=True)
    rows = [r for r in csv.DictReader(io.StringIO(table)) if r["pose"] == "down"]
    assert {r["servo"]: r["speed_percent"] for r in rows} == {"arm": "75", "leg": "15"}

    # from `home down` the first move is speed-checked; without `home` it sets the servos at once
    first = editor.hover(uri, *where(FIXED, "move up", into=1)).contents.value
    assert "F = 31 frames × P 10 ms = 310 ms (as fast as the slowest servo allows)" in first
    assert "`arm`: +122 DAV (90.28°)" in first
    no_home = FIXED.replace("home down\n", "")
    editor.change(uri, no_home)
    first = editor.hover(uri, *where(no_home, "move up", into=1)).contents.value
    assert "F = 1 frame × P 10 ms = 10 ms (as fast as the slowest servo allows)" in first
    assert "`arm`: set at once to N 122" in first

    # too fast: flagged
    editor.change(uri, TOO_FAST)
    text = editor.hover(uri, *where(TOO_FAST, "move down", into=2)).contents.value
    assert "1505% of its top speed **too fast**" in text


def test_hover_on_a_name(editor: Editor):
    uri, _ = editor.open("hover-name.servo", FIXED)
    # a use of a servo in a pose shows its declaration
    text = editor.hover(uri, *where(FIXED, "leg", nth=1)).contents.value
    assert "**servo `leg`**, declared at line 3" in text and "servo leg = P1.1 trim 3" in text
    # the pose of a move: its declaration, and the move
    text = editor.hover(uri, *where(FIXED, "move down", into=6)).contents.value
    assert "**pose `down`**, declared at line 5" in text and "pose down { arm: 0, leg: 100 }" in text
    assert "F = 40 frames" in text
    # nothing at a blank place
    assert editor.hover(uri, len(FIXED.splitlines()), 0) is None


# ---------------------------------------------------------------- navigation

def test_definition_and_references_of_a_pose(editor: Editor):
    uri, _ = editor.open("nav.servo", FIXED)
    loc = editor.definition(uri, *where(FIXED, "move down", into=6))
    assert loc.uri == uri and pos(loc.range.start) == where(FIXED, "down") and pos(loc.range.end) == where(FIXED, "down", into=4)
    refs = editor.references(uri, *where(FIXED, "down"))
    assert [pos(r.range.start) for r in refs] == [where(FIXED, "down", nth=n) for n in range(3)]   # `home down`
    refs = editor.references(uri, *where(FIXED, "down", nth=2), with_decl=False)
    assert [pos(r.range.start) for r in refs] == [where(FIXED, "down", nth=n) for n in (1, 2)]


def test_definition_of_a_servo_group_and_sequence(editor: Editor):
    text = FIXED.replace("main {", "group legs = leg\nsequence go {\n  move down in 400ms\n}\nmain {\n  play go") \
                .replace("pose up { arm: 122, leg: 1500us }", "pose up { arm: 122, legs: 1500us }")
    uri, diags = editor.open("nav2.servo", text)
    assert [d.code for d in diags] == []
    for use, decl in (("legs: ", "legs ="), ("play go", "go {"), ("= leg\n", "leg =")):
        line, col = where(text, use, into=2 if use.startswith("=") else (5 if use.startswith("play") else 0))
        loc = editor.definition(uri, line, col)
        assert pos(loc.range.start) == where(text, decl), use


# ---------------------------------------------------------------- completion

def test_completion_offers_names_and_keywords(editor: Editor):
    uri, _ = editor.open("complete.servo", FIXED)
    items = {c.label: c for c in editor.completion(uri, *where(FIXED, "main")).items}
    assert {"arm", "leg", "up", "down"} <= set(items)
    assert {"servo", "move", "ease", "in-out", "loop"} <= set(items)
    assert items["up"].detail == "pose" and items["arm"].detail == "servo"
    assert items["loop"].kind == lsp.CompletionItemKind.Keyword
    # after `move`, only poses fit; and while the line is half typed the names are still known
    half = FIXED.replace("  move up\n", "  move u\n  move \n")
    uri2, _ = editor.open("complete-half.servo", half)
    labels = [c.label for c in editor.completion(uri2, *where(half, "move u", into=6)).items]
    assert sorted(labels) == ["down", "up"]
    labels = [c.label for c in editor.completion(uri2, *where(half, "move \n", into=5)).items]
    assert sorted(labels) == ["down", "up"]
    # after `ease`, the four curves
    eased = FIXED.replace("in 400ms", "in 400ms ease ")
    uri3, _ = editor.open("complete-ease.servo", eased)
    labels = [c.label for c in editor.completion(uri3, *where(eased, "ease ", into=5)).items]
    assert labels == ["linear", "in", "out", "in-out"]


# ---------------------------------------------------------------- rename

def test_rename_a_servo_everywhere(editor: Editor):
    uri, _ = editor.open("rename.servo", FIXED)
    at = where(FIXED, "arm", nth=1)          # a use in a pose
    assert pos(editor.prepare_rename(uri, *at).start) == at
    edit = editor.rename(uri, *at, "elbow")
    edits = edit.changes[uri]
    assert len(edits) == FIXED.count("arm") == 3
    lines = FIXED.splitlines()
    for e in sorted(edits, key=lambda e: (e.range.start.line, e.range.start.character), reverse=True):
        line = lines[e.range.start.line]
        assert line[e.range.start.character:e.range.end.character] == "arm"
        lines[e.range.start.line] = line[:e.range.start.character] + e.new_text + line[e.range.end.character:]
    renamed = "\n".join(lines) + "\n"
    assert renamed == FIXED.replace("arm", "elbow")
    assert editor.change(uri, renamed) == []


@pytest.mark.parametrize("new, why", [("loop", "is a keyword"), ("2arm", "is not a name"),
                                      ("leg", "is already declared"), ("P1", "port")])
def test_rename_refused(editor: Editor, new: str, why: str):
    uri, _ = editor.open(f"refuse-{new}.servo", FIXED)
    with pytest.raises(Exception) as info:
        editor.rename(uri, *where(FIXED, "arm"), new)
    assert why in str(info.value)


def test_rename_needs_a_declared_name(editor: Editor):
    uri, _ = editor.open("rename-nothing.servo", FIXED)
    assert editor.prepare_rename(uri, *where(FIXED, "frame")) is None
    with pytest.raises(Exception, match="only a declared"):
        editor.rename(uri, *where(FIXED, "frame"), "x")


def test_references_of_an_input_through_edges_and_until(editor: Editor):
    text = ("input btn = P3.2\nservo arm = P1.0\npose a { arm: 10 }\npose b { arm: 200 }\nhome a\nmain {\n"
            "  wait press btn\n  move b in 2s until release btn\n  select {\n    on btn { move a }\n"
            "    meanwhile { hold 1s }\n  }\n}\n")
    uri, diags = editor.open("edges.servo", text)
    assert [d.code for d in diags] == []
    refs = editor.references(uri, *where(text, "btn"))
    assert [pos(r.range.start) for r in refs] == [where(text, "btn", nth=n) for n in range(4)]
    edit = editor.rename(uri, *where(text, "btn", nth=2), "button")
    assert len(edit.changes[uri]) == 4
    refs = editor.references(uri, *where(text, "home a", into=5))       # `home a` uses the pose `a`
    assert [pos(r.range.start) for r in refs] == [where(text, "a {"), where(text, "home a", into=5),
                                                  where(text, "move a", into=5)]


@pytest.mark.parametrize("clock,top,overlap", [("target at89c52 clock 22.1184MHz\n", 250, True), ("", 250, True),
                                               ("", 40, False)])
def test_hover_on_frame_says_where_the_ports_pulses_begin(editor: Editor, clock, top, overlap):
    """Where the lines reach N 250 the pulses bound the period and overlap; lines below N 40 leave
    the work bounding it, and the ports pulse one after another."""
    text = (clock + "frame 10ms\n" + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p in (1, 2) for b in range(3))
            + "pose a { " + ", ".join(f"s{p}{b}: {top - 20 * b}" for p in (1, 2) for b in range(3)) + " }\n"
            + "main { move a }\n")
    uri, _ = editor.open("hover-frame.servo", text)
    value = editor.hover(uri, *where(text, "frame 10ms", into=2)).contents.value
    assert "**`frame 10ms`**" in value and "P = 10 ms; the shortest the firmware holds: " in value
    assert "P1 rises at 0 ms, P2 rises at " in value
    assert ("the ports' pulses overlap" in value) == overlap
    assert ("the ports pulse one after another" in value) == (not overlap)
    assert ("they rise at once" in value) == bool(clock)      # 22.1184 MHz: the ports at once
