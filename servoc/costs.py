"""The frame engine's timing and its budget, in machine cycles: Plan -> shortest period.

Every edge comes from the Timer0 handler (firmware_templates/irq.asm.j2).
Timer0 overflows a fixed ENTRY cycles before the first edge of a cluster; the
handler reads TL0, which counts the cycles since the overflow and so includes
the entry latency, and pads itself to that fixed point by jumping into a pad of
NOPs at that reading (a latency of up to LATENCY cycles). Edges closer than SPLIT cycles
run in one entry as steps into the port's NOP sled (STEP cycles + the sled),
each an `XRL Px,A` with the lines that change. Between entries the exit
stops Timer0 for STOP cycles and adds (65536 - interval + STOP), so the next
overflow comes exactly `interval` cycles after the last one, whatever the
handler took: widths and the period are counter arithmetic.

Port k rises at the sum of the spans of the ports before it (`fit_spans`: a port's longest
pulse, for the highest N its lines reach, and an entry, or RISE_STEP in a build whose rises can be
steps; longer where the next port's sort needs it); its lines fall C(N) cycles later. At
the rise the handler writes that port's items from the distinct N the
background sorted (frame_irq.asm.j2): one sorted buffer, filled for each port
between the previous port's rise and its own.

The budget: the background's work between two frames (W, read from the
generated code by `servoc.wcet`), each port's sort (read the same way) and
the handler's worst load per port (its rise entry, read from the code, and
its falls in the worst frame the program's moves can put out: `port_load`)
must fit the frame, and so must the pulses themselves:

    P >= the sum of the spans
    P >= sum(sorts) + W + sum(handler loads)                          (`frame_load`)
    P >= R(m-2) + sort(m-1) + W + sort(0) + load(m-2) + load(m-1)   (m >= 2 ports)
    P >= R(m-1) + sort(0) + load(m-1)

(the falls in the second, from one frame's first items to the next, and those of ports m-2 and m-1
in the third come from one frame: they are charged together, for the frame whose falls of those
ports take the handler longest, `falls_together`, not each port's worst frame apart;
with one port the second is, more finely, the larger of: a frame whose work starts no
move, with the worst sort and falls of any frame; and one whose work reads a move's record, with
the sort of that move's first frame and the falls of the frame before it, for each move: frame_io
returns only once the handler has taken the port, so a frame's work, its sort and the falls of the
frame before fall in one period. The last two: W runs after the last port's sort, and each port's sort must
be there before its rise; with sort buffer B for the last of three ports the
last is R(m-1) + sort(m-1) + sort(0) + load(m-1) and the one before goes).
With a serial line, each term adds the serial handler's runs that can come in
its window: the whole frame, or from the rise it starts at to the first
port's next rise. `tests/test_costs.py` runs adversarial programs in ucsim at
their own minimum.

A build may make each port's rise come among the falls of the port before it (`stagger_span`,
irq_stagger.asm.j2): at a time STEP or more from every fall that port can have (`rise_slot`), so
that the rise is a step of its own in that port's list (a second sled in its window) or an entry
of its own; or, where a DIV is less than 2 STEP cycles (`beside`: 12 MHz, 11.0592 MHz), BESIDE
cycles after the fall of an N j, in one block of straight code with that fall and the fall of
j + 1 (irq_beside.asm.j2), a step from an edge at N j - 1. The
background writes each port's items after its sort (frame_irq.asm.j2, stagger_emit.asm.j2: the
sort's term includes it, for the most distinct N the port's lines fall at in one frame:
`PortLoad.distinct`, codegen._unread) into the one of two buffers the handler does not use; the handler takes
them after the last edge of the port before (its handover, `handovers`), a run that must end
before the rising port's earliest fall: the span is C(top) - C(bottom) and that run
(Budget.emits), `bottom` the lowest N the rising port's lines fall at (flow.port_reach).
The last port's span holds its pulses whole (C(top) + STEP), so that every period from the
shortest on holds. In the terms above, each port's rise is then its handover, and each sort
must fit between the handover before it and its port's rise; a window from a port's handover holds
its handover and falls, not its rise's edge, which comes before (`rise_edge`), and ends ENTRY
before the first port's next rise, where the handover reads the first port's header (the first
edge's N: Budget.head, the writing up to it); the rest of its items, read from its first edge on,
end ENTRY before that rise, or before that edge (`first_read`) with the rise's entry and handover
in between. The handler
never reads the sort
buffer then: frame_io sorts a port before it waits, and writes only its items (Budget.items) after
the handler took the port before's, so the last port's sort can end before its wait
(`_items_start`). With three ports the third term is the later of two chains to the first port's
items: from the middle port's handover, where the last port's sort is done by then (its items,
W, the first port's sort and items, the handler's runs of the last two ports), and from the
first port's handover, where the background is then at the middle port's sort at the latest
(chain 1 has the first port's items written before its rise) and busy on to the end (both sorts
and both lists between, then the same, the handler's runs of all three ports each counted once).

Where a DIV holds one write to every port in use between the falls of two consecutive N
(`merged_step`: 3 cycles a port and the read and jump), a build may pulse the ports at once
(codegen.can_merge; frame_merged.asm.j2, irq_merged.asm.j2): all rise in one entry, 3 cycles
apart, and the falls of every port are one timeline of groups, each writing every port in the
same order (`merged_split`: groups this far apart are entries of their own). frame_io sorts each
port into a list of its own, waits for the handler's last group of the frame before, and merges
the lists into the items (Budget.merge). Two terms (`merged_load`: the falls and the groups of
the worst frame over every port's lines together):

    P >= C(highest N) + the last group's entry and exit to the merging (Budget.tail) + late
    P >= W + the sorts + merge + the rise's entry + the falls

(the first: the items the rise's entry reads are written before the next rise; `late`
(`merged_late`) is the merging up to them (Budget.head) where the rest of it, and the rise's entry,
fit in C(the lowest N any line falls at), so that every group is written before the handler reads
it; else the whole merging. The second: the background's chain from one frame's items to the next
holds all of the frame's work and every run of the handler in it. Where the merging starts later
than the first term's, the chain has started it: then it was begun at the latest `head` before the
rise too, and so ends before the frame's first fall as well). With a serial line each window has
the serial handler's runs in it (`serial_load`): the merging's from the last group's exit to the
rise, the rest of it before the first fall, and the whole frame's; and the edge handler can keep
the serial handler waiting for at most everything it does in a frame (`busy_stretch`).
"""

from __future__ import annotations

import dataclasses
from bisect import bisect_left
from dataclasses import dataclass
from functools import lru_cache

from .units import DEFAULT_PERIOD_FLOOR_US, N_MAX

# The entry latency the handler's pad absorbs: 3 to 9 cycles on an 8051 (an instruction under
# way, up to a 4-cycle MUL, and one more after a RETI or a write to IE; nothing else holds the
# edge handler off: it alone has high priority and the firmware never clears EA), 1 or 2 in
# ucsim; `tests/test_irq.py` holds interrupts off in ucsim up to this and past it.
LATENCY = 12
# TL0 as the handler reads it with no latency: the vector (PUSH PSW, PUSH ACC, LJMP: 6), PUSH
# DPL/DPH (4), MOV DPTR (2), MOV A,TL0 (1).
PAD_FROM = 13
STOP = 7            # cycles Timer0 stands still while an exit adds to it
STEP = 7            # the shortest step between two edges of one entry
# Overflow to the first edge of an entry: to the read of TL0 (PAD_FROM + latency), the jump into
# the pad (2) and its PAD_FROM + LATENCY - v NOPs for v = TL0 read, MOV PSW (2), MOV DPL/DPH (4),
# MOV A,R6 (1), JMP (2), and the edge's 3: 39 whatever the latency (`tests/test_costs.py` reads
# TL0 at each such edge in ucsim).
ENTRY = PAD_FROM + LATENCY + 2 + 9 + 3
# The last edge of an entry to the end of its RETI on the longest exit: the step's
# read and jump (4), LJMP (2), exit_far (28), MOV R6 (1), the add to SETB (8), POPs (8),
# RETI (2); `tests/test_costs.py` reads it from the code.
EXIT = 53
# The build whose ports' pulses overlap (never at a 1 us cycle): exit_far's C(N) comes from the
# table, a cycle more; its groups of m ports are 3 (m - 1) cycles longer than one port's edge.
MEXIT = EXIT + 1
RISEM_AT = 2        # stagger: a port's items begin with its rise's lines: MOV RISEM, ACT+p
PORT_WRITE = 3      # a group's write to one port: MOV A,@R0; INC R0; XRL Px,A (the rise's too)


