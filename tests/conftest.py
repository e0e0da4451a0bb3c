"""Shared helpers for the firmware tests: compile .servo text, run it in ucsim.

Only firmware helpers live here (see tests/test_firmware.py, test_codegen.py,
test_verify.py). Every helper needs SDCC and ucsim; they never skip.
"""

from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass

from servoc import api
from servoc.diagnostics import render_short
from servoc.plan import Plan
from servoc.source import SourceFile

TIMING_RE = re.compile(r"^\s*[0-9A-F]{6}\s+(?:[0-9A-F]{2}\s)+\s*\[(\d+)\]\s+\d+\s+(.*)$")


@dataclass(frozen=True)
class Built:
    source: SourceFile
    plan: Plan
    firmware: api.Firmware
    diagnostics: tuple

    def verify(self, frames: int | None = None):
        """Run in ucsim and compare `frames` frames (default: the whole program and 3 more)."""
        if frames is None:
            frames = 200 if self.plan.total_frames is None else self.plan.total_frames + 3
        return api.verify(self.plan, self.firmware, frames)


def compile_file(path: str) -> tuple[Built | None, api.FrontEnd, list]:
    """Compile one .servo file: (Built or None, front end, diagnostics)."""
    source, reporter = api.load_source(path)
    fe, fw = api.build(source, reporter)
    built = None if fw is None else Built(source, fe.plan, fw, tuple(reporter.diagnostics))
    return built, fe, reporter.diagnostics


def build_text(text: str, name: str = "prog.servo") -> Built:
    """Compile .servo text written to a temporary file; fails the test on any error."""
    with tempfile.TemporaryDirectory(prefix="servoc-test-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        built, _, diags = compile_file(path)
        source = api.load_source(path)[0]
    errors = [render_short(d, source) for d in diags if d.is_error]
    assert built is not None and not errors, "compile failed:\n" + "\n".join(errors) + "\n--- source:\n" + text
    return built


def front_end_text(text: str, name: str = "prog.servo") -> tuple[api.FrontEnd, list]:
    with tempfile.TemporaryDirectory(prefix="servoc-test-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        source, reporter = api.load_source(path)
        fe = api.front_end(source, reporter)
    return fe, reporter.diagnostics


def assert_exact(report, text: str = "") -> None:
    """The report is OK with zero error and checked some pulses."""
    detail = "\n".join(str(m) for m in report.mismatches[:15])
    assert report.ok, f"{report.summary()}\n{detail}\n--- source:\n{text}"
    assert report.max_error_cycles == 0, report.summary()
    assert report.pulses > 0, report.summary()


def listing_lines(listing: str) -> list[tuple[int, str]]:
    """(machine cycles, source text) of every instruction line of an sdas8051 listing."""
    out = []
    for line in listing.splitlines():
        m = TIMING_RE.match(line)
        if m:
            out.append((int(m.group(1)) // 12, m.group(2)))
    return out


def servo_decls(pins: list[tuple[int, int]], prefix: str = "s", options: str = "") -> str:
    return "".join(f"servo {prefix}{p}_{b} = P{p}.{b}{(' ' + options) if options else ''}\n" for p, b in pins)


def pose(name: str, values: dict[str, int]) -> str:
    return f"pose {name} {{ " + ", ".join(f"{k}: {v}" for k, v in values.items()) + " }\n"
