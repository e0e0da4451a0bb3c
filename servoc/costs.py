"""The firmware's own cost per frame, in machine cycles (1 us at 12 MHz).

This is the one place the front end learns what the generated firmware
needs: the shortest frame period it sustains. A frame is the pulse routines
of the ports in use (fixed length each, sort and differencing included) plus
the work between the last port's pulses and the next tick: stepping every
moving servo, and on the first frame of a move reading its record. The
constants below are upper bounds of what `benchmarks/stress.py` measures in
ucsim; `tests/test_costs.py` fails when they stop being safe or get wasteful.
"""

from __future__ import annotations

from .units import BASE_US, DEFAULT_PERIOD_FLOOR_US, DIV_US, N_MAX

# The port routine (firmware_templates/pulse.asm.j2) has a fixed length:
HEAD_CYCLES = BASE_US - DIV_US + 1   # rise to the first edge block: 493, so N = 0 falls at 500
PRE_RISE_CYCLES = 1                  # MOV A,ACT before the ORL that raises the lines
FINAL_N = N_MAX + 1                  # the edge chain closes with a silent block at N = 251
PORT_CYCLES = PRE_RISE_CYCLES + HEAD_CYCLES - 1 + DIV_US * (FINAL_N + 1) + 1

# Measured by `benchmarks/stress.py` (shortest P that verifies exactly, worst-case
# programs): about 121 fixed, 26 per nesting level, 101 per servo (a DDA carry
# on the first frame adds a few), 43 more per servo for a run-time F.
# Between two frames: tick sync, frame_io's return, the move's bookkeeping.
FRAME_FIXED_CYCLES = 130
# Per level of `repeat` or `play` that ends and starts again between two frames.
LEVEL_CYCLES = 28
# Per servo with pulses, on a move's first frame: record, DDA terms and first step.
CHANNEL_CYCLES = 108
# Per servo, when some move's F is found at run time (frames-needed lookup).
RUNTIME_F_CYCLES = 45


def min_period_us(port_count: int, channel_count: int, runtime_frames: bool = False, nesting: int = 0) -> int:
    """The shortest frame period the firmware sustains."""
    per_channel = CHANNEL_CYCLES + (RUNTIME_F_CYCLES if runtime_frames else 0)
    return (PORT_CYCLES * port_count + FRAME_FIXED_CYCLES + LEVEL_CYCLES * nesting
            + per_channel * channel_count)


def default_period_us(port_count: int, channel_count: int, runtime_frames: bool = False, nesting: int = 0) -> int:
    """The spec's default P: the shortest sustainable period, never below 5.3 ms."""
    return max(DEFAULT_PERIOD_FLOOR_US, min_period_us(port_count, channel_count, runtime_frames, nesting))


# The stack: 32 bytes at the top of the indirect RAM. Each `repeat` keeps its
# pass counter there and each `play` its return address (2 bytes a level);
# the runtime goes at most ENGINE_STACK bytes deeper below a program call.
STACK_BYTES = 32
ENGINE_STACK = 8


def stack_bytes(nesting: int) -> int:
    """Stack bytes a program with `nesting` levels of repeat/play needs."""
    return 2 * nesting + ENGINE_STACK


def max_nesting() -> int:
    return (STACK_BYTES - ENGINE_STACK) // 2
