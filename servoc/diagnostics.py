"""Diagnostics: what every stage reports to the user.

A `Diagnostic` has a code (e.g. ``infeasible-speed``), a severity, a message,
a span in the source, an optional label shown under the caret, optional
secondary labels (another place in the source and what it is, such as "first
declared here", underlined with `-` below the primary one) and an optional help
line. `Reporter` collects them; the renderers turn them into the
``FILE:LINE:COL: severity: message [code]`` form (the spec's
``FILE:LINE:COL: error|warning: message`` with the rule's code at the end), a caret display, or JSON.
"""

from __future__ import annotations

import json
import unicodedata
from dataclasses import dataclass, field
from enum import Enum

from .source import NO_SPAN, SourceFile, Span


class Severity(str, Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True)
class Label:
    """A secondary place a diagnostic points at, e.g. where a name was first declared."""
    span: Span
    message: str


@dataclass(frozen=True)
class Diagnostic:
    code: str
    severity: Severity
    message: str
    span: Span = NO_SPAN
    label: str = ""
    help: str = ""
    secondary: tuple[Label, ...] = ()

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


def limit_diagnostic(code: str, message: str, help_: str, span: Span, labels=()) -> Diagnostic:
    """A resource limit of the generated code (layout.LayoutError) as an error at `span`, with
    (span, text) of the other places it comes from."""
    return Diagnostic(code, Severity.ERROR, message, span, "", help_, tuple(Label(sp, text) for sp, text in labels))


@dataclass
class Reporter:
    """Collects diagnostics for one source file."""

    source: SourceFile
    diagnostics: list[Diagnostic] = field(default_factory=list)

    def report(self, diag: Diagnostic) -> None:
        self.diagnostics.append(diag)

    def error(self, code: str, message: str, span: Span = NO_SPAN, *, label: str = "", help: str = "",
              secondary: tuple[Label, ...] = ()) -> None:
        self.report(Diagnostic(code, Severity.ERROR, message, span, label, help, tuple(secondary)))

    def warning(self, code: str, message: str, span: Span = NO_SPAN, *, label: str = "", help: str = "",
              secondary: tuple[Label, ...] = ()) -> None:
        self.report(Diagnostic(code, Severity.WARNING, message, span, label, help, tuple(secondary)))

    def note(self, code: str, message: str, span: Span = NO_SPAN, *, label: str = "", help: str = "",
              secondary: tuple[Label, ...] = ()) -> None:
        self.report(Diagnostic(code, Severity.NOTE, message, span, label, help, tuple(secondary)))

    @property
    def has_errors(self) -> bool:
        return any(d.is_error for d in self.diagnostics)

    def sorted(self) -> list[Diagnostic]:
        """Diagnostics in source order (stable for equal positions)."""
        return sorted(self.diagnostics, key=lambda d: (d.span.start, d.span.end))


def _paint(text: str, style: str, color: bool) -> str:
    if not color:
        return text
    codes = {"error": "1;31", "warning": "1;33", "note": "1;36", "bold": "1", "blue": "1;34"}
    return f"\x1b[{codes[style]}m{text}\x1b[0m"


def _printable(line: str) -> str:
    """A source line as shown under a diagnostic: one printable character per character, so
    the caret stays aligned and no control character reaches the terminal."""
    out = []
    for ch in line:
        if ch.isspace() and not ch.isprintable():
            out.append(" ")                     # tab, CR (of CRLF), VT, FF, line separators
        elif unicodedata.category(ch) in ("Cc", "Cf", "Cs", "Co", "Cn"):
            out.append("\ufffd")
        else:
            out.append(ch)
    return "".join(out)


def render_short(diag: Diagnostic, source: SourceFile) -> str:
    """One line: FILE:LINE:COL: severity: message [code]."""
    line, col = source.line_col(diag.span.start)
    return f"{source.path}:{line}:{col}: {diag.severity.value}: {diag.message} [{diag.code}]"


SHOWN_COLUMNS = 100
"""A source line longer than this is shown cut to a window of this many columns around the caret,
with `...` where text is left out."""
_BEFORE = 40        # columns of the window before the caret when the line is cut


def _underline(source: SourceFile, span: Span) -> tuple[int, int, str, int]:
    """The line of a span, its column, the line's text and how many columns to underline."""
    line, col = source.line_col(span.start)
    text = source.line_text(line)
    end_line, end_col = source.line_col(max(span.start, span.end - 1))
    if span.end <= span.start:
        width = 1
    elif end_line == line:
        width = end_col - col + 1
    else:   # a span over several lines: underline the rest of its first line
        width = len(text.rstrip()) - col + 1
    width = max(1, min(width, len(text) - col + 1)) if len(text) >= col else 1
    return line, col, text, width


