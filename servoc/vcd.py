"""Simulated pin waveforms as a Value Change Dump (VCD) file, for GTKWave.

`write_vcd(plan, trace, path, source_name)` turns a `SimTrace` into a VCD
with a timescale of 1 us: one machine cycle of the 12 MHz AT89C52 is 1 us, so
a timestamp is `PortWrite.cycle` unchanged. The hierarchy is

    servoc            top scope
      P1              one scope per port that has a declared servo
        hip_l         1-bit wire per servo on that port, named after the servo
        ...
        latch         8-bit wire: the port latch after every write

Every declared servo gets a wire, also one that is never moved (its line is
still driven low after reset). Wires start at 1 at time 0 (ports reset to
0xFF) and change at the cycles of `SimTrace.pin_edges`; the latch starts at
0xFF and follows the writes that change it. The dump ends at `trace.cycles`.
The output has no `$date`, so the same trace always gives the same bytes.

pyvcd is an optional dependency (extra `vcd`); it is imported only when a
VCD is written, and its absence raises `MissingExtra`.
"""

from __future__ import annotations

import io

from .plan import Plan
from .plot import MissingExtra
from .sim import SimTrace
from .toolchain import write_atomic

__all__ = ["MissingExtra", "TOP_SCOPE", "LATCH_NAME", "render_vcd", "write_vcd"]

TOP_SCOPE = "servoc"
LATCH_NAME = "latch"
_RESET_LATCH = 0xFF


def _writer_class():
    try:
        from vcd import VCDWriter
    except ImportError as exc:
        raise MissingExtra("VCD output", "vcd", "pyvcd") from exc
    return VCDWriter


def render_vcd(plan: Plan, trace: SimTrace, source_name: str) -> str:
    """The VCD text of `trace` for the servos of `plan`'s program."""
    writer_class = _writer_class()
    servos = sorted(plan.program.servos, key=lambda s: (s.port, s.bit))
    ports = sorted({s.port for s in servos})
    comment = (f"servoc: {source_name.replace('$', '_')}; frame period {plan.period_us} us; "
               f"{len(servos)} servos; 1 us = 1 machine cycle at 12 MHz; {trace.cycles} cycles simulated")
    out = io.StringIO()
    writer = writer_class(out, timescale="1 us", date="", comment=comment, version="servoc")
    # (cycle, order, variable, value): `order` keeps the writes of one cycle in a fixed order.
    events: list[tuple[int, int, object, int]] = []
    order = 0
    for port in ports:
        scope = f"{TOP_SCOPE}.P{port}"
        for s in (s for s in servos if s.port == port):
            var = writer.register_var(scope, s.name, "wire", size=1, init=1)
            for cycle, level in trace.pin_edges(s.port, s.bit):
                events.append((cycle, order, var, level))
                order += 1
        latch = writer.register_var(scope, LATCH_NAME, "wire", size=8, init=_RESET_LATCH)
        for w in trace.port_writes(port):
            events.append((w.cycle, order, latch, w.value))
            order += 1
    events.sort(key=lambda e: (e[0], e[1]))
    last = 0
    for cycle, _, var, value in events:
        writer.change(var, cycle, value)
        last = cycle
    writer.close(max(trace.cycles, last))
    return out.getvalue()


def write_vcd(plan: Plan, trace: SimTrace, path: str, source_name: str) -> None:
    """Write the pin waveforms of `trace` to `path` as a VCD (atomically)."""
    write_atomic(path, render_vcd(plan, trace, source_name))