def merged_split(m: int) -> int:
    """Groups of m ports this far apart or more: entries of their own (after the RETI before)."""
    return ENTRY + PORT_WRITE * (m - 1) + MEXIT + 1


@lru_cache(maxsize=64)
def near_dn(target, split: int) -> int:
    """The least difference of N from which every two falls are `split` cycles apart or more
    (C(N + dN) - C(N) >= split for every N, from the widths the firmware uses): the edge handler
    or frame_io takes a group that far from the one before as an entry of its own without
    looking up the gap."""
    widths = [target.width_cycles(n) for n in range(N_MAX + 1)]
    return next(d for d in range(1, N_MAX + 1)
                if all(widths[n + d] - widths[n] >= split for n in range(N_MAX + 1 - d)))


def merged_step(m: int) -> int:
    """The shortest step from one group of m ports to the next: each port's write, the read and
    jump (4)."""
    return PORT_WRITE * m + 4


SPLIT = ENTRY + EXIT + 1   # edges this far apart or more: separate entries (the next
                           # overflow comes after the RETI before it)
SLED = SPLIT - 1 - STEP    # NOPs before each port's edge: any gap from STEP to SPLIT - 1
# A port's rise less than SPLIT cycles after the last fall of the port before it is a step of
# that fall's entry (not in a build for size): the step's read and jump (4), the window's stub
# (7: the offset, R5/R4 at the rising port's window, DPTR at rsled), RSLED NOPs less the offset,
# rsled's jump to that window's step rise (7), and its 3 to the edge: the gap is RISE_STEP to
# SPLIT - 1. From the rise's edge the handler reaches emit_p's path (its first two cycles,
# R5:R4 = 0) 2 cycles later after a rise that starts an entry; after a step, LJMP (2) and emit_s
# (9: R5:R4 = the rise from the step's entry's overflow) come before emit_b, 9 more than emit_p's
# first two. The fall before such a rise is charged its entry and exit (SPLIT - 1), which the gap
# is within, so RISE_HEAD + emit_p's longest path bounds both.
RISE_STEP = 4 + 7 + 7 + 3
RSLED = SPLIT - 1 - RISE_STEP
RISE_HEAD = ENTRY + 9


def rise_steps(compact: bool) -> bool:
    """Whether a build can have rises as steps: not a build for size (their code, rsled and its jump
    and more in each port's window and emit: the README's "ROM runtime" row with and without them,
    would take room the build for size is for)."""
    return not compact


def port_span(target, top: int = 250, steps: bool = False) -> int:
    """A port's rise to the next port's: its longest pulse (its lines reach N `top` at the most),
    then, with `steps`, the shortest step to the next rise (RISE_STEP; a last fall SPLIT or more
    before that rise leaves the rise an entry of its own), else an entry of its own."""
    return target.width_cycles(top) + (RISE_STEP if steps else SPLIT)


def apart_span(target, top: int = 250) -> int:
    """The shortest span in which the next port's rise is always an entry of its own, after the
    exit of the port's last fall."""
    return target.width_cycles(top) + SPLIT


@lru_cache(maxsize=16)
def stagger_ok(target) -> bool:
    """Whether a port's rise can come among the falls of the port before it (`stagger_span`): only
    where every two falls one DIV apart leave room for a step on both sides of a rise between them
    (2 STEP cycles), so that some rise times are at least STEP from every fall."""
    return all(target.width_cycles(n + 1) - target.width_cycles(n) >= 2 * STEP for n in range(250))


# Where a DIV is less than 2 STEP cycles (12 MHz, 11.0592 MHz) no time between two falls one DIV
# apart is STEP from both, so a rise among the falls comes BESIDE cycles after the fall of some N j
# (1 <= j <= 250), in one block of the port's window with that fall and the next N's: the fall of j,
# BESIDE cycles later the rise (MOV A,RISEM; XRL), the fall of j + 1 C(j + 1) - C(j) - BESIDE cycles
# after the rise (at least 3: MOV A,@R0; INC R0; XRL). Each block is entered as a step of exactly
# its gap from an edge at N j - 1 (a fall there, or one with no line when that port has none): so
# its sled is that gap's own NOPs (irq.asm.j2, stagger_emit.asm.j2).
BESIDE = 2


@lru_cache(maxsize=16)
def beside_gaps(target) -> tuple[int, int]:
    """The gaps C(j) - C(j - 1) and C(j + 1) - C(j) around every N j a rise may come beside: the
    pair most N from 1 to 249 have (at 12 MHz every N's: 8 and 8), so that the blocks' code is the
    same whatever j the spans give (only immediates change when the code is laid out again)."""
    c = target.width_cycles
    pairs: dict[tuple[int, int], int] = {}
    for j in range(1, N_MAX):
        pair = (c(j) - c(j - 1), c(j + 1) - c(j))
        pairs[pair] = pairs.get(pair, 0) + 1
    return max(pairs, key=lambda pair: (pairs[pair], pair))


def beside(target) -> bool:
    """Whether a rise among the falls comes beside a fall (`BESIDE`): where no time between two falls
    one DIV apart is STEP from both (not `stagger_ok`)."""
    return not stagger_ok(target)


@lru_cache(maxsize=16)
def beside_extra(target) -> int:
    """The handler's most cycles in a frame that a rise beside a fall adds to its port's falls and
    the rise's own entry (`rises`): the edge with no line at N j - 1 before the block, at most its
    gap to the block's first edge (C(j) - C(j - 1), or BESIDE more to a rise that comes first); 0
    where rises do not come beside falls."""
    if not beside(target):
        return 0
    return max(target.width_cycles(n + 1) - target.width_cycles(n) for n in range(250)) + BESIDE


@lru_cache(maxsize=4096)
def rise_slot(target, top: int, at_least: int, bottom: int = 0) -> int:
    """The first time from `at_least` on (cycles after a port's rise) at least STEP cycles from the
    fall of every N from `bottom` to `top` (the N its lines can fall at): where the next port's rise
    can come among this port's falls as a step on either side, or before or after them. Where a rise
    comes `beside` a fall, also BESIDE cycles after the fall of an N j from 1 to 249 whose gaps to the
    N before and after it are `beside_gaps`, the earlier."""
    widths = _widths(target, bottom, top)
    d = at_least
    while True:     # the latest fall less than STEP after d, if it is less than STEP before d
        k = bisect_left(widths, d + STEP)
        if k == 0 or widths[k - 1] <= d - STEP:
            break
        d = widths[k - 1] + STEP
    if beside(target):
        c, gaps = target.width_cycles, beside_gaps(target)
        by = next((c(j) + BESIDE for j in range(1, N_MAX) if c(j) + BESIDE >= at_least
                   and (c(j) - c(j - 1), c(j + 1) - c(j)) == gaps), d)
        d = min(d, by)
    return d


@lru_cache(maxsize=64)
def _widths(target, bottom: int, top: int) -> tuple[int, ...]:
    """C(N) for N from `bottom` to `top`, ascending."""
    return tuple(target.width_cycles(n) for n in range(bottom, top + 1))


