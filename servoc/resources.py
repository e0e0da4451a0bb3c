"""The one place that loads the grammar and the firmware templates.

Both ship inside the package (`servoc.grammar`, `servoc.firmware_templates`,
mapped from the top-level `grammar/` and `firmware_templates/` folders).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources


@lru_cache(maxsize=None)
def grammar_text() -> str:
    return resources.files("servoc.grammar").joinpath("servo.lark").read_text(encoding="utf-8")


def template_text(name: str) -> str:
    return resources.files("servoc.firmware_templates").joinpath(name).read_text(encoding="utf-8")


def template_names() -> list[str]:
    return sorted(p.name for p in resources.files("servoc.firmware_templates").iterdir() if p.name.endswith(".j2"))
