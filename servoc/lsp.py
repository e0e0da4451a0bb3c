"""The language server: `servoc lsp` gives any editor live help while a .servo file is written.

It speaks the Language Server Protocol over standard input and output (pygls):

- diagnostics as you type: the codes, places and help lines of `servoc lint`,
  with secondary labels (such as "first declared here") as related information;
- hover: on a position in a pose, its N, pulse width and the angle it produces
  (for each servo it is sent to, after limit, reverse and trim); on a `move`, its
  frames, duration and each servo's share of its top speed and the time it needs;
  on a name, its declaration; on `frame`, the period, the shortest the firmware
  holds and where each port's pulses begin (one after another, or overlapping);
- go to definition, find references and rename for servos, groups, poses and
  sequences (names share one namespace, so a name means the same thing everywhere);
- completion of the declared names and the keywords (with the words that are keywords only
  where the grammar expects them, such as `host` and `channel`; after `host`, its protocols).

Every request works on the editor's text, never on the file on disk. Analysis
never takes the server down: an exception inside servoc becomes "no
diagnostics" for that text.
"""

from __future__ import annotations

import bisect
import logging
import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterator

from lsprotocol import types as lsp
from pygls.exceptions import JsonRpcException
from pygls.lsp.server import LanguageServer

from . import __version__, api, nodes, units, walk
from .check import quantities
from .check.context import PORTS
from .diagnostics import Diagnostic, Reporter, Severity
from .model import EASES, HOSTS, host_channel
from .steps import MoveInstance, Plan
from .printer import format_quantity
from .source import NO_SPAN, SourceFile, Span
from .syntax import keywords

logger = logging.getLogger(__name__)

NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
KINDS = {nodes.ServoDecl: "servo", nodes.GroupDecl: "group", nodes.PoseDecl: "pose",
         nodes.SequenceDecl: "sequence", nodes.InputDecl: "input"}
SEVERITY = {Severity.ERROR: lsp.DiagnosticSeverity.Error, Severity.WARNING: lsp.DiagnosticSeverity.Warning,
            Severity.NOTE: lsp.DiagnosticSeverity.Information}
COMPLETION_KIND = {"servo": lsp.CompletionItemKind.Variable, "group": lsp.CompletionItemKind.Module,
                   "pose": lsp.CompletionItemKind.Constant, "sequence": lsp.CompletionItemKind.Function,
                   "input": lsp.CompletionItemKind.Event}
SYMBOL_KIND = {"servo": lsp.SymbolKind.Variable, "group": lsp.SymbolKind.Array,
               "pose": lsp.SymbolKind.Constant, "sequence": lsp.SymbolKind.Function,
               "input": lsp.SymbolKind.Event}
# After these words only one kind of name fits.
WANTS = {"move": "pose", "play": "sequence", "wait": "input", "on": "input"}
# Words that are no keywords but start a declaration, a statement or a servo option (completed with them).
SOFT_KEYWORDS = frozenset({"home", "stagger", "host", "channel"})
MAX_INSTANCES = 6       # move contexts shown in one hover


# ---------------------------------------------------------------- positions

def _utf16(s: str) -> int:
    return len(s.encode("utf-16-le", "surrogatepass")) // 2


def _utf8(s: str) -> int:
    return len(s.encode("utf-8", "surrogatepass"))


UNIT_COUNTERS = {lsp.PositionEncodingKind.Utf16: _utf16, lsp.PositionEncodingKind.Utf8: _utf8,
                 lsp.PositionEncodingKind.Utf32: len}