def _window(length: int, col: int) -> tuple[int, int]:
    """The part [start, end) of a line of `length` characters shown for a mark at column `col`."""
    if length <= SHOWN_COLUMNS:
        return 0, length
    start = max(0, min(col - 1 - _BEFORE, length - SHOWN_COLUMNS))
    return start, start + SHOWN_COLUMNS


def _cut(text: str, window: tuple[int, int]) -> tuple[str, int]:
    """The shown part of a line, printable, with `...` for what is left out; and how far its
    columns are shifted against the line's."""
    start, end = window
    head = "..." if start > 0 else ""
    tail = "..." if end < len(text) else ""
    return head + _printable(text[start:end]) + tail, len(head) - start


def render_full(diag: Diagnostic, source: SourceFile, color: bool = False) -> str:
    """The one-line header, the source line, a caret under the span, each secondary label's
    line with `-` under its span, and the help line."""
    line, col = source.line_col(diag.span.start)
    head = f"{source.path}:{line}:{col}: "
    head += _paint(diag.severity.value, diag.severity.value, color)
    head += f": {diag.message} [{diag.code}]"
    out = [head]
    # NO_SPAN means "no place in the file" (e.g. a missing `main`): no source line then.
    if source.text and diag.span != NO_SPAN:
        marks = [(diag.span, "^", diag.label, diag.severity.value)]
        marks += [(lab.span, "-", lab.message, "blue") for lab in diag.secondary if lab.span != NO_SPAN]
        shown = [(*_underline(source, span), char, text, style) for span, char, text, style in marks]
        pad = max(4, *(len(str(m[0])) for m in shown))
        last, window = None, (0, 0)
        for at, c, text, width, char, label, style in shown:
            # a label on the line just shown shares it when it falls in the part shown
            if at != last or not window[0] <= c - 1 < window[1]:
                window = _window(len(text), c)
                shown_text, shift = _cut(text, window)
                out.append(_paint(f"{at:>{pad}} | ", "blue", color) + shown_text)
                last = at
            width = max(1, min(width, window[1] - (c - 1)))
            under = " " * (c - 1 + shift) + char * width + (f" {label}" if label else "")
            out.append(_paint(" " * pad + " | ", "blue", color) + _paint(under, style, color))
    if diag.help:
        out.append(_paint("     = ", "blue", color) + "help: " + diag.help)
    return "\n".join(out)


def summary(diags: list[Diagnostic]) -> str:
    """e.g. '1 error, 2 warnings, 0 notes'."""
    counts = {s: sum(1 for d in diags if d.severity is s) for s in Severity}

    def n(k: int, word: str) -> str:
        return f"{k} {word}{'' if k == 1 else 's'}"

    return ", ".join([n(counts[Severity.ERROR], "error"), n(counts[Severity.WARNING], "warning"), n(counts[Severity.NOTE], "note")])


def _where(span: Span, source: SourceFile) -> dict:
    line, col = source.line_col(span.start)
    end_line, end_col = source.line_col(span.end)
    return {"line": line, "column": col, "end_line": end_line, "end_column": end_col}


def to_dict(diags: list[Diagnostic], source: SourceFile | None) -> dict:
    """The JSON document of a run: {"diagnostics": [...], "summary": {"errors": E, "warnings": W, "notes": N}}."""
    items = []
    for d in diags:
        assert source is not None
        item = {"file": source.path, **_where(d.span, source),
                "severity": d.severity.value, "code": d.code, "message": d.message,
                "label": d.label, "help": d.help}
        if d.secondary:     # only when there are any, so that other diagnostics keep their form
            item["labels"] = [{**_where(lab.span, source), "message": lab.message} for lab in d.secondary]
        items.append(item)
    return {"diagnostics": items, "summary": counts(diags)}


def counts(diags: list[Diagnostic]) -> dict[str, int]:
    """{"errors": E, "warnings": W, "notes": N}: the summary line as counts."""
    return {f"{s.value}s": sum(1 for d in diags if d.severity is s) for s in Severity}


def to_json(diags: list[Diagnostic], source: SourceFile | None) -> str:
    return json.dumps(to_dict(diags, source), indent=2)
