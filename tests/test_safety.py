"""Firmware safety over long runs: random valid programs simulated in ucsim for thousands of frames.

For every program (built and simulated through servoc.api), straight from the port trace:
- every pulse is 500..2500 us wide, and every rise is followed by its fall within 2.5 ms, so
  every servo line is low at the end of every frame;
- no frame is missed: a servo with a target pulses in every frame from its first one on, its
  rises exactly P apart;
- servo lines go low right after reset, and a servo that never gets a target never pulses;
- `api.check_trace` agrees with the plan (every width, and pins that are not servos never change);
- the stack stays within its budget: `AsmUnit.stack_bytes` <= 32, and a second ucsim run with a
  write breakpoint on every byte of the stack area (0xE0..0xFF) records the highest byte the
  firmware writes there, which must lie inside the `stack_bytes` the code generator reserved.
"""

from __future__ import annotations

import itertools
import re
import subprocess
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings

from servoc import api, costs, layout, sim, toolchain
from servoc.plan import expand
from servoc.units import BASE_US, DIV_US, N_MAX
from servoc.verify import first_pulse_frame

from conftest import build_text
from test_firmware import deepest_that_fits, nested_source, program_text, programs
from test_fuzz import valid_programs

pytestmark = pytest.mark.toolchain

SAFE = dict(deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])

FRAMES = 2000                   # frames from the first pulse, each program
MIN_WIDTH, MAX_WIDTH = BASE_US, BASE_US + DIV_US * N_MAX     # 500 .. 2500 us
RESET_LOW = 20
STACK_TOP = layout.STATE_BASE   # the stack lives from where the RAM the program uses ends up to STATE_BASE - 1


def stack_bottom(unit) -> int:
    """Where the firmware's stack starts: its STACK (the end of the RAM it allocates)."""
    return int(re.search(r"^STACK\s+=\s+0x([0-9A-F]+)", unit.text, re.M)[1], 16)


# ============================================================ the stack, watched in ucsim

_MARK = 2718200                 # printed with the address of a stack byte on its first write
_END = 2718199                  # printed with the tick count when the run reaches its limit


def _limit_vcd(cycles: int) -> str:
    """A VCD input with one event half a cycle before `cycles` (1 cycle = 1000 ns at 12 MHz) on a
    ucsim variable with `break` set: the run stops at the first instruction boundary after it."""
    return ("$timescale 1ns $end\n$scope module limit $end\n$var wire 8 ! variables[0xf0] $end\n"
            f"$upscope $end\n$enddefinitions $end\n#{cycles * 1000 - 500}\nb00000001 !\n")


def stack_bytes_written(hex_text: str, cycles: int, bottom: int) -> set[int]:
    """The IRAM addresses of the stack the firmware writes during `cycles` machine cycles.

    One write breakpoint per address (`break iram w ADDR`); each prints its address and deletes
    itself on its first hit (breakpoints are numbered 1, 2, ... in the order they are set), so
    the run costs about as much as one without breakpoints. PUSH, LCALL and interrupts write the
    stack through IRAM, so they are all seen."""
    lines = ['file "fw.ihx"']
    for number, addr in enumerate(range(bottom, STACK_TOP), start=1):
        lines += [f"break iram w {addr:#04x}", f"commands expr {_MARK + addr};delete {number};run"]
    lines += ['set hardware vcd[0] input "limit.vcd"', "set hardware vcd[0] break", "set hardware vcd[0] start",
              "run", f"expr {_END} /u sim_ticks", "info breakpoints", "kill"]
    with tempfile.TemporaryDirectory(prefix="servoc-stack-") as tmp:
        folder = Path(tmp)
        (folder / "fw.ihx").write_text(hex_text, encoding="ascii")
        (folder / "limit.vcd").write_text(_limit_vcd(cycles), encoding="ascii")
        (folder / "run.cmd").write_text("\n".join(lines) + "\n", encoding="ascii")
        proc = subprocess.run([toolchain.find_tool("s51"), "-b", "-t", sim.CPU_TYPE, "-X", "12M", "-C", "run.cmd"],
                              cwd=tmp, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=300)
    out = proc.stdout.splitlines()
    assert str(_END) in out, f"s51 did not reach the end of the run:\n" + "\n".join(out[-20:])
    end = out.index(str(_END))
    ticks = int(out[end + 1])
    assert ticks >= cycles * sim.CLOCKS_PER_CYCLE, f"the run stopped early at {ticks} ticks:\n" + "\n".join(out[-20:])
    written = {int(line) - _MARK for line in out[:end]
               if line.isdigit() and _MARK + bottom <= int(line) < _MARK + STACK_TOP}
    # The breakpoints left are exactly those of the bytes never written (the numbering was right).
    left = {int(m, 16) for m in _breakpoint_addresses(out[end:])}
    assert left == set(range(bottom, STACK_TOP)) - written, (sorted(left), sorted(written))
    return written


def _breakpoint_addresses(lines: list[str]) -> list[str]:
    """Addresses of the event breakpoints listed by `info breakpoints`."""
    found = []
    for line in lines:
        parts = line.split()
        if len(parts) >= 6 and parts[0].isdigit() and parts[1] == "event" and parts[-1] == "write":
            found.append(parts[5])
    return found


# ============================================================ the checks

def check_long_run(text: str, frames: int = FRAMES, stack_reached: bool = False) -> None:
    built = build_text(text)
    plan, firmware = built.plan, built.firmware
    cycles = api.cycles_needed(plan, frames)
    trace = api.simulate(firmware.hex_text, cycles)
    report = api.check_trace(plan, trace, frames)
    detail = "\n".join(str(m) for m in report.mismatches[:10])
    assert report.ok, f"{report.summary()}\n{detail}\n--- source:\n{text}"
    check_pulses(plan, firmware.unit, trace, frames, text)
    check_stack(plan, firmware, cycles, text, stack_reached)