class Lines:
    """Character offsets into a text <-> LSP positions.

    Spans are offsets of characters (code points) into the decoded text; an LSP
    position is a 0-based line and a column counted in the negotiated encoding's
    code units (UTF-16 unless the editor chose otherwise), so a character outside
    the Basic Multilingual Plane is two columns in UTF-16 and `µ` two in UTF-8.
    Lines end at `\\n`, as in `SourceFile`.
    """

    def __init__(self, text: str, encoding: str | None = None) -> None:
        self.text = text
        self.starts = [0] + [i + 1 for i, ch in enumerate(text) if ch == "\n"]
        self.units = UNIT_COUNTERS.get(encoding or lsp.PositionEncodingKind.Utf16, _utf16)

    def _line_end(self, line: int) -> int:
        return self.starts[line + 1] - 1 if line + 1 < len(self.starts) else len(self.text)

    def position(self, offset: int) -> lsp.Position:
        offset = max(0, min(offset, len(self.text)))
        line = bisect.bisect_right(self.starts, offset) - 1
        return lsp.Position(line=line, character=self.units(self.text[self.starts[line]:offset]))

    def range(self, span: Span) -> lsp.Range:
        return lsp.Range(start=self.position(span.start), end=self.position(max(span.start, span.end)))

    def offset(self, pos: lsp.Position) -> int:
        if pos.line >= len(self.starts):
            return len(self.text)
        i, end, counted = self.starts[pos.line], self._line_end(pos.line), 0
        while i < end and counted < pos.character:
            counted += self.units(self.text[i])
            i += 1
        return i


# ---------------------------------------------------------------- analysis

@dataclass(frozen=True)
class Analysis:
    """One version of one document, run through the front end."""
    uri: str
    source: SourceFile
    lines: Lines
    tree: nodes.Program | None
    program: object | None
    plan: Plan | None
    diagnostics: tuple[Diagnostic, ...]


def analyze(uri: str, path: str, text: str, encoding: str | None = None) -> Analysis:
    """parse, check, plan and lint, as `servoc lint` does; never raises."""
    source = SourceFile(path, text)
    lines = Lines(text, encoding)
    reporter = Reporter(source)
    try:
        fe = api.front_end(source, reporter)
        return Analysis(uri, source, lines, fe.tree, fe.program, fe.plan, tuple(reporter.sorted()))
    except Exception:       # a bug in servoc: no diagnostics, and keep serving
        logger.exception("servoc failed on %s", path)
    try:                    # the syntax tree alone still serves navigation
        tree = api.parse(source, Reporter(source))
    except Exception:
        tree = None
    return Analysis(uri, source, lines, tree, None, None, ())


def to_lsp_diagnostic(d: Diagnostic, a: Analysis) -> lsp.Diagnostic:
    """The same code, place and help as `servoc lint`; secondary labels as related information."""
    message = d.message + (f"\nhelp: {d.help}" if d.help else "")
    related = [lsp.DiagnosticRelatedInformation(location=lsp.Location(uri=a.uri, range=a.lines.range(lab.span)),
                                                message=lab.message)
               for lab in d.secondary if lab.span != NO_SPAN]
    return lsp.Diagnostic(range=a.lines.range(d.span), message=message, severity=SEVERITY[d.severity],
                          code=d.code, source="servoc", related_information=related or None)


# ---------------------------------------------------------------- names

@dataclass(frozen=True)
class Declared:
    kind: str           # servo, group, pose or sequence
    item: object        # the declaration node
    name: nodes.Name


def _input_of(event: nodes.Event) -> tuple[nodes.Name, ...]:
    """The input an event names (`b`, `press b`, `release b`), as a tuple of none or one."""
    if isinstance(event, nodes.EdgeEvent):
        return () if event.literal else (event.input,)
    return (event,) if isinstance(event, nodes.Name) else ()


