"""Simulated pin waveforms as a Value Change Dump (VCD) file, for GTKWave.

`write_vcd(plan, trace, path, source_name, ...)` turns a `SimTrace` into a VCD
whose times are in the unit its `$timescale` names, at any clock: `1 us`
when a machine cycle is one microsecond (12 MHz, or 24 MHz in 6T mode), so a
timestamp is `PortWrite.cycle` unchanged; else `1 ns`, each cycle count
times the machine cycle, to the nearest ns (11.0592 MHz: a cycle is
1085.069 ns, and a 90deg pulse of 1360 cycles shows as 1475694 ns). The
hierarchy is

    servoc            top scope
      P1              one scope per port that has a declared servo or input
        hip_l         1-bit wire per servo on that port, named after the servo
        button        1-bit wire per `input` on that port: the level on its pin
        ...
        latch         8-bit wire: the port (latch and pins) after every write
      serial          with `serial`: RXD (P3.0) and TXD (P3.1)

Every declared servo gets a wire, also one that is never moved (its line is
still driven low after reset). Wires start at 1 at time 0 (ports reset to
0xFF) and change at the cycles of `SimTrace.pin_edges`; the latch starts at
0xFF and follows the writes that change it. An input's wire follows what the
run drove on its pin (`pins`: the (cycle, port, level) changes of
`api.Stimulus.pins`). RXD shows each byte the host sent (`rx`: its start
bit's cycle and the byte), TXD each byte the firmware sent (from the write
to SBUF; a real UART starts it at its next bit time, within one bit), both
as start bit, 8 data bits LSB first and stop bit, `bit_cycles` each. The
dump ends at `trace.cycles`. The output has no `$date`, so the same trace
always gives the same bytes.

pyvcd is an optional dependency (extra `vcd`); it is imported only when a
VCD is written, and its absence raises `MissingExtra`.
"""

from __future__ import annotations

import io
from fractions import Fraction

from .steps import Plan
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


def render_vcd(plan: Plan, trace: SimTrace, source_name: str, pins: tuple = (), rx: tuple = (),
               bit_cycles: int = 0) -> str:
    """The VCD text of `trace` for the servos, inputs and serial line of `plan`'s program."""
    writer_class = _writer_class()
    target = plan.program.target
    servos = sorted(plan.program.servos, key=lambda s: (s.port, s.bit))
    inputs = sorted(plan.program.inputs, key=lambda i: (i.port, i.bit))
    ports = sorted({s.port for s in servos} | {i.port for i in inputs})
    whole = target.cycle_us == 1
    unit = "1 us" if whole else "1 ns"

    def at(cycle: int) -> int:
        return cycle if whole else int(cycle * target.cycle_us * 1000 + Fraction(1, 2))

    comment = (f"servoc: {source_name.replace('$', '_')}; frame period {plan.period_us} us; "
               f"{len(servos)} servos; {target.describe()}, 1 machine cycle = {float(target.cycle_us * 1000):.3f} ns; "
               f"{trace.cycles} cycles simulated; times in {unit.split()[1]}")
    out = io.StringIO()
    writer = writer_class(out, timescale=unit, date="", comment=comment, version="servoc")
    # (cycle, order, variable, value): `order` keeps the writes of one cycle in a fixed order.
    events: list[tuple[int, int, object, int]] = []
    order = 0

    def add(cycle: int, var, value: int) -> None:
        nonlocal order
        events.append((cycle, order, var, value))
        order += 1

    for port in ports:
        scope = f"{TOP_SCOPE}.P{port}"
        for s in (s for s in servos if s.port == port):
            var = writer.register_var(scope, s.name, "wire", size=1, init=1)
            for cycle, level in trace.pin_edges(s.port, s.bit):
                add(cycle, var, level)
        for i in (i for i in inputs if i.port == port):
            var = writer.register_var(scope, i.name, "wire", size=1, init=1)
            level = 1
            for cycle, p, value in pins:
                if p == port and (value >> i.bit) & 1 != level:
                    level = (value >> i.bit) & 1
                    add(cycle, var, level)
        if any(s.port == port for s in servos):
            latch = writer.register_var(scope, LATCH_NAME, "wire", size=8, init=_RESET_LATCH)
            for w in trace.port_writes(port):
                add(w.cycle, latch, w.value)
    if plan.program.serial is not None and bit_cycles:
        for name, frames in (("RXD", rx), ("TXD", trace.sent)):
            var = writer.register_var(f"{TOP_SCOPE}.serial", name, "wire", size=1, init=1)
            for start, byte in frames:
                bits = [0] + [(byte >> k) & 1 for k in range(8)] + [1]
                for k, level in enumerate(bits):
                    add(start + k * bit_cycles, var, level)
    events.sort(key=lambda e: (e[0], e[1]))
    last = 0
    for cycle, _, var, value in events:
        writer.change(var, at(cycle), value)
        last = cycle
    writer.close(at(max(trace.cycles, last)))
    return out.getvalue()


def write_vcd(plan: Plan, trace: SimTrace, path: str, source_name: str, pins: tuple = (), rx: tuple = (),
              bit_cycles: int = 0) -> None:
    """Write the pin waveforms of `trace` to `path` as a VCD (atomically); see `render_vcd`."""
    write_atomic(path, render_vcd(plan, trace, source_name, pins, rx, bit_cycles))