def check_pulses(plan, unit, trace, frames: int, text: str) -> None:
    """Widths, lines low at the end of every frame, and a pulse in every frame from a servo's first target on."""
    period = plan.period_us
    lead = first_pulse_frame(plan)
    firsts = {}                 # channel -> frame (0 = frame 1) of its first target, if the trace can show it
    if lead is not None:
        # The trace covers `frames` frames from the first pulse, two more and a little: look that far ahead.
        golden = list(itertools.islice(expand(plan), lead, lead + frames + 3))
        for c in plan.channels:
            firsts[c.index] = next((j for j, fr in enumerate(golden) if fr.n[c.index] is not None), None)
    offsets = dict(zip(plan.ports, unit.rise_offsets))
    starts = [ps[0][0] - offsets[c.port] for c in plan.channels if (ps := trace.pulses(c.port, c.bit))]
    t1 = min(starts) if starts else None        # the first port's rise in frame 1
    assert (t1 is None) == (lead is None), f"first pulse: plan {lead}, firmware {t1}"
    for servo in plan.program.servos:
        pin = f"P{servo.port}.{servo.bit} ({servo.name})"
        edges = trace.pin_edges(servo.port, servo.bit)
        assert edges and edges[0][1] == 0 and edges[0][0] <= RESET_LOW, f"{pin}: not low {RESET_LOW} us after reset"
        channel = plan.channel_of(servo.name) if any(c.servo.name == servo.name for c in plan.channels) else None
        first = None if channel is None else firsts.get(channel.index)
        if first is None:
            assert len(edges) == 1, f"{pin} never has a target but changed {len(edges)} times"
            continue
        # Every rise is followed by its fall within 2.5 ms: the line is low at the end of the frame.
        for (rise, level), nxt in itertools.zip_longest(edges[1::2], edges[2::2]):
            assert level == 1
            if nxt is None:
                assert trace.cycles - rise <= MAX_WIDTH, f"{pin}: high from {rise} to the end of the run"
            else:
                assert MIN_WIDTH <= nxt[0] - rise <= MAX_WIDTH, f"{pin}: a {nxt[0] - rise} us pulse at {rise}"
        # From its first target on, one rise in every frame, exactly P apart, none before.
        rises = [r for r, _ in trace.pulses(servo.port, servo.bit)]
        expected = [t1 + offsets[servo.port] + j * period for j in range(first, frames)]
        assert rises[:len(expected)] == expected, (
            f"{pin}: rises not exactly P = {period} us apart from frame {first + 1}: "
            f"{_first_difference(rises, expected)}\n--- source:\n{text}")
        assert not rises or rises[0] == t1 + offsets[servo.port] + first * period, f"{pin}: a pulse before its target"
        assert all(b - a == period for a, b in zip(rises, rises[1:])), f"{pin}: a rise off its slot after frame {frames}"


def check_stack(plan, firmware, cycles: int, text: str, reached: bool) -> None:
    """Statically within the 32 bytes, and in ucsim never a byte past what was reserved
    (with `reached`: the run uses every byte the program and the runtime reserve, so the static
    bound is tight up to the edge handler's share, which only an interrupt at the deepest point uses)."""
    unit = firmware.unit
    assert unit.stack_bytes == costs.stack_bytes(plan.nesting) <= costs.STACK_BYTES
    bottom = stack_bottom(unit)
    written = stack_bytes_written(firmware.hex_text, cycles, bottom)
    if unit.budget is not None and unit.budget.last_in_b:   # sort buffer B and its rise mask: not stack
        assert written >= set(range(layout.BUFB_BASE - 1, layout.BUFB_BASE + 3)), "buffer B unused"
        written = {a for a in written if a < STACK_TOP - costs.BUFB_RAM}
    assert {bottom, bottom + 1} <= written, "no call seen on the stack: the watch does not work"
    deepest = max(written) - bottom + 1
    assert deepest <= unit.stack_bytes, (
        f"the firmware used {deepest} bytes of stack, {unit.stack_bytes} were reserved\n--- source:\n{text}")
    if reached:
        assert deepest >= unit.stack_bytes - costs.HANDLER_STACK, (
            f"{unit.stack_bytes} bytes of stack reserved, {deepest} used")


def _first_difference(got: list[int], want: list[int]) -> str:
    for k, (g, w) in enumerate(zip(got, want)):
        if g != w:
            return f"rise {k}: at {g}, expected {w}"
    return f"{len(got)} rises, {len(want)} expected"


# ============================================================ the programs

@settings(max_examples=2, **SAFE)
@given(valid_programs(min_servos=3))
def test_long_runs_of_programs_with_every_construct(text):
    """Groups, `with` poses, limits, trims, reversed servos, eased moves, sequences, loops."""
    check_long_run(text)


@settings(max_examples=2, **SAFE)
@given(programs().filter(lambda prog: len(prog.servos) >= 3))
def test_long_runs_at_the_shortest_frame_period(prog):
    """Moves whose F is found at run time, nested repeats and plays, at (or near) the minimum P."""
    check_long_run(program_text(prog))


@pytest.mark.parametrize("with_repeats", [False, True])
def test_deepest_nesting_stays_within_its_stack(with_repeats):
    """Nested as deep as the 32-byte stack allows: the run touches the reserved stack and not one byte more."""
    text = nested_source(deepest_that_fits(with_repeats), with_repeats)
    check_long_run(text, frames=600, stack_reached=True)