class Symbols:
    """Every name of one syntax tree: declarations (the first of a name counts) and uses."""

    def __init__(self, tree: nodes.Program) -> None:
        self.decls: dict[str, Declared] = {}
        self.names: list[nodes.Name] = []           # every occurrence, declarations included
        self.declaring: set[Span] = set()           # the spans of declared names (duplicates too)
        bodies = []
        for item in tree.items:
            kind = KINDS.get(type(item))
            if kind is not None:
                self.decls.setdefault(item.name.text, Declared(kind, item, item.name))
                self.names.append(item.name)
                self.declaring.add(item.name.span)
            if isinstance(item, nodes.GroupDecl):
                self.names.extend(item.members)
            elif isinstance(item, nodes.PoseDecl):
                if item.base is not None:
                    self.names.append(item.base)
                self.names.extend(entry.target for entry in item.entries)
            elif isinstance(item, nodes.SettingDecl) and item.word.text == "home" \
                    and isinstance(item.value, nodes.Name):
                self.names.append(item.value)
            if isinstance(item, (nodes.SequenceDecl, nodes.MainDecl)):
                bodies.append(item.body)
        for st in walk.statements(bodies):
            if isinstance(st, nodes.MoveStmt):
                self.names.append(st.pose)
            elif isinstance(st, nodes.PlayStmt):
                self.names.append(st.name)
            elif isinstance(st, (nodes.WaitStmt, nodes.UntilStmt)):
                self.names.extend(_input_of(st.event))
            elif isinstance(st, nodes.SelectStmt):
                self.names.extend(n for b in st.branches if isinstance(b, nodes.OnBranch) for n in _input_of(b.event))

    def at(self, offset: int) -> nodes.Name | None:
        """The name under the cursor (touching either end of it counts)."""
        return next((n for n in self.names if n.span.start <= offset <= n.span.end), None)

    def uses(self, text: str) -> list[nodes.Name]:
        return sorted((n for n in self.names if n.text == text), key=lambda n: n.span.start)


DECL_RE = re.compile(r"(?<![A-Za-z0-9_])(servo|group|pose|sequence|input)[ \t]+([A-Za-z_][A-Za-z0-9_]*)")


def declared_names(a: Analysis) -> dict[str, str]:
    """Name -> kind; read from the text when it does not parse (as while it is being typed)."""
    if a.tree is not None:
        return {name: d.kind for name, d in Symbols(a.tree).decls.items()}
    found: dict[str, str] = {}
    kws = keywords()
    for line in a.source.text.split("\n"):
        for m in DECL_RE.finditer(line.split("#", 1)[0]):
            if m.group(2) not in kws and m.group(2) not in PORTS:
                found.setdefault(m.group(2), m.group(1))
    return found


# ---------------------------------------------------------------- hover

def _first_line(a: Analysis, span: Span) -> str:
    line, _ = a.source.line_col(span.start)
    return a.source.line_text(line).strip()


def hover_name(a: Analysis, sym: Symbols, name: nodes.Name) -> str:
    if name.text in PORTS:
        return f"port `{name.text}`: every servo on {name.text}"
    decl = sym.decls.get(name.text)
    if decl is None:
        return f"`{name.text}` is not declared"
    line, _ = a.source.line_col(decl.name.span.start)
    text = f"**{decl.kind} `{name.text}`**, declared at line {line}:\n```servo\n{_first_line(a, decl.item.span)}\n```"
    if decl.kind == "servo" and a.program is not None and a.program.host is not None:
        servo = next((s for s in a.program.servos if s.name == name.text), None)
        if servo is not None:
            how = "its `channel`" if servo.channel_option is not None else f"its pin {servo.pin}"
            text += f"\nhost channel {host_channel(servo)} (`host {a.program.host}`, from {how})"
    if decl.kind == "group" and a.program is not None:
        group = next((g for g in a.program.groups if g.name == name.text), None)
        if group is not None:
            text += "\nservos: " + ", ".join(f"`{s}`" for s in group.servos)
    return text


def _n_line(n: int) -> str:
    return (f"N {n}: pulse 500 + 8 × {n} = {units.n_to_width_us(n)} µs, "
            f"angle {n} × 0.74° = {units.fmt_deg(units.n_to_deg(n))}")


