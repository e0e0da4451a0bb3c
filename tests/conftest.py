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
from servoc.steps import Plan
from servoc.source import SourceFile


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


def compile_file(path: str, for_size: bool = False) -> tuple[Built | None, api.FrontEnd, list]:
    """Compile one .servo file: (Built or None, front end, diagnostics); `for_size`: built for size."""
    source, reporter = api.load_source(path)
    fe, fw = api.build(source, reporter, for_size)
    built = None if fw is None else Built(source, fe.plan, fw, tuple(reporter.diagnostics))
    return built, fe, reporter.diagnostics


def build_text(text: str, name: str = "prog.servo", for_size: bool = False) -> Built:
    """Compile .servo text written to a temporary file; fails the test on any error."""
    with tempfile.TemporaryDirectory(prefix="servoc-test-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        built, _, diags = compile_file(path, for_size)
        source = api.load_source(path)[0]
    errors = [render_short(d, source) for d in diags if d.is_error]
    assert built is not None and not errors, "compile failed:\n" + "\n".join(errors) + "\n--- source:\n" + text
    return built


def build_engine(text: str, stepping: bool = False, stagger: bool = False, merged: bool = False) -> Built:
    """Compile .servo text with one edge handler (codegen.generate's `stepping`, `stagger`, `merged`), not the
    one whose period is shortest: at the program's `frame`, or at that handler's own shortest period
    where the program's is shorter."""
    from servoc import codegen
    from servoc.diagnostics import Reporter

    for _ in range(2):
        fe, diags = front_end_text(text)
        assert fe.plan is not None, diags
        unit = codegen.generate(fe.plan, fe.source, stepping=stepping, stagger=stagger, merged=merged or None)
        if unit.period_holds:
            break
        text = f"frame {unit.min_period_us}us\n" + text
    assert unit.period_holds and (unit.budget.steps, unit.budget.stagger, unit.budget.merged) == (stepping, stagger, merged)
    reporter = Reporter(fe.source)
    fw = api.assemble(unit, reporter)
    assert fw is not None, reporter.diagnostics
    plan = api.with_rises(fe.plan, unit)       # where this code's ports rise
    return Built(fe.source, plan, fw, tuple(diags))


def front_end_text(text: str, name: str = "prog.servo") -> tuple[api.FrontEnd, list]:
    with tempfile.TemporaryDirectory(prefix="servoc-test-") as tmp:
        path = os.path.join(tmp, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        source, reporter = api.load_source(path)
        fe = api.front_end(source, reporter)
    return fe, reporter.diagnostics


def simulate_events(text: str, scenario: str, frames: int, hex_text: str | None = None, firmware=None):
    """Compile `text` and run it (or `firmware`, or `hex_text`, built from it) in ucsim for `frames`
    frames from the first pulse, driven by the events `scenario` (as `servoc verify --events`),
    watched by the firmware's probes: (plan, events, trace)."""
    from servoc import events
    built = build_text(text)
    plan = built.plan
    evs = events.parse(scenario, plan.program.inputs, plan.program.serial is not None)
    stim = api.stimulus(plan, evs)
    fw = firmware or built.firmware
    cycles = max(api.cycles_needed(plan, frames), stim.last() + 1)
    trace = api.simulate(hex_text or fw.hex_text, cycles, plan.program.target, stim, api.probes(fw))
    choices = api.events_report(plan, trace, frames, evs)[0]
    if api.cycles_needed(plan, frames, choices) > trace.cycles:     # a later first pulse: run on
        cycles = max(api.cycles_needed(plan, frames, choices), stim.last() + 1)
        trace = api.simulate(hex_text or fw.hex_text, cycles, plan.program.target, stim, api.probes(fw))
    return plan, evs, trace


def assert_exact(report, text: str = "") -> None:
    """The report is OK with zero error and checked some pulses."""
    detail = "\n".join(str(m) for m in report.mismatches[:15])
    assert report.ok, f"{report.summary()}\n{detail}\n--- source:\n{text}"
    assert report.max_error_cycles == 0, report.summary()
    assert report.pulses > 0, report.summary()


@dataclass(frozen=True)
class Instr:
    address: int
    cycles: int
    op: str
    args: tuple[str, ...]
    labels: tuple[str, ...]


def parse_listing(listing: str) -> tuple[list[Instr], dict[str, int]]:
    """Instructions of an sdas8051 listing with their machine cycles, and label -> instruction index."""
    instrs: list[Instr] = []
    labels: dict[str, int] = {}
    pending: list[str] = []
    for line in listing.splitlines():
        # Columns: address 6..11, code bytes, [clocks] at 30, source line number 34..38, source from 40.
        head, src = line[:39], line[40:]
        if not head[34:39].strip().isdigit():
            continue
        code = src.split(";", 1)[0].strip()
        m = re.match(r"^([A-Za-z_][\w]*)::?\s*(.*)$", code)
        if m:
            pending.append(m.group(1))
            code = m.group(2)
        clocks = re.search(r"\[(\d+)\]", head)
        if not code:
            continue
        if clocks is None:          # a directive or an equate: labels before it are not code labels
            pending = []
            continue
        assert int(clocks.group(1)) % 12 == 0
        parts = code.split(None, 1)
        args = tuple(a.strip() for a in parts[1].split(",")) if len(parts) > 1 else ()
        for lab in pending:
            labels[lab] = len(instrs)
        instrs.append(Instr(int(head[6:12], 16), int(clocks.group(1)) // 12, parts[0].upper(), args, tuple(pending)))
        pending = []
    return instrs, labels


def servo_decls(pins: list[tuple[int, int]], prefix: str = "s", options: str = "") -> str:
    return "".join(f"servo {prefix}{p}_{b} = P{p}.{b}{(' ' + options) if options else ''}\n" for p, b in pins)


def pose(name: str, values: dict[str, int]) -> str:
    return f"pose {name} {{ " + ", ".join(f"{k}: {v}" for k, v in values.items()) + " }\n"


def damaged(data: bytes, rnd, splices: tuple = ()) -> bytes:
    """`data` damaged 1-4 times at random places, as files get: a byte flipped, bytes cut or inserted,
    the rest cut off, or (when `splices` are given) one of them put in. Never empty."""
    data = bytearray(data)
    for _ in range(rnd.randint(1, 4)):
        i = rnd.randrange(len(data))
        action = rnd.choice(["flip", "cut", "insert", "truncate"] + (["splice"] if splices else []))
        if action == "flip":
            data[i] = rnd.randrange(256)
        elif action == "cut":
            del data[i:i + rnd.randint(1, 6)]
        elif action == "insert":
            data[i:i] = bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 6)))
        elif action == "splice":
            data[i:i] = rnd.choice(splices)
        else:
            del data[i:]
        if not data:
            data = bytearray(b"\n")
    return bytes(data)
