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

from dataclasses import dataclass
from functools import lru_cache

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


def rise_offsets(ports: tuple[int, ...], target=None, sizes: tuple[int, ...] | None = None) -> dict[int, int]:
    """Cycles from the first port's rise to each port's rise: the port routines follow each other.
    `sizes`: the lines on each port (the cycles engine's ports differ in length by it)."""
    lengths = port_lengths(target, sizes or (8,) * len(ports))
    out, t = {}, 0
    for port, (lead, tail) in zip(ports, lengths):
        out[port] = t + lead - lengths[0][0]
        t += lead + tail
    return out


def port_lengths(target, sizes: tuple[int, ...]) -> list[tuple[int, int]]:
    """(cycles from the port routine's start to its rise, cycles from the rise to the next port) per port."""
    if target is None or target.grid:
        return [(PRE_RISE_CYCLES, PORT_CYCLES - PRE_RISE_CYCLES)] * len(sizes)
    engine = cycles_engine(target)
    return [(engine.lead(s), engine.tail) for s in sizes]


def frame_cycles(port_count: int, work_cycles: int, target=None, sizes: tuple[int, ...] | None = None) -> int:
    """The shortest frame period in machine cycles for the ports in use and the longest work between frames."""
    lengths = port_lengths(target, sizes or (8,) * port_count)
    return FRAME_IO_FIXED + sum(a + b for a, b in lengths) + work_cycles


# ----------------------------------------------------------------- the cycles engine
# At a clock where a DIV is not 8 whole machine cycles, each line falls at
# C(N) = round_half_up((500 + 8 N) us / t_c) cycles after the rise. The port
# routine (firmware_templates/pulse_cycles.asm.j2) sorts the port's N with
# their masks, looks C up in a table and writes one block per distinct N:
# (mask, [S], P, LO, HI). A block waits exactly its gap g to the edge before:
#   "inline" blocks (a DIV of 8 cycles or more): g = 8 + u;
#   "short" blocks (a DIV of 6 or 7 cycles): lines one DIV apart take a short
#   path of DIV cycles (S = 1), the others a long one of g = 12 + u;
# with u = 2 w + odd, P = 2 - odd, LO = (w mod 256) + 1, HI = (w div 256) + 1
# (DJNZ loops of 2 cycles; each further HI is 512 cycles). The prep work runs
# partly before the rise and partly in the rise's first 500 us, split so
# that the chain is entered exactly on time.

CE_CYCLES = 13               # one compare-exchange of the sorting network, either way
SORT_SIZES = (0, 0, 1, 3, 5, 9, 12, 16, 19)   # compare-exchanges of the network for 0..8 lines


@dataclass(frozen=True)
class CyclesEngine:
    div_floor: int           # whole machine cycles in a DIV (floor)
    short: bool              # blocks have the short path (a DIV of 6 or 7 cycles)
    flip: bool               # the short path counts its odd cycle the other way (DIV odd)
    long_base: int           # LB: the shortest gap of a long (or inline) block
    th: int                  # the time of the virtual edge before the first block (cycles after the rise)
    tclose: int              # the closing block's edge: the port routine ends 3 cycles later
    table: tuple[int, ...]   # C(N) for N = 0..250

    @property
    def close_base(self) -> int:
        """The closing block's u is close_base - C(largest N)."""
        return self.tclose - self.long_base

    @property
    def first_base(self) -> int:
        """The first block's u is C(smallest N) - first_base."""
        return self.th + self.long_base

    @property
    def block_bytes(self) -> int:
        """Code bytes of one chain block (the entry jump skips a block per merged line)."""
        return 11 + self.short_pad if self.short else 14

    @property
    def short_pad(self) -> int:
        return self.div_floor - 6

    @property
    def slot_bytes(self) -> int:
        return 5 if self.short else 4

    @property
    def store(self) -> int:
        return 22 + (3 if self.short else 0) + (2 if self.flip else 0)

    @property
    def line(self) -> int:
        """One sorted line after the first, emit or merge path."""
        return 33 + (7 if self.short else 0) + self.store

    @property
    def close(self) -> int:
        return 16 + (2 if self.short else 0) + 2 + self.store

    @property
    def first(self) -> int:
        return 9 + (2 if self.short else 0) + 2 + self.store

    def units(self, s: int) -> list[int]:
        """The prep work of a port with s lines, unit by unit: the sort, the table pointer, the
        closing block, lines s-1..1, the first line. Any unit boundary may carry the rise."""
        return [CE_CYCLES] * SORT_SIZES[s] + [2, self.close] + [self.line] * (s - 1) + [self.first]

    def split(self, s: int) -> int:
        """How many prep units run before the rise: as few as let the rest fit the head."""
        units = self.units(s)
        for k in range(len(units) + 1):
            if self.post_cycles(s, k) + POST_FIXED <= self.th + 1:
                return k
        raise AssertionError("the head cannot be shorter than its fixed part")

    def post_cycles(self, s: int, k: int) -> int:
        return sum(self.units(s)[k:]) + 2          # with the RET

    def pre_cycles(self, s: int, k: int) -> int:
        return sum(self.units(s)[:k]) + 2

    def head_pad(self, s: int) -> int:
        return self.th + 1 - POST_FIXED - self.post_cycles(s, self.split(s))

    def lead(self, s: int) -> int:
        """Port start to the rise: copy N and masks (4 s), R0/R1/R6 (3), LCALL pre (2 + ...), MOV A,ACT (1)."""
        return 4 * s + 3 + 2 + self.pre_cycles(s, self.split(s)) + 1

    @property
    def tail(self) -> int:
        """The rise to the next port: the closing edge, its ANL and the SJMP over the long paths."""
        return self.tclose + 1 + 2


# From the rise to the first block: ORL (1), LCALL post (2), MOV A,R1 (1), MOV DPTR (2), JMP @A+DPTR (2);
# the first block starts 1 cycle after the virtual edge at th.
POST_FIXED = 1 + 2 + 1 + 2 + 2


@lru_cache(maxsize=None)
def cycles_engine(target) -> CyclesEngine:
    fl = int(target.div_cycles)
    short = fl < 8
    flip = short and fl % 2 == 1
    lb = 12 if short else 8
    table = tuple(target.width_cycles(n) for n in range(N_MAX + 1))
    return CyclesEngine(fl, short, flip, lb, table[0] - lb, table[-1] + lb, table)


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