def hover_value(a: Analysis, pose: nodes.PoseDecl, entry: nodes.Entry) -> str:
    """A position in a pose: its N, and what each servo it names is sent."""
    written = format_quantity(entry.position)
    pos = quantities.position(entry.position, "a pose")
    if isinstance(pos, quantities.Problem):
        return f"`{written}`: {pos.message}"
    out = [f"**`{written}`** is {_n_line(pos.n)}"]
    targets = []
    if a.program is not None:
        model_pose = next((p for p in a.program.poses if p.name == pose.name.text), None)
        if model_pose is not None:
            targets = [t for t in model_pose.targets if t.span == entry.span]
    if targets:
        out.append("")
        for t in targets:
            servo = a.program.servo(t.servo)
            how = []
            if servo.reverse:
                how.append("reversed")
            if servo.trim:
                how.append(f"trim {servo.trim:+d}")
            via = f" ({', '.join(how)})" if how else ""
            out.append(f"- `{t.servo}`{via}: sent {_n_line(t.n)}")
    elif a.program is None:
        out.append("\n(limit, reverse and trim are shown once the program has no errors in names and units)")
    return "\n".join(out)


def speed_share(plan: Plan, inst: MoveInstance, channel: int, delta: int) -> Fraction:
    """A servo's speed in a move instance as a share (in %) of its top speed, as `servoc plan` shows it."""
    t_dav = plan.class_t_dav_us[plan.channels[channel].speed_class]
    return abs(delta) * t_dav * 100 / (inst.frames * plan.period_us)


def hover_move(a: Analysis, stmt: nodes.MoveStmt) -> str:
    head = f"**`{a.source.snippet(stmt.span)}`**"
    plan = a.plan
    if plan is None:
        return head + "\n\n(timing is shown once the program has no errors in names and units)"
    insts = [m for m in plan.moves if m.step.span == stmt.span]
    if not insts:
        return head + "\n\nnot reached from `main`: no timing"
    P = plan.period_us
    out = [head]
    for i, inst in enumerate(insts[:MAX_INSTANCES]):
        if len(insts) > 1:
            out.append(f"\n*context {i + 1} of {len(insts)}*")
        how = "" if inst.step.duration_us is not None else " (as fast as the slowest servo allows)"
        out.append(f"\nF = {inst.frames} frame{'s' if inst.frames != 1 else ''} × P {units.fmt_ms(P)} = "
                   f"{units.fmt_ms(inst.frames * P)}{how}"
                   + ("; P is that of the firmware built for size (the build for speed does not fit)"
                      if plan.compact and i == 0 else ""))
        for m in inst.motions:
            ch = plan.channels[m.channel]
            if m.n0 is None:
                out.append(f"- `{ch.name}`: set at once to N {m.n1} (it had no target before)")
            elif m.delta == 0:
                out.append(f"- `{ch.name}`: already at N {m.n1}")
            else:
                t_dav = plan.class_t_dav_us[ch.speed_class]
                share = speed_share(plan, inst, m.channel, m.delta)
                need = units.frames_needed(m.delta, t_dav, P)
                flag = " **too fast**" if share > 100 else ""
                out.append(f"- `{ch.name}`: {m.delta:+d} DAV ({units.fmt_deg(abs(m.delta) * units.DAV_DEG)}), "
                           f"{round(float(share))}% of its top speed{flag}; it needs "
                           f"{units.fmt_ms(abs(m.delta) * t_dav)} ({need} frame{'s' if need != 1 else ''})")
    if len(insts) > MAX_INSTANCES:
        out.append(f"\n... and {len(insts) - MAX_INSTANCES} more contexts (`servoc plan` lists them all)")
    return "\n".join(out)


