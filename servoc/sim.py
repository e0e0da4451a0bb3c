"""Run an Intel HEX image in ucsim (s51) and capture every write to the ports.

Input
    `run(hex_text, cycles)`: an Intel HEX image for an AT89C52 (8052 core
    with Timer2, 12 MHz crystal, so 1 machine cycle = 12 clocks = 1 us) and
    the number of machine cycles to simulate from reset.

Output
    `SimTrace`: every write to P0, P1, P2 and P3 (byte writes such as
    ``MOV P1,#x`` / ``ORL P1,A`` / ``ANL P1,#x`` / ``XRL`` / ``INC`` /
    ``DJNZ`` / ``POP P1`` / ``XCH A,P1``, and bit writes such as ``SETB``,
    ``CLR``, ``CPL``, ``MOV P1.0,C``, ``JBC``), in execution order, each as
    a `PortWrite` (cycle, port number, latch value after the write), plus
    the total number of simulated machine cycles.  Writes that do not change
    the value are recorded too; `SimTrace.pin_edges` keeps only changes.

Timing: the meaning of `PortWrite.cycle`
    ``cycle`` is the number of machine cycles from reset to the END of the
    instruction that wrote the port: an instruction starting at cycle ``s``
    with length ``n`` cycles (``MOV P1,#d``: 2, ``SETB P1.0``: 1, ``ORL P1,A``:
    1, ``ANL P1,#d``: 2, ...) reports ``cycle = s + n``.  This is the cycle
    boundary at which the new level appears on the pin of a real 8051 (the
    latch is written in the instruction's last machine cycle and drives the
    pin from the next one), and it is the same rule for every instruction
    kind, so the difference between two writes is exactly the sum of the
    lengths of the instructions executed between the ends of the two
    writing instructions.  The first instruction starts at cycle 0.  Ports
    are 0xFF after reset, so every pin starts high.

How it works
    s51 runs a generated command script (``-C``); the script sets event
    breakpoints on the port SFRs (``break sfr w 0x90``) and on each port bit
    (``break bits w 0x90`` ... ``0x97``; bit instructions reach the latch
    through the bit space, which the SFR breakpoint does not see).  Each
    breakpoint carries commands that print a marker, the tick counter
    (``sim_ticks``, 12 per machine cycle) and the latch, then ``run`` on, so
    capture needs no round trip per event.  When a breakpoint fires, the
    writing instruction has completed, and ``sim_ticks`` counts the clocks
    to its end (an interrupt accepted right after it is not yet counted).
    The cycle limit is a VCD *input* file with a single event at
    ``cycles - 0.5`` machine cycles, driving a cell of ucsim's private
    variable space (invisible to the 8051) with ``break`` enabled: the
    simulator stops at the first instruction boundary at or after
    ``cycles``.  `SimTrace.cycles` is that boundary (``>= cycles``; it
    exceeds ``cycles`` by less than the length of one instruction, or by
    one more cycle when an interrupt is accepted right there).

Errors
    `SimError` when s51 cannot run, does not finish within the wall-clock
    timeout (the process is killed and reaped), or stops before the limit:
    ucsim stops on a stack overflow (SP incremented past 0xFF), which is
    reported with its message.  Unknown opcodes do not stop it.

ucsim 0.6.4 behaviour that matters for timing
    * Accepting an interrupt costs 1 machine cycle (the hardware LCALL of a
      real 8051 takes 2), and an interrupt is accepted right after the
      instruction during which its flag was set, without the real 8051's
      polling delay.  ISR timing is therefore up to a few cycles early
      compared with silicon; polled flags (``JNB TF2,$``) are exact.
    * Timer2 auto-reload (T2CON = 0x04) works on the C52 type: TF2 is set
      every 65536 - RCAP2 cycles exactly.
    * ``step N ms`` / ``step N clk`` never stop on the 8051 core, hence the
      VCD cycle limit.  Fetch breakpoints set by the user at every address
      of a loop would defeat it; the probes (`run(probes=...)`) stand at a
      few addresses of the program, but a breakpoint whose commands run on
      can swallow a VCD stop that falls at the same instruction boundary
      (`MissedInput`: the caller retries with the changes a little later).
    * ``sim_ticks`` is 32 bits wide (wraps after 2**32 clocks = 357.9 s
      simulated).  Event times are unwrapped on the assumption that some
      port is written at least once per 357 s of simulated time; the total
      comes from ``state``, which is 64-bit.
    * Command scripts given with ``-C`` run before the files named on the
      command line are loaded, so the script loads the image itself
      (``file "fw.ihx"``).
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from .toolchain import find_tool, rom_used

__all__ = [
    "CLOCKS_PER_CYCLE",
    "CPU_TYPE",
    "PORT_SFR",
    "PortWrite",
    "Probe",
    "SimError",
    "SimTrace",
    "XTAL_HZ",
    "run",
]

CPU_TYPE = "C52"
"""s51 ``-t`` value: the CMOS 8052 (Timer2, 256 bytes of IRAM, idle and
power-down modes), like the AT89C52; ``s51 -H`` lists the types."""

XTAL_HZ = 12_000_000
CLOCKS_PER_CYCLE = 12

PORT_SFR: dict[int, int] = {0: 0x80, 1: 0x90, 2: 0xA0, 3: 0xB0}
"""Port number -> SFR address (bit addresses are SFR + 0..7)."""

_MARK_BASE = 3141500  # marker printed before each event: _MARK_BASE + port
_MARK_END = _MARK_BASE + 99  # marker printed before the final tick count
_MARK_INPUT = _MARK_BASE + 50  # marker printed after the run stopped for an input change
_MARK_TX = _MARK_BASE + 60     # marker printed before the tick count of each write to SBUF
_MARK_PROBE = _MARK_BASE + 70  # marker printed before a probe's tag, tick count and RAM bytes
SBUF = 0x99

TICKS_WRAP = 1 << 32  # sim_ticks is a 32-bit unsigned value
_STATE_CLKS_RE = re.compile(r"^Total time since last reset=.*\((\d+) clks\)")


class SimError(Exception):
    """The simulator failed, timed out or stopped before the cycle limit."""

    def __init__(self, message: str, output: str = ""):
        super().__init__(message)
        self.output = output

class MissedInput(SimError):
    """ucsim stopped for an input change later than asked (a port-write breakpoint in the same
    instruction went on with the run): the changes came at the wrong times."""


@dataclass(frozen=True)
class PortWrite:
    """One write to a port latch.

    `cycle`: machine cycles from reset to the end of the writing instruction
    (see the module docstring); `port`: 0..3; `value`: the latch after the
    write.
    """

    cycle: int
    port: int
    value: int


@dataclass(frozen=True)
class Probe:
    """The firmware reached a probed code address: `tag` (the caller's number for that address),
    `cycle` (machine cycles from reset to the start of the instruction there, before it runs) and
    `ram` (the internal RAM bytes asked for, read at that moment)."""

    tag: int
    cycle: int
    ram: tuple[int, ...] = ()


@dataclass(frozen=True)
class SimTrace:
    """All port writes of one simulation run, and its length in cycles."""

    writes: tuple[PortWrite, ...]
    cycles: int
    sent: tuple[tuple[int, int], ...] = ()   # (cycle, byte) of each byte the UART sent: the end of
                                             # the instruction that wrote SBUF
    probes: tuple[Probe, ...] = ()           # each time the firmware reached a probed address, in order
    inputs: tuple = ()                       # (cycle, port, outside level) changes ucsim made, as made
    uart: tuple | None = None                # (cycle, on) changes of the UART's input flag, as made
    observation: object = None               # what the probes saw (observe.Observation), when probed

    def port_writes(self, port: int) -> list[PortWrite]:
        """The writes to one port, in order."""
        return [w for w in self.writes if w.port == port]

    def pin_edges(self, port: int, bit: int) -> list[tuple[int, int]]:
        """(cycle, new level) for every change of pin ``Pport.bit``.

        The level before the first write is 1 (ports reset to 0xFF); writes
        that leave the bit unchanged produce no entry.
        """
        _check_pin(port, bit)
        level = 1
        edges: list[tuple[int, int]] = []
        mask = 1 << bit
        for w in self.writes:
            if w.port != port:
                continue
            new = 1 if w.value & mask else 0
            if new != level:
                edges.append((w.cycle, new))
                level = new
        return edges

    def pulses(self, port: int, bit: int) -> list[tuple[int, int]]:
        """(rise cycle, width in cycles) of each complete high pulse.

        A pulse starts at a rising edge and ends at the next falling edge;
        the high level from reset to the first falling edge is not a pulse
        (see `first_low`), nor is a final high level that has not ended by
        the end of the trace.
        """
        result: list[tuple[int, int]] = []
        rise: int | None = None
        for cycle, level in self.pin_edges(port, bit):
            if level == 1:
                rise = cycle
            elif rise is not None:
                result.append((rise, cycle - rise))
                rise = None
        return result

    def first_low(self, port: int, bit: int) -> int | None:
        """Cycle at which pin ``Pport.bit`` first goes low, or None."""
        for cycle, level in self.pin_edges(port, bit):
            if level == 0:
                return cycle
        return None

    def level_at(self, port: int, bit: int, cycle: int) -> int:
        """Pin level during machine cycle `cycle` (after all writes with
        ``write.cycle <= cycle``)."""
        _check_pin(port, bit)
        level = 1
        for c, lv in self.pin_edges(port, bit):
            if c > cycle:
                break
            level = lv
        return level


def _check_pin(port: int, bit: int) -> None:
    if port not in PORT_SFR:
        raise ValueError(f"port must be 0..3, got {port!r}")
    if not 0 <= bit <= 7:
        raise ValueError(f"bit must be 0..7, got {bit!r}")


def port_watch(ports: Iterable[int], mark: int) -> list[str]:
    """ucsim commands that print `mark + port`, the cycle and the port's latch at every write of a
    servo port (a byte write or a bit's), then run on."""
    lines = []
    for port in ports:
        sfr = PORT_SFR[port]
        report = f"commands expr {mark + port} /u sim_ticks /u sfr[{sfr}];run"
        lines += [f"break sfr w {sfr}", report]
        for bit in range(8):
            lines += [f"break bits w {sfr + bit}", report]
    return lines


def _script(hex_name: str, limit_name: str, ports: Iterable[int],
            actions: tuple[tuple[int, str], ...] = (), uart: bool = False,
            probes: tuple[tuple[int, int, tuple[int, ...]], ...] = ()) -> str:
    lines = [f'file "{hex_name}"']
    for address, tag, ram in probes:
        reads = "".join(f" /u iram[{a:#04x}]" for a in ram)
        lines += [f"break {address:#06x}", f"commands expr {_MARK_PROBE} /u {tag} /u {len(ram)} /u sim_ticks{reads};run"]
    lines += port_watch(ports, _MARK_BASE)
    if uart:
        lines += [f"break sfr w {SBUF:#04x}", f"commands expr {_MARK_TX} /u sim_ticks;run"]
    lines += [
        f'set hardware vcd[0] input "{limit_name}"',
        "set hardware vcd[0] break",
        "set hardware vcd[0] start",
    ]
    # Each input change is an event of the VCD unit: the run stops there, the pins change (or the
    # UART starts or stops taking bytes from its input file), it goes on.
    for _, command in actions:
        lines += ["run", f"expr {_MARK_INPUT} /u sim_ticks", command]
    lines += [
        "run",
        f"expr {_MARK_END} /u sim_ticks",
        "state",
        "kill",
    ]
    return "\n".join(lines) + "\n"


def _limit_vcd(cycles: int, xtal_hz: int = XTAL_HZ, stops: tuple[int, ...] = ()) -> str:
    # One event half a machine cycle before the limit, in ps (12 MHz:
    # 1 cycle = 1000000 ps), so the stop is the first instruction boundary at
    # or after `cycles` whatever the floating-point rounding; one more event at
    # each of `stops` (cycles, increasing), on another variable, for the inputs.
    cycle_ps = CLOCKS_PER_CYCLE * 10**12 / xtal_hz
    text = (
        "$timescale 1ps $end\n"
        "$scope module servoc_limit $end\n"
        "$var wire 8 ! variables[0xf0] $end\n"
        "$var wire 8 \" variables[0xf1] $end\n"
        "$upscope $end\n"
        "$enddefinitions $end\n"
    )
    for k, at in enumerate(stops):
        text += f"#{round((at - 0.5) * cycle_ps)}\nb{(k + 1) % 256:08b} \"\n"
    text += f"#{round((cycles - 0.5) * cycle_ps)}\nb00000001 !\n"
    # If ucsim ran past a stop, the script's remaining runs end on these instead of running on.
    for k in range(len(stops)):
        text += f"#{round((cycles + 20 + 8 * k) * cycle_ps)}\nb{(len(stops) + k + 1) % 256:08b} \"\n"
    return text


def run(
    hex_text: str,
    cycles: int,
    *,
    timeout: float = 120,
    ports: Iterable[int] = (0, 1, 2, 3),
    xtal_hz: int = XTAL_HZ,
    inputs: Iterable[tuple[int, int, int]] = (),
    uart: Iterable[tuple[int, bool]] | None = None,
    rx: bytes = b"",
    probes: Iterable[tuple[int, int, tuple[int, ...]]] = (),
) -> SimTrace:
    """Simulate `hex_text` from reset for at least `cycles` machine cycles.

    Returns every write to the selected ports.  Raises `SimError` when s51
    fails, does not finish within `timeout` seconds (wall clock; the process
    is killed and reaped), or stops before the limit (ucsim stops on a stack
    overflow), and
    `toolchain.ToolNotFound` when s51 is missing.

    `inputs`: (cycle, port, level) changes of the outside levels of a port's pins (what the
    firmware reads), at increasing cycles below `cycles`.

    `uart`: None for firmware without the serial line; else the UART is connected to files:
    it receives the bytes of `rx` in order, taking them from its file only between an (cycle,
    True) and the next (cycle, False) of `uart` (ucsim's "check input at every cycle" flag):
    one byte starts at the first, and one more each byte time until the second. Every byte
    the UART sends is in `SimTrace.sent`. All changes come at least 8 cycles apart.

    `probes`: (code address, tag, internal RAM addresses): each time the firmware is about to run
    the instruction at an address, a `Probe` with its tag, the cycle and those RAM bytes is added
    to `SimTrace.probes`.
    """
    if not isinstance(cycles, int) or isinstance(cycles, bool) or cycles < 1:
        raise ValueError(f"cycles must be a positive int, got {cycles!r}")
    port_list = sorted(set(ports))
    for p in port_list:
        if p not in PORT_SFR:
            raise ValueError(f"port must be 0..3, got {p!r}")
    n_bytes = rom_used(hex_text)
    s51 = find_tool("s51")

    with tempfile.TemporaryDirectory(prefix="servoc-sim-") as tmp:
        tmpdir = Path(tmp)
        (tmpdir / "fw.ihx").write_text(hex_text, encoding="ascii")
        changes = tuple(sorted([(at, f"set hardware port[{port}] {level:#04x}") for at, port, level in inputs]
                               + [(at, f"expr uart_0_cfg[1]={int(on)}") for at, on in (uart or ())]))
        if any(not 0 < at < cycles for at, _ in changes) or any(
                b[0] - a[0] < 8 for a, b in zip(changes, changes[1:])):
            raise ValueError("input changes must come at least 8 cycles apart, inside the run")
        (tmpdir / "limit.vcd").write_text(_limit_vcd(cycles, xtal_hz, tuple(at for at, _ in changes)),
                                          encoding="ascii")
        (tmpdir / "run.cmd").write_text(_script("fw.ihx", "limit.vcd", port_list, changes, uart is not None,
                                                tuple(probes)),
                                        encoding="ascii")
        argv = [s51, "-b", "-t", CPU_TYPE, "-X", str(xtal_hz), "-C", "run.cmd"]
        if uart is not None:
            (tmpdir / "rx.bin").write_bytes(rx)
            (tmpdir / "tx.bin").write_bytes(b"")
            argv[1:1] = ["-S", "in=rx.bin,out=tx.bin"]
        try:
            proc = subprocess.Popen(
                argv,
                cwd=tmp,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                start_new_session=True,
                preexec_fn=die_with_parent,
            )
        except OSError as exc:
            raise SimError(f"cannot start {s51}: {exc.strerror}") from None
        try:
            out_b, err_b = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            out_b, err_b = proc.communicate()
            raise SimError(
                f"s51 did not finish within {timeout:g} s (simulating {cycles} cycles)",
                _tail(out_b.decode("utf-8", "replace") + err_b.decode("utf-8", "replace")),
            ) from None
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        tx = (tmpdir / "tx.bin").read_bytes() if uart is not None else b""
    out = out_b.decode("utf-8", "replace")
    err = err_b.decode("utf-8", "replace")
    trace = _parse(out, err, proc.returncode, cycles, n_bytes)
    lines = out.splitlines()
    stopped = [int(lines[i + 1]) for i, ln in enumerate(lines) if ln == str(_MARK_INPUT) and i + 1 < len(lines)]
    for (at, _), ticks in zip(changes, stopped):
        if not at <= _to_cycles_floor(ticks) <= at + 8:
            raise MissedInput(f"the input change for cycle {at} came at cycle {_to_cycles_floor(ticks)}")
    if len(stopped) != len(changes):
        raise MissedInput(f"{len(stopped)} of {len(changes)} input changes made")
    if uart is not None:
        ticks = [int(lines[i + 1]) for i, ln in enumerate(lines) if ln == str(_MARK_TX) and i + 1 < len(lines)]
        # the UART writes the byte out as its stop bit ends: the last write may still be on the line
        trace = replace(trace, sent=tuple(zip((_to_cycles(t) for t in ticks), tx)))
    return trace


def _to_cycles_floor(ticks: int) -> int:
    return ticks // CLOCKS_PER_CYCLE


def _tail(text: str, n: int = 40) -> str:
    return "\n".join(text.splitlines()[-n:])


def _parse(out: str, err: str, returncode: int, cycles: int, n_bytes: int) -> SimTrace:
    everything = out + err
    loaded = f"{n_bytes} words read from fw.ihx"
    if loaded not in everything:
        raise SimError(f"s51 did not load the HEX image (expected '{loaded}')", _tail(everything))

    markers = {str(_MARK_BASE + p): p for p in PORT_SFR}
    end_marker = str(_MARK_END)
    probe_marker = str(_MARK_PROBE)
    writes: list[PortWrite] = []
    probes: list[Probe] = []
    lines = out.splitlines()
    n = len(lines)
    wrap = 0
    last_raw = 0
    final_ticks: int | None = None
    i = 0
    try:
        while i < n:
            s = lines[i]
            port = markers.get(s)
            if port is not None:
                raw = int(lines[i + 1])
                value = int(lines[i + 2])
                if raw < last_raw:
                    wrap += TICKS_WRAP
                last_raw = raw
                writes.append(PortWrite(_to_cycles(raw + wrap), port, value & 0xFF))
                i += 3
                continue
            if s == probe_marker:
                tag, count, raw = int(lines[i + 1]), int(lines[i + 2]), int(lines[i + 3])
                if raw < last_raw:
                    wrap += TICKS_WRAP
                last_raw = raw
                ram = tuple(int(lines[i + 4 + k]) & 0xFF for k in range(count))
                probes.append(Probe(tag, _to_cycles(raw + wrap), ram))
                i += 4 + count
                continue
            if s == end_marker:
                raw = int(lines[i + 1])
                if raw < last_raw:
                    wrap += TICKS_WRAP
                final_ticks = raw + wrap
                # `state` prints the 64-bit clock count; prefer it.
                for ln in lines[i + 2 :]:
                    m = _STATE_CLKS_RE.match(ln)
                    if m:
                        final_ticks = int(m[1])
                        break
                break
            i += 1
    except (IndexError, ValueError) as exc:
        raise SimError(f"unexpected s51 output near line {i + 1}: {exc}", _tail(everything)) from None

    if final_ticks is None:
        raise SimError(f"s51 ended without finishing the run (exit status {returncode})", _tail(everything))
    total = _to_cycles(final_ticks)
    if total < cycles:
        reason = _stop_reason(lines, markers, end_marker)
        raise SimError(f"simulation stopped at cycle {total} before the limit {cycles}: {reason}", _tail(everything))
    return SimTrace(writes=tuple(writes), cycles=total, probes=tuple(probes))


_NOISE_PREFIXES = ("Simulation started", "Loading from", "Simulated ", "Host usage", "run", "expr ")


def _stop_reason(lines: list[str], markers: dict[str, int], end_marker: str) -> str:
    """The simulator's own messages printed during the run (e.g. "Stack
    overflow, PC=0x3", "Stop at 0x000003: ..."), joined on one line."""
    try:
        start = lines.index("run")
    except ValueError:
        start = 0
    found: list[str] = []
    skip = 0
    for ln in lines[start + 1 :]:
        if skip:
            skip -= 1
            continue
        if ln in markers:
            skip = 2
            continue
        if ln == end_marker:
            break
        text = ln.strip()
        if not text or text.startswith(_NOISE_PREFIXES) or text.endswith("words read from fw.ihx"):
            continue
        found.append(" ".join(text.split()))
    return "; ".join(found[:8]) if found else "no message from s51"


def die_with_parent() -> None:
    """In the child before exec: ucsim gets SIGKILL when servoc dies, even by SIGTERM or SIGKILL."""
    try:
        import ctypes
        import signal
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)      # PR_SET_PDEATHSIG
    except Exception:
        pass


def _to_cycles(ticks: int) -> int:
    q, r = divmod(ticks, CLOCKS_PER_CYCLE)
    if r:
        raise SimError(f"tick count {ticks} is not a whole number of machine cycles")
    return q