def stagger_span(target, top: int, emit: int, last: bool, bottom: int = 0, next_bottom: int = 0) -> int:
    """The shortest span of a port whose next port's rise may come among its falls: the next port's
    first fall (C(next_bottom) after its rise at the earliest: the lowest N its lines fall at,
    `flow.port_reach`) must come after this port's last fall (C(top)) and the handler's run from
    it that takes the next port's items (`emit`: Budget.emits, an entry's ENTRY included); the rise
    no earlier than C(0) (the run that takes this port's items ends by then, `HandlerTooSlow`),
    and at least STEP from every fall this port's lines can have (`rise_slot`, N `bottom` to
    `top`). The last port's span holds its falls whole (the next frame's first rise after them),
    so that every longer period holds too."""
    if last:
        return target.width_cycles(top) + STEP
    least = target.width_cycles(top) - target.width_cycles(next_bottom) + emit
    return rise_slot(target, top, max(least, target.width_cycles(0)), bottom)


def rise_offsets(ports: tuple[int, ...], target, spans: tuple[int, ...] = ()) -> dict[int, int]:
    """Cycles from the first port's rise to each port's rise: each port `spans` after the one
    before (`fit_spans`; none given: every port's longest pulse N 250)."""
    return dict(zip(ports, _rises(target, spans, len(ports))))


def _rises(target, spans: tuple[int, ...], m: int) -> list[int]:
    """Each of `m` ports' rise from the first port's, in port order, then the end of the last
    port's span (no `spans`: each N 250's)."""
    spans = spans or (port_span(target),) * m
    return [sum(spans[:k]) for k in range(m + 1)]


def _sort_need(target, budget: "Budget", j: int, span: int) -> int:
    """What must fit in the span of the port before port j (j >= 1) for port j's sort to be there
    before its rise: that sort, the port before's handler load, the serial handler's runs."""
    runs = serial_load(target, budget, span) if budget.byte_cycles else 0
    return budget.sorts[j] + handler_load(budget.rises[j - 1], budget.falls[j - 1]) + runs


def fit_spans(target, budget: "Budget", tops: tuple[int, ...]) -> tuple[int, ...]:
    """Each port's span: its longest pulse, the highest N its lines can reach (`tops`, in port
    order: flow.port_tops), then the shortest step to the next rise; longer where the sort of the port after it
    in buffer A (its sort, the port's handler load, the serial handler's runs in that time) needs
    more time between the two rises. With a serial line whose bytes the edge handler would keep
    waiting too long, each span also leaves the serial handler the time to take a byte between its
    port's last edge and the next port's rise (`busy_stretch`), where that makes it short enough."""
    spans = _fit_spans(target, budget, tops, None)
    if budget.byte_cycles:
        late = serial_latency(target, dataclasses.replace(budget, spans=spans, tops=tops))
        if late > rx_gap(budget.byte_cycles):
            apart = _fit_spans(target, budget, tops, serial_gap(budget) - 1)
            if serial_latency(target, dataclasses.replace(budget, spans=apart, tops=tops)) < late:
                return apart
    return spans


def _fit_spans(target, budget: "Budget", tops: tuple[int, ...], gap: int | None) -> tuple[int, ...]:
    """`fit_spans` with `gap` more cycles than its longest pulse and an entry in each span (None:
    the shortest, the next rise a step after the longest pulse)."""
    m = len(budget.lines)
    if budget.stagger:
        return _stagger_spans(target, budget, tops)
    spans = [port_span(target, top, budget.steps) if gap is None else apart_span(target, top) + gap for top in tops]
    for j in range(1, m - 1 if budget.last_in_b else m):
        while (more := _sort_need(target, budget, j, spans[j - 1])) > spans[j - 1]:
            spans[j - 1] = more
    return tuple(spans)


def _stagger_spans(target, budget: "Budget", tops: tuple[int, ...]) -> tuple[int, ...]:
    """`fit_spans` where each rise may come among the falls of the port before it: each span
    `stagger_span`, longer where the next port's sort needs more between the handover before it
    (`handovers`) and its rise (`_stagger_need`): fitted with each later port's sort and items
    whole by its rise, and with each part only by the read that needs it; the fit whose period
    is shorter."""
    m = len(budget.lines)
    gap = serial_gap(budget) if budget.byte_cycles else 0     # the serial handler's time between two ports' runs
    low = budget.bottoms or (0,) * m
    fits = []
    for whole in (False, True):
        spans = [stagger_span(target, top, budget.emits[(k + 1) % m] + gap, k == m - 1, low[k], low[(k + 1) % m])
                 for k, top in enumerate(tops)]
        for j in range(1, m - 1 if budget.last_in_b else m):
            while True:
                need = _stagger_need(target, budget, tops, spans, j, whole)
                if need <= spans[j - 1]:
                    break
                spans[j - 1] = rise_slot(target, tops[j - 1], need, low[j - 1])      # j - 1 < m - 1: never the last
        fits.append(tuple(spans))
    if fits[0] == fits[1] or not (budget.heads and budget.items):
        return fits[1]
    # a shorter span puts the next port's handover later: the fit whose period is shorter
    def period(spans):
        try:
            return _least(target, dataclasses.replace(budget, spans=spans, tops=tops))
        except TooSlow:
            return 1 << 17
    return min(fits, key=period)


def _stagger_need(target, budget: "Budget", tops: tuple[int, ...], spans, j: int, whole: bool = False) -> int:
    """The shortest span of port j - 1 that leaves port j's sort and items their time, from the
    handover of port j - 1 (the background's wait ends there at the latest) with that port's load
    and the serial handler's runs: the rise of port j reads only RISEM (written first), SPLIT - 1
    before it; its handover only the items' header (`Budget.heads`), ENTRY before it: it comes
    after port j's rise and after port j - 1's last fall, which in some frame can be its lowest,
    C(bottom); the rest is read from port j's first edge on (`first_read`), so it ends ENTRY
    before that edge, port j's rise and handover in between, or SPLIT - 1 before the rise."""
    late = handovers(target, tops, tuple(spans))[j - 1] - sum(spans[:j - 1])
    base = late + handler_load(budget.rises[j - 1], budget.falls[j - 1])
    runs = serial_load(target, budget, spans[j - 1]) if budget.byte_cycles else 0
    if whole or not budget.heads or not budget.items:
        return base + budget.sorts[j] + runs + SPLIT - 1
    written = base + budget.sorts[j] + runs
    net = budget.sorts[j] - budget.items[j]
    first = first_read(target, dataclasses.replace(budget, bottoms=(budget.bottoms or (0,) * len(spans))[j:],
                                                   spans=tuple(spans[j:])))
    more = serial_load(target, budget, spans[j - 1] + first) if budget.byte_cycles else 0
    header = base + net + budget.heads[j] + runs + ENTRY
    bottom = (budget.bottoms or (0,) * len(spans))[j - 1]
    return max(base + net + RISEM_AT + runs + SPLIT - 1,
               header if header > target.width_cycles(bottom) else 0,
               min(written + SPLIT - 1, written - runs + more + budget.rises[j] + ENTRY - first))


def handovers(target, tops: tuple[int, ...], spans: tuple[int, ...]) -> list[int]:
    """Where each port's items are written at the latest (cycles from the first port's rise): at its
    rise, or after the last fall of the port before it where the rise comes among those falls."""
    m = len(spans)
    rise = _rises(target, spans, m)
    return [rise[j] + max(0, target.width_cycles(tops[j - 1]) - spans[j - 1]) for j in range(m)]


def handler_load(rise_cycles: int, falls: int) -> int:
    """The handler's worst cycles in one frame for a port: its rise entry, then its falls (`port_load`)."""
    return rise_cycles + falls