def hover_frame(a: Analysis, decl: nodes.FrameDecl) -> str:
    """The frame period, the shortest the firmware holds, and where each port's pulses begin (as
    `servoc plan` says: one after another, or overlapping)."""
    head = f"**`{a.source.snippet(decl.span)}`**"
    plan = a.plan
    if plan is None:
        return head + "\n\n(timing is shown once the program has no errors in names and units)"
    out = [head, f"\nP = {units.fmt_ms(plan.period_us)}; the shortest the firmware holds: "
                 f"{units.fmt_ms(plan.min_period_us)}"]
    if len(plan.rise_offsets) == len(plan.ports) > 1:
        out.append("\n" + ", ".join(f"P{p} rises at {units.fmt_ms(r)}" for p, r in zip(plan.ports, plan.rises_us())))
        out.append("\nthe ports' pulses overlap: each port's rise after the first comes among the falls of the "
                   "port before it" if plan.rises_among_falls else
                   "\nthe ports' pulses overlap whole: they rise at once, and one timeline puts out every "
                   "port's falls" if plan.ports_at_once
                   else "\nthe ports pulse one after another")
    return "\n".join(out)


def _moves(tree: nodes.Program) -> Iterator[nodes.MoveStmt]:
    bodies = [item.body for item in tree.items if isinstance(item, (nodes.SequenceDecl, nodes.MainDecl))]
    return (st for st in walk.statements(bodies) if isinstance(st, nodes.MoveStmt))


def hover(a: Analysis, offset: int) -> lsp.Hover | None:
    if a.tree is None:
        return None
    sym = Symbols(a.tree)
    parts: list[str] = []
    span: Span | None = None
    name = sym.at(offset)
    if name is not None:
        parts.append(hover_name(a, sym, name))
        span = name.span
    for item in a.tree.items:
        if isinstance(item, nodes.PoseDecl):
            for entry in item.entries:
                if entry.position.span.start <= offset <= entry.position.span.end:
                    parts.append(hover_value(a, item, entry))
                    span = entry.position.span
    frame = next((d for d in a.tree.items if isinstance(d, nodes.FrameDecl)
                  and d.span.start <= offset <= d.span.end), None)
    if frame is not None and name is None:
        parts.append(hover_frame(a, frame))
        span = frame.span
    move = next((m for m in _moves(a.tree) if m.span.start <= offset <= m.span.end), None)
    if move is not None:
        parts.append(hover_move(a, move))
        span = span or move.span
    if not parts:
        return None
    return lsp.Hover(contents=lsp.MarkupContent(kind=lsp.MarkupKind.Markdown, value="\n\n---\n\n".join(parts)),
                     range=a.lines.range(span))


# ---------------------------------------------------------------- completion

