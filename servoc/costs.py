"""The frame engine's timing and its budget, in machine cycles: Plan -> shortest period.

Every edge comes from the Timer0 handler (firmware_templates/irq.asm.j2).
Timer0 overflows a fixed ENTRY cycles before the first edge of a cluster; the
handler reads TL0, which counts the cycles since the overflow and so includes
the entry latency, and pads itself to that fixed point through a cascade of
`JB ACC.k` over 2^k NOPs (WINDOW_BITS bits). Edges closer than SPLIT cycles
run in one entry as steps into the port's NOP sled (STEP cycles + the sled),
each an `XRL Px,A` with the lines that change. Between entries the exit
stops Timer0 for STOP cycles and adds (65536 - interval + STOP), so the next
overflow comes exactly `interval` cycles after the last one, whatever the
handler took: widths and the period are counter arithmetic.

Port k rises at k x port_span(target); its lines fall C(N) cycles later. At
the rise the handler writes that port's items from the distinct N the
background sorted (frame_irq.asm.j2): one sorted buffer, filled for each port
between the previous port's rise and its own.

The budget: the background's work between two frames (W, read from the
generated code by `servoc.wcet`), each port's sort (read the same way) and
the handler's worst load per port (its rise entry, read from the code, plus
SPLIT for each line) must fit the frame, and so must the pulses themselves:

    P >= ports x port_span
    P >= sum(sorts) + W + sum(handler loads)
    P >= R(m-2) + sort(m-1) + W + sort(0) + load(m-2) + load(m-1)   (m >= 2 ports)
    P >= R(m-1) + sort(0) + load(m-1)

(the last two: W runs after the last port's sort, and each port's sort must
be there before its rise). `tests/test_costs.py` runs adversarial programs in
ucsim at their own minimum.
"""

from __future__ import annotations

from dataclasses import dataclass

from .units import DEFAULT_PERIOD_FLOOR_US

WINDOW_BITS = 5     # the entry pads over 2^5 TL0 readings (interrupts held off 22 cycles: exact, tests/test_irq.py)
STOP = 7            # cycles Timer0 stands still while an exit adds to it
STEP = 7            # the shortest step between two edges of one entry
# Overflow to the first edge of an entry: the vector (PUSH PSW, PUSH ACC, LJMP: 6),
# MOV A,TL0 (1), the cascade (2 a bit, and 31 - v NOPs for v = TL0 read), MOV PSW (2),
# PUSH DPL/DPH (4), MOV DPL/DPH (4), MOV A,R6 (1), JMP (2), and the edge's 3; with
# v = latency + 7 this is 57 whatever the latency (`tests/test_costs.py` reads TL0 at each
# such edge in ucsim).
ENTRY = 57
# The last edge of an entry to the end of its RETI on the longest exit: the step's
# read and jump (4), LJMP (2), exit_far (28), MOV R6 (1), the add to SETB (8), POPs (8),
# RETI (2); `tests/test_costs.py` reads it from the code.
EXIT = 53
SPLIT = ENTRY + EXIT + 1   # edges this far apart or more: separate entries (the next
                           # overflow comes after the RETI before it)
SLED = SPLIT - 1 - STEP    # NOPs before each port's edge: any gap from STEP to SPLIT - 1


def port_span(target) -> int:
    """A port's rise to the next port's: its longest pulse, then an entry of its own."""
    return target.width_cycles(250) + SPLIT


def rise_offsets(ports: tuple[int, ...], target) -> dict[int, int]:
    """Cycles from the first port's rise to each port's rise."""
    return {port: k * port_span(target) for k, port in enumerate(ports)}


def handler_load(rise_cycles: int, lines: int) -> int:
    """The handler's worst cycles in one frame for a port: its rise entry, then at most SPLIT
    per line (an entry of its own, or a step shorter than SPLIT)."""
    return rise_cycles + SPLIT * lines


@dataclass(frozen=True)
class Budget:
    """What the generated code takes, per frame: read from its text by `servoc.wcet`."""
    work: int                   # the longest work between two frames
    sorts: tuple[int, ...]      # each port's sort in frame_io, in port order
    rises: tuple[int, ...]      # each port's rise entry of the handler, overflow to RETI
    lines: tuple[int, ...]      # servo lines on each port


def frame_cycles(target, budget: Budget) -> int:
    """The shortest frame period in machine cycles this code holds."""
    m = len(budget.lines)
    if m == 0:
        return budget.work
    span = port_span(target)
    load = [handler_load(r, s) for r, s in zip(budget.rises, budget.lines)]
    need = [m * span, sum(budget.sorts) + budget.work + sum(load),
            (m - 1) * span + budget.sorts[0] + load[-1]]
    if m >= 2:
        need.append((m - 2) * span + budget.sorts[-1] + budget.work + budget.sorts[0] + load[-2] + load[-1])
    for j in range(1, m):       # each later port's sort fits between the rise before and its own
        if budget.sorts[j] + load[j - 1] > span:
            raise AssertionError(f"port {j}: its sort does not fit between two rises")
    return max(need)


def default_period_us(min_period: int) -> int:
    """The spec's default P: the shortest sustainable period, never below 5.3 ms."""
    return max(DEFAULT_PERIOD_FLOOR_US, min_period)


# The stack: 46 bytes from the end of the direct variables (0x72, with 24 servos
# on three ports) up to the motion state at 0xA0. Each `repeat` keeps its
# pass counter there and each `play` its return address (2 bytes a level);
# the runtime goes at most RUNTIME_STACK bytes deeper below a program call, and
# the edge handler, which may come at any instruction, HANDLER_STACK more.
STACK_BYTES = 46
RUNTIME_STACK = 8
HANDLER_STACK = 8           # LCALL, PSW, ACC, DPL, DPH, and its own LCALL
ENGINE_STACK = RUNTIME_STACK + HANDLER_STACK


def stack_bytes(nesting: int) -> int:
    """Stack bytes a program with `nesting` levels of repeat/play needs."""
    return 2 * nesting + ENGINE_STACK


def max_nesting() -> int:
    return (STACK_BYTES - ENGINE_STACK) // 2