def frame_load(budget: "Budget") -> int:
    """The handler's worst cycles in a frame: every port's rise entry, and every port's falls of one
    frame (the work from one frame's first items to the next holds those of one frame:
    `Budget.frame_falls`, where known together, else each port's worst; with the ports at once,
    their one timeline's)."""
    return sum(budget.rises) + frame_falls(budget)


def frame_falls(budget: "Budget") -> int:
    """The handler's most cycles for every port's falls in one frame: `Budget.frame_falls`, where
    known together, else each port's worst added."""
    return budget.frame_falls or sum(budget.falls)


def last_two_falls(budget: "Budget") -> int:
    """The handler's most cycles for the last two ports' falls in one frame: `Budget.pair_falls`,
    where known together, else each port's worst added."""
    return budget.pair_falls or sum(budget.falls[-2:])


def edges_load(widths, values, split: int = 0) -> int:
    """The handler's cycles for the falls of one frame whose lines fall at N = `values`: the first
    fall an entry of its own (ENTRY + EXIT = SPLIT - 1), then per distinct N after it the gap to the
    edge before when it is a step in the same entry (gap < SPLIT), else SPLIT - 1 (the exit, then an
    entry of its own). `widths[N]` = C(N) in cycles. `split`: where not SPLIT (the build whose
    ports' pulses overlap: its groups' entries are longer)."""
    split = split or SPLIT
    cs = sorted({widths[v] for v in values})
    return (split - 1) * bool(cs) + sum(min(b - a, split - 1) for a, b in zip(cs, cs[1:]))


# Optimal sorting networks (comparator counts 0, 1, 3, 5, 9, 12, 16, 19): frame_io's sort of a
# port's N in pin order (frame_irq.asm.j2). A comparator (a, b) swaps when N_b < N_a.
SORTING_NETWORKS: dict[int, tuple[tuple[int, int], ...]] = {
    1: (),
    2: ((0, 1),),
    3: ((0, 2), (0, 1), (1, 2)),
    4: ((0, 1), (2, 3), (0, 2), (1, 3), (1, 2)),
    5: ((0, 3), (1, 4), (0, 2), (1, 3), (0, 1), (2, 4), (1, 2), (3, 4), (2, 3)),
    6: ((0, 5), (1, 3), (2, 4), (1, 2), (3, 4), (0, 3), (2, 5), (0, 1), (2, 3), (4, 5), (1, 2), (3, 4)),
    7: ((0, 6), (2, 3), (4, 5), (0, 2), (1, 4), (3, 6), (0, 1), (2, 5), (3, 4), (1, 2), (4, 6), (2, 3),
        (4, 5), (1, 2), (3, 4), (5, 6)),
    8: ((0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7), (0, 1), (2, 3), (4, 5), (6, 7),
        (2, 4), (3, 5), (1, 4), (3, 6), (1, 2), (3, 4), (5, 6)),
}


def swaps(values) -> int:
    """How many comparators of the sorting network swap when it sorts `values` (pin order)."""
    v = list(values)
    n = 0
    for a, b in SORTING_NETWORKS[len(v)]:
        if v[b] < v[a]:
            v[a], v[b] = v[b], v[a]
            n += 1
    return n


@dataclass(frozen=True)
class PortLoad:
    """A port's worst frame, over every frame the program's moves can put out (`port_load`)."""
    falls: int      # the handler's cycles for its falls (`edges_load`)
    swaps: int      # comparators of its sort that swap
    distinct: int   # distinct N its lines with a target fall at (frame_io's `distinct` pairs)


SWEEP_BUDGET = 40_000       # breakpoints swept per port before the rest get the hull bound


@lru_cache(maxsize=16)
def port_load(target, motions: frozenset) -> PortLoad:
    """The handler's worst cycles for one port's falls in any frame (`handler_load`), the most
    comparators of its sort that swap, and the most distinct N its lines fall at, over the port's motions (`flow.port_motions`): for a move of
    known start, every frame it can have at any period. Its lines' N are functions of one u in
    [0, 1] (k / F, or the eased table's value), each a step function that changes at known u: the
    frames are the sets of N between those u, swept in order. A move that can start after an
    interruption (a `Reach`) gets the bound of its hull: each gap at most SPLIT - 1, and all of them
    at most C(highest) - C(lowest), every comparator swapping and every line at an N of its own. Paths are swept in order of that
    bound while it, or a swap not yet seen, can still beat the worst found. (The motions do not
    depend on the period: the period stage asks again with the same ones.)"""
    widths = [target.width_cycles(n) for n in range(256)]
    order = sorted(((_hull(widths, lines, SPLIT), lines) for lines in motions), key=lambda m: -m[0])
    most = max((len(SORTING_NETWORKS[len(lines)]) for lines in motions), default=0)
    worst, swapped, distinct, budget = 0, 0, 0, SWEEP_BUDGET
    for at, (bound, lines) in enumerate(order):
        if bound <= worst and swapped >= most:      # the rest: at most every line its own N
            distinct = max([distinct] + [_targets(rest) for _, rest in order[at:]])
            break
        cost = _breakpoints(lines)
        if cost is None or cost > budget:
            worst, swapped, distinct = max(worst, bound), most, max(distinct, _targets(lines))
            continue
        budget -= cost
        falls, swapped_here, distinct_here = _sweep(target, lines)
        worst, swapped, distinct = max(worst, falls), max(swapped, swapped_here), max(distinct, distinct_here)
    return PortLoad(worst, swapped, distinct)


def _breakpoints(lines) -> int | None:
    """The steps a move's lines take over its frames (`_frames`: what sweeping it costs), or None
    where one can start anywhere (a `Reach`): its frames are not known."""
    fall = [ab for ab in lines if ab is not None]
    if not all(isinstance(a, int) and isinstance(b, int) for a, b in fall):
        return None
    return sum(abs(b - a) for a, b in fall)


def _targets(lines) -> int:
    """The lines of a motion with a target: the most distinct N they can fall at."""
    return sum(ab is not None for ab in lines)


@lru_cache(maxsize=16)
def falls_together(target, motions: frozenset, ports: tuple[int, ...], groups: tuple[tuple[int, ...], ...],
                   caps: tuple[int, ...]) -> tuple[int, ...]:
    """For each group of ports, the handler's most cycles for the falls of its ports in one frame
    (`edges_load` of each, added), over every frame the program's moves can put out: `motions`
    every line of every port (`flow.port_motions(joint=True)`), `ports` each line's port; never more
    than its cap (the sum of those ports' `port_load`), and less where their worst frames are not
    the same frame. A move that can start after an interruption (a `Reach`), or whose frames are
    more than SWEEP_BUDGET breakpoints, gets the sum of the ports' hulls; moves are swept in order
    of that bound while it can still beat the worst found."""
    widths = [target.width_cycles(n) for n in range(256)]
    own = sorted({p for group in groups for p in group})
    cuts = [0]
    for port in own:
        cuts.append(cuts[-1] + sum(q == port for q in ports))
    part = dict(zip(own, (slice(a, b) for a, b in zip(cuts, cuts[1:]))))
    every = {tuple(ab for port in own for ab, q in zip(lines, ports) if q == port) for lines in motions}

    def bounds(lines) -> tuple[int, ...]:      # each group's: its ports' hulls, at most its cap
        hull = {p: _hull(widths, lines[part[p]], SPLIT) if any(lines[part[p]]) else 0 for p in own}
        return tuple(min(cap, sum(hull[p] for p in group)) for group, cap in zip(groups, caps))

    order = sorted(((bounds(lines), lines) for lines in every if any(lines)), key=lambda m: (-max(m[0]), repr(m[1])))
    worst, budget = [0] * len(groups), SWEEP_BUDGET
    for bound, lines in order:
        if all(b <= w for b, w in zip(bound, worst)):
            continue
        cost = _breakpoints(lines)
        if cost is None or cost > budget:
            worst = [max(b, w) for b, w in zip(bound, worst)]
            continue
        budget -= cost
        falling = [ab is not None for ab in lines]
        seen: dict[int, tuple] = {}
        load: dict[int, int] = {}
        for cur in _frames(lines):
            for p in own:       # each port's falls, again only where its lines moved
                values = tuple(cur[part[p]])
                if seen.get(p) != values:
                    seen[p] = values
                    load[p] = edges_load(widths, [v for v, f in zip(values, falling[part[p]]) if f])
            worst = [max(w, sum(load[p] for p in group)) for w, group in zip(worst, groups)]
            if all(w >= b for w, b in zip(worst, bound)):
                break
    return tuple(worst)


