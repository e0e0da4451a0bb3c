"""Source text and spans.

A `SourceFile` holds the decoded text of one program; a `Span` is a pair of
character offsets into it. Line and column (both 1-based) are computed only
when a diagnostic is rendered.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Span:
    start: int
    end: int

    def to(self, other: "Span") -> "Span":
        """The span covering self and other."""
        return Span(min(self.start, other.start), max(self.end, other.end))


NO_SPAN = Span(0, 0)


@dataclass(frozen=True)
class SourceFile:
    path: str
    text: str
    _line_starts: tuple[int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        starts = [0] + [m.end() for m in re.finditer("\n", self.text)]
        object.__setattr__(self, "_line_starts", tuple(starts))

    @classmethod
    def from_bytes(cls, path: str, data: bytes) -> tuple["SourceFile", int | None]:
        """Decode UTF-8; returns the file and the offset of the first bad byte, if any.

        Undecodable bytes become U+FFFD so that later stages always have text.
        """
        try:
            return cls(path, data.decode("utf-8")), None
        except UnicodeDecodeError as exc:
            return cls(path, data.decode("utf-8", errors="replace")), exc.start

    def line_col(self, offset: int) -> tuple[int, int]:
        """1-based line and column of a character offset."""
        offset = max(0, min(offset, len(self.text)))
        line = bisect.bisect_right(self._line_starts, offset) - 1
        return line + 1, offset - self._line_starts[line] + 1

    def line_text(self, line: int) -> str:
        """The text of a 1-based line, without its newline."""
        start = self._line_starts[line - 1]
        end = self.text.find("\n", start)
        return self.text[start:] if end < 0 else self.text[start:end]

    def snippet(self, span: Span) -> str:
        return self.text[span.start:span.end]