def completion(a: Analysis, offset: int) -> list[lsp.CompletionItem]:
    text = a.source.text
    start = offset
    while start > 0 and (text[start - 1].isalnum() or text[start - 1] == "_"):
        start -= 1
    before = re.search(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*\Z", text[max(0, start - 64):start])
    word = before.group(1) if before else ""
    if word == "ease":
        return [lsp.CompletionItem(label=e, kind=lsp.CompletionItemKind.Keyword, detail="ease") for e in EASES]
    if word == "host" and _line_start(text, start - len(before.group(0))):
        return [lsp.CompletionItem(label=h, kind=lsp.CompletionItemKind.Keyword, detail="host protocol")
                for h in HOSTS]
    wanted = WANTS.get(word, "")
    names = declared_names(a)
    items = [lsp.CompletionItem(label=name, kind=COMPLETION_KIND[kind], detail=kind)
             for name, kind in sorted(names.items()) if not wanted or kind == wanted]
    if not wanted:
        items += [lsp.CompletionItem(label=kw, kind=lsp.CompletionItemKind.Keyword, detail="keyword")
                  for kw in sorted(keywords() | SOFT_KEYWORDS | {"in-out"})]
    return items


def _line_start(text: str, offset: int) -> bool:
    """Whether only blanks (or a `;`) come before `offset` on its line: a declaration starts there."""
    before = text[text.rfind("\n", 0, offset) + 1:offset]
    return before.strip(" \t") == "" or before.rstrip(" \t").endswith(";")


# ---------------------------------------------------------------- rename

class Refused(JsonRpcException):
    """A request that cannot be done, e.g. a rename to a keyword; the editor shows the message."""
    CODE = lsp.LSPErrorCodes.RequestFailed.value


def rename(a: Analysis, offset: int, new: str) -> lsp.WorkspaceEdit:
    if a.tree is None:
        raise Refused("the file has a syntax error; fix it before renaming")
    sym = Symbols(a.tree)
    name = sym.at(offset)
    if name is None or name.text not in sym.decls:
        raise Refused("only a declared servo, group, pose or sequence can be renamed")
    if not NAME_RE.match(new):
        raise Refused(f"`{new}` is not a name: letters, digits and `_`, not starting with a digit")
    if new in keywords():
        raise Refused(f"`{new}` is a keyword and cannot be a name")
    if new in PORTS:
        raise Refused(f"`{new}` is the name of a port and cannot be a name")
    if new != name.text and new in sym.decls:
        other = sym.decls[new]
        line, _ = a.source.line_col(other.name.span.start)
        raise Refused(f"`{new}` is already declared ({other.kind}, line {line})")
    edits = [lsp.TextEdit(range=a.lines.range(n.span), new_text=new) for n in sym.uses(name.text)]
    return lsp.WorkspaceEdit(changes={a.uri: edits})


class _QuietRefusals(logging.Filter):
    """A refused request is an answer to the user, not a server error: no traceback for it."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not (record.exc_info and isinstance(record.exc_info[1], Refused))


# ---------------------------------------------------------------- the server

class ServoLanguageServer(LanguageServer):
    def __init__(self) -> None:
        super().__init__("servoc", __version__, text_document_sync_kind=lsp.TextDocumentSyncKind.Full)
        self.analyses: dict[str, Analysis] = {}

    def analysis(self, uri: str) -> Analysis:
        """The analysis of the document's current text (cached until the text changes)."""
        doc = self.workspace.get_text_document(uri)
        text = doc.source
        cached = self.analyses.get(uri)
        if cached is not None and cached.source.text == text:
            return cached
        a = analyze(uri, doc.path or uri, text, self.workspace.position_encoding)
        self.analyses[uri] = a
        return a

    def publish(self, uri: str, version: int | None) -> None:
        try:
            a = self.analysis(uri)
            diags = [to_lsp_diagnostic(d, a) for d in a.diagnostics]
        except Exception:
            logger.exception("cannot analyse %s", uri)
            diags = []
        self.text_document_publish_diagnostics(
            lsp.PublishDiagnosticsParams(uri=uri, version=version, diagnostics=diags))


def build_server() -> ServoLanguageServer:
    server = ServoLanguageServer()
    logging.getLogger("pygls.protocol.json_rpc").addFilter(_QuietRefusals())

    @server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: ServoLanguageServer, params: lsp.DidOpenTextDocumentParams) -> None:
        ls.publish(params.text_document.uri, params.text_document.version)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: ServoLanguageServer, params: lsp.DidChangeTextDocumentParams) -> None:
        ls.publish(params.text_document.uri, params.text_document.version)

    @server.feature(lsp.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: ServoLanguageServer, params: lsp.DidSaveTextDocumentParams) -> None:
        ls.publish(params.text_document.uri, None)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: ServoLanguageServer, params: lsp.DidCloseTextDocumentParams) -> None:
        ls.analyses.pop(params.text_document.uri, None)
        ls.text_document_publish_diagnostics(
            lsp.PublishDiagnosticsParams(uri=params.text_document.uri, diagnostics=[]))

    def at(ls: ServoLanguageServer, doc: lsp.TextDocumentIdentifier, pos: lsp.Position) -> tuple[Analysis, int]:
        a = ls.analysis(doc.uri)
        return a, a.lines.offset(pos)

    def name_at(ls: ServoLanguageServer, doc: lsp.TextDocumentIdentifier, pos: lsp.Position):
        """(analysis, symbols, the name under the cursor), or None where there is no name or no tree."""
        a, offset = at(ls, doc, pos)
        if a.tree is None:
            return None
        sym = Symbols(a.tree)
        name = sym.at(offset)
        return None if name is None else (a, sym, name)

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    def on_hover(ls: ServoLanguageServer, params: lsp.HoverParams) -> lsp.Hover | None:
        a, offset = at(ls, params.text_document, params.position)
        return hover(a, offset)

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: ServoLanguageServer, params: lsp.DefinitionParams) -> lsp.Location | None:
        found = name_at(ls, params.text_document, params.position)
        if found is None:
            return None
        a, sym, name = found
        decl = sym.decls.get(name.text)
        if decl is None:
            return None
        return lsp.Location(uri=a.uri, range=a.lines.range(decl.name.span))

    @server.feature(lsp.TEXT_DOCUMENT_REFERENCES)
    def references(ls: ServoLanguageServer, params: lsp.ReferenceParams) -> list[lsp.Location] | None:
        found = name_at(ls, params.text_document, params.position)
        if found is None or found[2].text in PORTS:
            return None
        a, sym, name = found
        with_decl = params.context.include_declaration
        return [lsp.Location(uri=a.uri, range=a.lines.range(n.span)) for n in sym.uses(name.text)
                if with_decl or n.span not in sym.declaring]

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_HIGHLIGHT)
    def highlight(ls: ServoLanguageServer, params: lsp.DocumentHighlightParams) -> list[lsp.DocumentHighlight] | None:
        found = name_at(ls, params.text_document, params.position)
        if found is None:
            return None
        a, sym, name = found
        return [lsp.DocumentHighlight(range=a.lines.range(n.span),
                                      kind=lsp.DocumentHighlightKind.Write if n.span in sym.declaring
                                      else lsp.DocumentHighlightKind.Read) for n in sym.uses(name.text)]

    @server.feature(lsp.TEXT_DOCUMENT_DOCUMENT_SYMBOL)
    def symbols(ls: ServoLanguageServer, params: lsp.DocumentSymbolParams) -> list[lsp.DocumentSymbol] | None:
        a = ls.analysis(params.text_document.uri)
        if a.tree is None:
            return None
        out = []
        for item in a.tree.items:
            kind = KINDS.get(type(item))
            if kind is not None:
                name, detail, at_ = item.name.text, kind, item.name.span
            elif isinstance(item, nodes.MainDecl):
                name, detail, at_ = "main", "", item.keyword
            else:
                continue
            out.append(lsp.DocumentSymbol(name=name, detail=detail, kind=SYMBOL_KIND.get(kind, lsp.SymbolKind.Function),
                                          range=a.lines.range(item.span), selection_range=a.lines.range(at_)))
        return out

    @server.feature(lsp.TEXT_DOCUMENT_COMPLETION)
    def complete(ls: ServoLanguageServer, params: lsp.CompletionParams) -> lsp.CompletionList:
        a, offset = at(ls, params.text_document, params.position)
        return lsp.CompletionList(is_incomplete=False, items=completion(a, offset))

    @server.feature(lsp.TEXT_DOCUMENT_PREPARE_RENAME)
    def prepare_rename(ls: ServoLanguageServer, params: lsp.PrepareRenameParams) -> lsp.Range | None:
        found = name_at(ls, params.text_document, params.position)
        if found is None or found[2].text not in found[1].decls:
            return None
        a, sym, name = found
        return a.lines.range(name.span)

    @server.feature(lsp.TEXT_DOCUMENT_RENAME)
    def on_rename(ls: ServoLanguageServer, params: lsp.RenameParams) -> lsp.WorkspaceEdit:
        a, offset = at(ls, params.text_document, params.position)
        return rename(a, offset, params.new_name)

    return server


def main() -> int:
    """Serve the language server over standard input and output until the editor ends it."""
    build_server().start_io()
    return 0