@lru_cache(maxsize=16)
def start_loads(target, starts: frozenset) -> frozenset:
    """For each move start on a port (`flow.move_starts`): (the handler's cycles for the falls of
    the frame before it, the comparators of its sort that swap on its first frame, the move is
    eased, its F is found at run time, the move statement's id)."""
    widths = [target.width_cycles(n) for n in range(256)]
    return frozenset((edges_load(widths, [v for v in before if v is not None]), swaps([v or 0 for v in first]),
                      eased, runtime_f, step) for before, first, eased, runtime_f, step in starts)


def _hull(widths, lines, split: int) -> int:
    """The handler's cycles for the falls of any frame of a move whose lines go anywhere between
    their starts and ends (`Reach` or N): the first an entry of its own (split - 1), each gap after
    it at most split - 1, and all of them at most C(highest) - C(lowest)."""
    fall = [ab for ab in lines if ab is not None]
    lo = min(min(_lo(a), _lo(b)) for a, b in fall)
    hi = max(max(_hi(a), _hi(b)) for a, b in fall)
    return (split - 1) + min((split - 1) * (len(fall) - 1), widths[hi] - widths[lo])


def _lo(v) -> int:
    return v if isinstance(v, int) else v.lo


def _hi(v) -> int:
    return v if isinstance(v, int) else v.hi


def _frames(lines):
    """The N of `lines` in each frame of one move, in order (a list changed in place between
    frames). The firmware puts line i at N0 +- floor(|d| u + 1/2), d = N1 - N0, for the frame's u
    (k / F, or the eased table's value / 256; `plan.firmware_value`): it steps by one at
    u = (m - 1/2) / |d|, m = 1..|d|, and holds the new N from that u on. (Equal rationals with
    denominators this small are equal floats, so the u of several lines meet exactly.) A line
    without a target (None) stays at N 0."""
    cur = [0 if ab is None else ab[0] for ab in lines]
    at: dict[float, list[int]] = {}
    for i, ab in enumerate(lines):
        if ab is None:
            continue
        d = abs(ab[1] - ab[0])
        for m in range(1, d + 1):
            at.setdefault((2 * m - 1) / (2 * d), []).append(i)
    yield cur
    for u in sorted(at):
        for i in at[u]:
            cur[i] += 1 if lines[i][1] > lines[i][0] else -1
        yield cur


@lru_cache(maxsize=4096)
def _sweep(target, lines: tuple) -> tuple[int, int, int]:
    """The most `edges_load`, the most `swaps` and the most distinct N falling over the frames of
    one move (`_frames`; see `port_load`), each up to its bound (the move's hull, its network's
    comparators, its lines with a target). A line without a target (None) is sorted, never
    falling. (Kept per move: programs that share moves, and the builds of one program, sweep
    each once.)"""
    widths = [target.width_cycles(n) for n in range(256)]
    bound, most, every = _hull(widths, lines, SPLIT), len(SORTING_NETWORKS[len(lines)]), _targets(lines)
    falling = [ab is not None for ab in lines]
    worst = swapped = distinct = 0
    for cur in _frames(lines):
        values = [v for v, f in zip(cur, falling) if f]
        worst = max(worst, edges_load(widths, values))
        swapped = max(swapped, swaps(cur))
        distinct = max(distinct, len(set(values)))
        if worst >= bound and swapped >= most and distinct >= every:
            break
    return worst, swapped, distinct


@dataclass(frozen=True)
class MergedLoad:
    """The worst frame of the build whose ports' pulses overlap (`merged_load`)."""
    falls: int      # the handler's cycles for the falls of every port (`edges_load` at its split)
    groups: int     # the most distinct N at which a line of any port falls


@lru_cache(maxsize=16)
def merged_load(target, motions: frozenset, split: int) -> MergedLoad:
    """Over every frame the program's moves can put out (`flow.port_motions(joint=True)`: every
    line of every port): the most handler cycles for the frame's falls, merged into one timeline
    (each group of the lines of every port at one N an edge: `edges_load` with `split`, the gap from
    which a group is an entry of its own), and the most groups. A move that can start after an
    interruption (a `Reach`) gets its hull's bound: every line its own group, each gap at most
    split - 1 and all of them at most C(highest) - C(lowest)."""
    widths = [target.width_cycles(n) for n in range(256)]
    falls = groups = 0
    for lines in motions:
        if _breakpoints(lines) is None:
            falls = max(falls, _hull(widths, lines, split))
            groups = max(groups, _targets(lines))
            continue
        falling = [ab is not None for ab in lines]
        for cur in _frames(lines):
            values = [v for v, f in zip(cur, falling) if f]
            falls = max(falls, edges_load(widths, values, split))
            groups = max(groups, len(set(values)))
    return MergedLoad(falls, groups)


@dataclass(frozen=True)
class Budget:
    """What the generated code takes, per frame: read from its text by `servoc.wcet`."""
    work: int                   # the longest work between two frames
    sorts: tuple[int, ...]      # each port's sort in frame_io, in port order
    rises: tuple[int, ...]      # each port's rise entry of the handler, overflow to RETI
    lines: tuple[int, ...]      # servo lines on each port
    falls: tuple[int, ...]      # the handler's worst cycles for each port's falls in a frame (port_load)
    pair_falls: int = 0         # the most of the last two ports' falls in one frame (`falls_together`; 0: not
                                # known together, the sum of their `falls`)
    frame_falls: int = 0        # the most of every port's falls in one frame (`falls_together`; 0: not known
                                # together, the sum of `falls`)
    start_frame: int | None = None  # one port: the longest frame that starts a move, its work and
                                # its own sort and falls (`start_loads`); None: not known apart
    other_work: int = 0         # then the longest work between frames of those that start no move
    serial_run: int = 0         # the serial handler's longest run, its vector's LCALL to RETI (0: no serial line)
    serial_head: int = 0        # its vector's LCALL to the end of `CLR RI`: a received byte taken
    byte_cycles: int = 0        # one byte on the serial line (10 bits)
    serial_sends: bool = False  # the program sends: the serial handler also runs for each byte that goes out
    last_in_b: bool = False     # the last port has sort buffer B: frame_io sorts it before the others
    spans: tuple[int, ...] = ()     # each port's rise to the next one's (`fit_spans`; none: N 250 each)
    tops: tuple[int, ...] = ()      # the highest N each port's lines reach (flow.port_tops; none: 250)
    bottoms: tuple[int, ...] = ()   # the lowest N each port's lines fall at (flow.port_reach; none: 0)
    steps: bool = False         # a rise less than SPLIT after the last fall before it is a step (RISE_STEP)
    stagger: bool = False       # each port's rise may come among the falls of the port before it (stagger_span)
    emits: tuple[int, ...] = ()     # stagger: each port's handover, from the last edge of the port before
                                # to the RETI, and an entry's ENTRY (its rise: `rises`, SPLIT - 1 more)
    items: tuple[int, ...] = ()     # stagger: the part of each port's sort (`sorts`) that waits for the
                                # handler to take the port before's items: writing its own
    merged: bool = False        # the ports' pulses overlap: one timeline of groups (merged_load);
                                # `sorts` is then frame_io's sorts of every port, before it waits, and
                                # its return once the handler has read the rise's items
    merge: int = 0              # merged: frame_io's merging of the ports' lists into items, after the wait
    tail: int = 0               # merged: from the frame's rise overflow, less C(the last group's N), to
                                # where frame_io goes on merging: the last group's entry and exit
    head: int = 0               # merged: the merging up to the items the rise's entry reads (every port's
                                # lines and the first group's link), or where no line falls, to MBUSY set;
                                # stagger: the first port's items (`items`) up to their header and first
                                # edge, all its handover reads (0: not known apart, the whole)
    heads: tuple[int, ...] = ()     # stagger: each port's items up to their header and first edge (none:
                                # not known apart: a later port's sort and items by its rise)


