"""The firmware's frame budget, in machine cycles (1 us at 12 MHz): Plan -> shortest period.

A frame is `frame_io`: the wait for the Timer2 tick, then the pulse routines
of the ports in use, each of a fixed length (sort and differencing inside its
first 0.5 ms), then RET. Between two frames the program does its work: the
longest path from any frame to the next is read from the generated assembly
itself by `servoc.wcet` (every instruction's cycles, every branch both ways,
loop bounds from the program's structure). So the shortest period is

    P_min = FRAME_IO_FIXED + PORT_CYCLES x ports + the longest work between frames

and it holds for every state the program can reach: nothing is fitted to a
benchmark. `tests/test_costs.py` runs adversarial programs in ucsim at their
own P_min.
"""

from __future__ import annotations

from .units import BASE_US, DEFAULT_PERIOD_FLOOR_US, DIV_US, N_MAX

# The port routine (firmware_templates/pulse.asm.j2) has a fixed length:
HEAD_CYCLES = BASE_US - DIV_US + 1   # rise to the first edge block: 493, so N = 0 falls at 500
PRE_RISE_CYCLES = 1                  # MOV A,ACT before the ORL that raises the lines
FINAL_N = N_MAX + 1                  # the edge chain closes with a silent block at N = 251
PORT_CYCLES = PRE_RISE_CYCLES + HEAD_CYCLES - 1 + DIV_US * (FINAL_N + 1) + 1

# frame_io around the ports (firmware_templates/runtime.asm.j2): the tick poll
# (JNB, 2: it sees the tick 0 or 1 cycle late), the sync that takes that cycle
# back (CLR, MOV, ADD, RRC, JC, NOP: 7), the RET (2), and 2 cycles of margin for
# where in its 2-cycle loop the poll stands when the tick comes (reasoned, not
# isolated in ucsim; tests/test_costs.py verifies programs at exactly P_min).
FRAME_IO_FIXED = 2 + 7 + 2 + 2


def rise_offsets(ports: tuple[int, ...]) -> dict[int, int]:
    """Cycles from the first port's rise to each port's rise: the port routines follow each other."""
    return {port: PORT_CYCLES * i for i, port in enumerate(ports)}


def frame_cycles(port_count: int, work_cycles: int) -> int:
    """The shortest frame period for `port_count` ports and the longest work between frames."""
    return FRAME_IO_FIXED + PORT_CYCLES * port_count + work_cycles


def default_period_us(min_period: int) -> int:
    """The spec's default P: the shortest sustainable period, never below 5.3 ms."""
    return max(DEFAULT_PERIOD_FLOOR_US, min_period)


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
