"""Intermediate forms as JSON (`--emit ast|model|plan`): dataclasses to plain data, spans as line:col."""

from __future__ import annotations

import dataclasses
import json
from enum import Enum
from fractions import Fraction

from .source import SourceFile, Span


def to_data(obj, source: SourceFile):
    if isinstance(obj, Span):
        line, col = source.line_col(obj.start)
        return f"{line}:{col}"
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {"kind": type(obj).__name__}
        for f in dataclasses.fields(obj):
            if f.name in ("program",) and type(obj).__name__ == "Plan":
                continue
            out[f.name] = to_data(getattr(obj, f.name), source)
        return out
    if isinstance(obj, Fraction):
        return str(obj) if obj.denominator != 1 else obj.numerator
    if isinstance(obj, Enum):
        return obj.value
    if isinstance(obj, (tuple, list)):
        return [to_data(x, source) for x in obj]
    if isinstance(obj, (frozenset, set)):
        return sorted(to_data(x, source) for x in obj)
    if isinstance(obj, dict):
        return {str(k): to_data(v, source) for k, v in obj.items()}
    return obj


def dump(obj, source: SourceFile) -> str:
    return json.dumps(to_data(obj, source), indent=2, ensure_ascii=False)