def frame_cycles(target, budget: Budget) -> int:
    """The shortest frame period in machine cycles from which on every period holds (`holds`).
    With a serial line its handler's runs come on top, in each window of the frame as many as
    bytes can come and go in it: the windows' lengths depend on the period, so the need is a step
    function of it. It is found again until it no longer grows, and then every step above is
    checked: where a longer period needs more than it has, the search goes on from there.
    Without the serial line's runs the need only shrinks as the period grows (with two ports and
    rises among falls the last port's handover of the frame before comes earlier: `_items_start`),
    so the shortest period that holds is found by bisection and every longer one holds too; with
    the runs, the search starts from there, and from the period found goes down while each
    period holds (the need is then no longer monotone: a search up from below can step past the
    first period that holds)."""
    least = _least(target, budget)
    if not budget.byte_cycles:
        return least
    period = _holding_from(target, budget, least)
    while period > least and holds(target, budget, period - 1):
        period -= 1
    return period


def _holding_from(target, budget: Budget, start: int) -> int:
    """With a serial line: the first period from `start` on that holds, and every longer one."""
    period = _settle(target, budget, start)
    while True:
        fails = _first_failing(target, budget, period)
        if fails is None:
            return period
        period = _settle(target, budget, fails)


def holds(target, budget: Budget, period: int) -> bool:
    """Whether the code holds a frame of `period` machine cycles (the model evaluated at it)."""
    return _frame_cycles(target, budget, period) <= period


def _least(target, budget: Budget) -> int:
    """The shortest period that holds what the code needs without the serial line's runs: the need
    evaluated at a period P never grows with P, so P - need(P) grows and the first P where it is 0
    or more is found by bisection between the need of the longest frame and the need at P = 0
    (which holds at itself)."""
    quiet = dataclasses.replace(budget, byte_cycles=0) if budget.byte_cycles else budget
    lo, hi = _frame_cycles(target, quiet, 1 << 16) - 1, _frame_cycles(target, quiet, 0)
    while hi - lo > 1:          # _frame_cycles(lo) > lo, _frame_cycles(hi) <= hi
        mid = (lo + hi) // 2
        if _frame_cycles(target, quiet, mid) <= mid:
            hi = mid
        else:
            lo = mid
    return hi


def _settle(target, budget: Budget, period: int) -> int:
    """The first period from `period` on that holds what the period itself brings."""
    while budget.byte_cycles:
        more = _frame_cycles(target, budget, period)
        if more <= period:
            break
        period = more
    return period


def _first_failing(target, budget: Budget, period: int) -> int | None:
    """The first period above `period` that does not hold, or None. The need changes only where a
    window's length crosses a byte time (`serial_load`), so only those periods are checked; the
    need grows by at most one run of each kind per byte time while the period grows by a byte
    time, so once a step holds with a run to spare, every longer period does."""
    gap, reach = rx_gap(budget.byte_cycles), run_reach(target, budget)
    m = len(budget.lines)
    rise = _rises(target, budget.spans or (port_span(target, 250, budget.steps),) * m, m)
    if budget.stagger and budget.spans:     # each port's handover starts its window
        rise = handovers(target, budget.tops or (250,) * m, budget.spans)
    offsets = {0} if m == 0 else {0, rise[m - 1], rise[max(0, m - 2)]}
    # (spacing, shift): a window's count of runs steps where its length crosses shift mod spacing
    steps = {(gap, 1)} | ({(gap, 1 - reach)} if reach is not None else set()) | \
        ({(budget.byte_cycles, 1)} if budget.serial_sends else set())
    step = (2 if budget.serial_sends else 1) * (budget.serial_run + SERIAL_WAIT)
    lo = period
    while True:
        hi = lo + 4 * gap           # the periods where a window of length P - d crosses a step
        points = sorted({p for d in offsets for every, s in steps
                         for k in range((lo - s - d) // every, (hi - s - d) // every + 2)
                         if lo < (p := k * every + s + d) <= hi})
        for p in points:
            if _frame_cycles(target, budget, p) > p:
                return p
        if hi - _frame_cycles(target, budget, hi) >= 2 * step:
            return None
        lo = hi


def _frame_cycles(target, budget: Budget, period: int) -> int:
    """The largest of the terms (module docstring), each window of a frame `period` long with the
    serial handler's runs in it (`serial_load`; none without a serial line)."""
    def runs(cycles: int) -> int:
        return serial_load(target, budget, max(cycles, 0)) if budget.byte_cycles else 0

    m = len(budget.lines)
    if m == 0:
        return budget.work + runs(period)
    if budget.merged:   # the items are written after the last group's exit, and the background's chain
        # from there to the next frame's items holds the whole frame's work (each with the serial
        # handler's runs in its window)
        last = target.width_cycles(max(budget.tops or (N_MAX,))) + budget.tail
        return max(last + merged_late(target, budget, runs) + runs(period - last),
                   budget.work + sum(budget.sorts) + budget.merge + frame_load(budget) + runs(period))
    rise = _rises(target, budget.spans or (port_span(target, 250, budget.steps),) * m, m)
    span = [b - a for a, b in zip(rise, rise[1:])]       # each port's rise to the next one's
    load = [handler_load(r, f) for r, f in zip(budget.rises, budget.falls)]
    frame = sum(budget.sorts) + budget.work + frame_load(budget)
    if budget.start_frame is not None:      # one port: a frame's work, then its sort, within its period
        frame = max(budget.sorts[0] + budget.other_work + load[0], budget.start_frame + budget.rises[0])
    need = [rise[m], frame + runs(period)]
    # the last two ports' falls in one frame: both in the chain from the one before last's rise
    # (with stagger, its handover) to the first port's next rise, both of the same frame
    together = sum(budget.falls[-2:]) - last_two_falls(budget)
    # where each port's items are written (its rise; with stagger, after the port before's last fall)
    hand = handovers(target, budget.tops or (250,) * m, tuple(span)) if budget.stagger else rise[:m]
    last = period - hand[m - 1]     # the last port's handover to the first port's next rise
    if budget.last_in_b:        # the last port's sort, then the first's, after the last port's rise
        need.append(hand[m - 1] + budget.sorts[-1] + budget.sorts[0] + load[-1] + runs(last))
    elif budget.items:      # stagger: a port is sorted before the wait, its items written after it
        # (a window from port j's handover holds its handover and falls, not its rise's edge, which
        # comes before; it ends ENTRY before the first port's next rise, where the handler takes
        # over from the items being written). The first port's handover reads only their header
        # (Budget.head); the rest is read from its first edge on (`first_read`): each chain to the
        # first port's items ends twice, at the header ENTRY before that rise, and whole ENTRY
        # before that rise or before that edge, the rise's entry and handover (`rises`) in between
        after = [ld - rise_edge(budget, j) + ENTRY for j, ld in enumerate(load)]
        first, late = first_read(target, budget), budget.items[0] - (budget.head or budget.items[0])
        def ends(chain: int, window: int) -> tuple[int, int]:     # (the whole before that rise holds
            return (chain - late + runs(window),                   # too, where it comes first)
                    min(chain + runs(window), chain + budget.rises[0] - first + runs(window + first)))

        need += ends(hand[m - 1] + budget.items[0] + after[-1], last)
        if m >= 2:      # the last port's items, once its sort is done and the handler took the port before's
            rest = budget.items[-1] + budget.work + budget.sorts[0]
            falls = after[-2] + load[-1] - together         # the handler's runs from the port before's handover
            if m == 3:      # its sort done by that handover, the chain starts there; else the background is
                # busy from the first port's handover on (`_items_start`'s `before`), each run of the handler
                # in it counted once: the first port's from its handover, the others whole
                net = [sg - it for sg, it in zip(budget.sorts, budget.items)]
                ready = ends(hand[1] + rest + falls, period - hand[1])
                busy = ends(hand[0] + budget.sorts[1] + net[2] + rest + after[0] + load[1] + load[2] - together,
                            period - hand[0])
                chain = tuple(max(r, b) for r, b in zip(ready, busy))
            else:
                chain = ends(min(hand[m - 2] + budget.sorts[-1], _items_start(budget, hand, rise[:m], load, period, runs))
                             + rest + falls, period - hand[m - 2])
            need += chain
    else:
        need.append(hand[m - 1] + budget.sorts[0] + load[-1] + runs(last))
        if m >= 2:
            need.append(hand[m - 2] + budget.sorts[-1] + budget.work + budget.sorts[0] + load[-2] + load[-1]
                        - together + runs(period - hand[m - 2]))
    for j in range(1, m - 1 if budget.last_in_b else m):   # each later port's sort in A fits between the rise before and its own
        room = span[j - 1] - (hand[j - 1] - rise[j - 1]) - (SPLIT - 1 if budget.stagger else 0)
        if (_stagger_need(target, budget, budget.tops or (N_MAX,) * m, span, j) > span[j - 1] if budget.stagger
                else _sort_need(target, budget, j, span[j - 1]) > room):
            raise TooSlow(f"the sort of the port pulsed {j + 1}. ({budget.sorts[j]} machine cycles, and the serial "
                          f"handler's {runs(span[j - 1])}) does not fit between the rise before it and its own")
    return max(need)


def merged_late(target, budget: Budget, runs=lambda cycles: 0) -> int:
    """With the ports at once: the part of the merging that must be done before the next rise. The
    handler reads the items as it goes: the rise's entry only the rise's lines and the first group's
    link (`Budget.head`), each later entry its own group's. So where the rest of the merging, and the
    rise's entry and the serial handler's runs (`runs` of a window) that may come in it, fit in
    C(lowest N any line falls at), the merging begun no later than `head` before the rise is done
    before the frame's first fall; else the whole merging comes before the rise."""
    first = target.width_cycles(min(budget.bottoms or (0,)))
    if budget.merge - budget.head + sum(budget.rises) + runs(first) <= first:
        return budget.head
    return budget.merge


def first_read(target, budget: Budget) -> int:
    """With rises among falls: the cycles from the first port's rise to the earliest edge of its
    list, where the handler reads its items past the header: its lowest fall, less two N for the
    edge with no line a block where a rise comes beside a fall can put first (irq_beside.asm.j2),
    or the next port's rise."""
    low = (budget.bottoms or (0,))[0]
    return min(target.width_cycles(max(0, low - 2)), (budget.spans or (1 << 16,))[0])


def rise_edge(budget: Budget, j: int) -> int:
    """With rises among falls: the part of port j's rise entry (`Budget.rises`) that comes before its
    handover: the rise's edge, its entry and exit (SPLIT - 1), and the edge with no line before a
    rise beside a fall (`beside_extra`). The rise is an edge of the port before's list, so it comes
    at or before that list's last edge, after which the handover runs (`Budget.emits`, the rest)."""
    return budget.rises[j] - (budget.emits[j] - ENTRY)


def _items_start(budget: Budget, hand: list[int], rise: list[int], load: list[int], period: int, runs) -> int:
    """Stagger: when the last port's items are written at the latest: once the handler took the
    port before's (its handover) and its sort is done. That sort follows the items of the port
    before, which wait for the handover of the port before that one (`before`: hand[m - 3], the
    first port's rise; with two ports, the last port's handover in the frame before) and are
    written before their own handover: so it is done by `before`, the two sorts and the items
    between, the handler's load of every port that rises by then (with two ports, and the last
    port's of the frame before; the last port's span holds its falls, so with three they are
    over by the first port's rise) and the serial handler's runs."""
    m = len(hand)
    before = hand[m - 3] if m >= 3 else hand[m - 1] - period
    net = [s - i for s, i in zip(budget.sorts, budget.items)]
    busy = net[m - 2] + budget.items[m - 2] + net[m - 1] + (load[m - 1] if m == 2 else 0)
    done = before + busy
    for _ in range(64):     # each pass adds a port's load or the serial handler's runs in more time
        more = before + busy + sum(ld for r, ld in zip(rise, load) if r < done) + runs(done - before)
        if more <= done:
            return max(hand[m - 2], done)
        done = more
    return max(hand[m - 2], before + busy + sum(load) + runs(1 << 16))


class TooSlow(Exception):
    """The code cannot hold the engine's timing at any frame period."""


# ---------------------------------------------------------------- the serial line (serial.asm.j2)
QUEUE = 4                       # bytes each of the receive and the transmit queue holds
SERIAL_RAM = 2 * QUEUE + 6      # the queues (the receive ring has a slot more), their four counters and
                                # RXB: taken from the stack
SERIAL_STACK = 5                # the serial handler: its LCALL, PSW, ACC, R0 (the edge handler may come on top)
# Before a pending serial interrupt is taken: the instruction under way (at most 4 cycles,
# MUL or DIV; or the one that always follows a RETI). Its vector's LCALL is in serial_head.
SERIAL_WAIT = 4


def busy_stretch(target, budget: Budget) -> int:
    """The longest time the edge handler (of high priority) can keep the CPU from the serial
    handler: one port's lines, each an entry of at most SPLIT cycles (or a step shorter than it),
    ending just before the next port's rise, and that rise's entry; when the gap the rise leaves
    before the earliest fall is too short for the serial handler to take a byte (`serial_gap`),
    that port's lines as well. Where a port's span leaves that gap after its longest pulse's exit,
    before the next port's rise, its lines and that rise are apart."""
    m = len(budget.lines)
    c0 = target.width_cycles(0)
    need = serial_gap(budget)
    if budget.merged:       # at most everything the handler does in a frame: the rise, every group, the last's exit
        return sum(budget.rises) + sum(budget.falls) + budget.tail
    if budget.stagger:
        return _stagger_stretch(target, budget, need)
    worst = 0
    for k in range(m):
        nxt = (k + 1) % m
        rise = budget.rises[nxt] - (0 if rise_may_step(target, budget, k) else RISE_HEAD - ENTRY - 2)
        if c0 - rise < need:
            rise += c0 - rise + SPLIT * budget.lines[nxt]
        chain = SPLIT * budget.lines[k]
        worst = max(worst, chain, rise) if span_slack(target, budget, k) + 1 >= need else max(worst, chain + rise)
    return worst


def _stagger_stretch(target, budget: Budget, need: int) -> int:
    """`busy_stretch` where each port's rise comes among the falls of the port before it: that
    port's lines and the rise, each an entry of at most SPLIT cycles (or a step shorter than it),
    then the handover; each span leaves `need` cycles after it before the next port's earliest
    fall's entry (`_stagger_spans`), and the last port's handover, right after the first port's
    rise, its earliest fall less its run. Where that is shorter than `need`, no bound: the build is
    refused (serial-too-fast) and the ports are pulsed one after another."""
    m = len(budget.lines)
    low = budget.bottoms or (0,) * m
    worst = 0
    for k in range(m):
        n = (k + 1) % m
        first = target.width_cycles(low[n])      # the next port's earliest fall, after its rise
        after = (budget.spans[k] + first - target.width_cycles(budget.tops[k]) if k < m - 1 and budget.spans
                 else first) - budget.emits[n]
        if after < need:
            return 1 << 20
        worst = max(worst, SPLIT * (budget.lines[k] + 1) + beside_extra(target) + budget.emits[n] - ENTRY)
    return worst


def rise_may_step(target, budget: Budget, k: int) -> bool:
    """Whether the rise after port k's span can be a step of its last fall's entry (RISE_STEP): it
    cannot where the span leaves SPLIT cycles or more after its longest pulse (the rise is then an
    entry of its own, and after its edge the handler runs RISE_HEAD - ENTRY - 2 cycles less)."""
    return budget.steps and (not (budget.spans and budget.tops) or span_slack(target, budget, k) < 0)


def serial_gap(budget: Budget) -> int:
    """The time between two runs of the edge handler in which the serial handler surely takes a
    byte: the instruction under way, a run for TI under way (when the program sends), its head."""
    return SERIAL_WAIT + (budget.serial_run if budget.serial_sends else 0) + budget.serial_head


def span_slack(target, budget: Budget, k: int) -> int:
    """Cycles port k's span has beyond its longest pulse and an entry (below 0: the next rise can be a
    step of the last fall's entry; 0 where not known)."""
    if not budget.spans or not budget.tops:
        return 0
    return budget.spans[k] - apart_span(target, budget.tops[k])


def serial_latency(target, budget: Budget) -> int:
    """The longest from a byte's RI to the serial handler's `CLR RI`: the edge handler's longest
    stretch, the instruction under way, a run of the serial handler for TI under way (when the
    program sends), then its head. No byte is lost while this is within `rx_gap` (the next byte
    can complete no sooner, from a host up to 2 % fast)."""
    return (busy_stretch(target, budget) + SERIAL_WAIT + (budget.serial_run if budget.serial_sends else 0)
            + budget.serial_head)


HOST_FAST = 2                   # % a host's rate may be above the chip's (the tolerance `serial` allows)
START_JITTER = 16               # the UART finds a start bit within 1/16 of a bit


def rx_gap(byte_cycles: int) -> int:
    """The least time between two received bytes' ends, in machine cycles: a byte time of a host up
    to HOST_FAST % fast, less the UART's start-bit jitter (a bit is a tenth of a byte)."""
    return (byte_cycles * (100 - HOST_FAST)) // 100 - -(-byte_cycles // (10 * START_JITTER))


def serial_load(target, budget: Budget, cycles: int) -> int:
    """The serial handler's cycles within `cycles` at the most: a run for each byte that can come
    in and, if the program sends, each TI, and the instruction each run waits for. Received bytes
    end `rx_gap` apart at the least (a host may be fast), and a run starts within that of its byte
    (serial_latency), so a window of c cycles meets ceil(c / gap) + 1 receive runs; fewer when a
    byte's run surely ends sooner (`run_reach`): then only the bytes that end in the c + reach
    cycles before the window's end have a run in it. TI comes a byte time apart from the chip's
    own UART, and once more from `send_byte` when the line rests (SETB TI, right after a TI run
    may have found the queue empty): ceil(c / byte) + 2 runs."""
    gap = rx_gap(budget.byte_cycles)
    each = -(-cycles // gap) + 1
    reach = run_reach(target, budget)
    if reach is not None:
        each = min(each, -(-(cycles + reach) // gap))
    sent = -(-cycles // budget.byte_cycles) + 2 if budget.serial_sends else 0
    return (each + sent) * (budget.serial_run + SERIAL_WAIT)


def run_reach(target, budget: Budget) -> int | None:
    """The longest from a byte's RI to the end of its run: the edge handler's longest stretch, the
    instruction under way, a TI run under way (when the program sends), and the run. That holds
    when the gap each rise leaves before the earliest fall takes the rest of the run (whatever
    runs between the entries before it only shortens what is left); None when it may not."""
    rest = SERIAL_WAIT + (budget.serial_run if budget.serial_sends else 0) + budget.serial_run
    if any(target.width_cycles(0) - rise < rest for rise in budget.rises):
        return None
    return busy_stretch(target, budget) + rest


def default_period_us(min_period: int) -> int:
    """The spec's default P: the shortest sustainable period, never below 5.3 ms."""
    return max(DEFAULT_PERIOD_FLOOR_US, min_period)


# The stack: with three ports, 46 bytes from the end of the direct variables (0x72,
# with 24 servos) up to the motion state at 0xA0; each port fewer leaves PORT_RAM more
# (its CUR and STATE are not laid out: `stack_room`). Each `repeat` keeps its
# pass counter there and each `play` its return address (2 bytes a level);
# the runtime goes at most RUNTIME_STACK bytes deeper below a program call (frame_io's
# 4 under run_list's 4), WATCH_STACK more with a meanwhile body (frame_w calls a look,
# 2, which calls rx_want, 2, which calls rx_named, 3: 9 where frame_io takes 4), and
# the edge handler, which may come at any instruction, HANDLER_STACK more. The selects'
# RAM (plan.select_ram) and the serial line's are taken from the stack's 46 bytes. Code
# generation reads the runtime's depth from the code (codegen.runtime_stack) and
# holds it to these figures. `stack_room` is what `too-deep` promises for the program's
# ports, whatever else it uses (with `host`, the RAM allocated decides instead: flow.host_short); the firmware itself starts the stack where the RAM it
# allocates ends (no eased moves, no `send`: fewer variables), so most programs have more.
STACK_BYTES = 46
PORT_RAM = 40               # CUR (8) and STATE (32) of one port: RAM a port not in use leaves to the stack
XSTATE_RAM = 32             # STATE of one port: internal RAM it leaves to the stack where it is kept in
                            # XRAM (flow.host_xram)
BUFB_RAM = 17               # sort buffer B (8 pairs of N and lines) and its rise mask: the top of the
                            # stack's bytes, taken only where the program's stack leaves that much room
RUNTIME_STACK = 8
WATCH_STACK = 5
WRAP_STACK = 2              # frame_h's call of frame_w (host.asm.j2)
HANDLER_STACK = 8           # LCALL, PSW, ACC, DPL, DPH, and its own LCALL


def runtime_stack(watch: bool = False, wrapped: bool = False) -> int:
    """Bytes the runtime may put on the stack below a program's call (`watch`: a meanwhile body,
    or `host`; `wrapped`: both, frame_h calling frame_w: flow.frame_wrapped)."""
    return RUNTIME_STACK + (WATCH_STACK if watch else 0) + (WRAP_STACK if wrapped else 0)


def stack_room(serial: bool = False, taken: int = 0, ports: int = 3, xram: bool = False) -> int:
    """Bytes of stack with `ports` ports of servos in use: 46 with three, PORT_RAM more for each
    port fewer; the serial line's queues and counters take SERIAL_RAM of them, the selects
    `taken` more (plan.select_ram). `xram`: the motion state is in XRAM (flow.host_xram),
    XSTATE_RAM more for each port in use."""
    return (STACK_BYTES + PORT_RAM * (3 - ports) + (XSTATE_RAM * ports if xram else 0)
            - (SERIAL_RAM if serial else 0) - taken)


def stack_bytes(nesting: int, serial: bool = False, watch: bool = False, wrapped: bool = False) -> int:
    """Stack bytes a program with `nesting` levels of repeat/play needs."""
    return 2 * nesting + runtime_stack(watch, wrapped) + HANDLER_STACK + (SERIAL_STACK if serial else 0)


def max_nesting(serial: bool = False, watch: bool = False, taken: int = 0, ports: int = 3, wrapped: bool = False,
                xram: bool = False) -> int:
    return (stack_room(serial, taken, ports, xram) - runtime_stack(watch, wrapped) - HANDLER_STACK
            - (SERIAL_STACK if serial else 0)) // 2
