"""What the firmware did, observed in the simulator: Firmware -> Probes, SimTrace -> Observation.

`servoc verify` does not guess which branch a select took from the pulses: it sets probes (ucsim
breakpoints that print the cycle and some RAM bytes, then run on) at the code addresses of each
select, found in the assembler's listing:

- `selN`, where the select is reached;
- `selN_ev`, where each of its looks begins (the receive queue's counters and bytes are read
  there), and every `RET` of that look routine, where it ends (with what it decided: the
  instruction before the `RET` loads A with 1 + the branch, or clears it);
- `selN_bK`, the first instruction of branch K;
- in the serial handler, `ui_got` (a byte was just taken from SBUF: the byte and the queue's
  counters) and `ui_drop` (it was queued, or not: the counters again);
- with `host`: `host_run` (a run of the statement begins), `hr_frame` (each frame's reading
  begins) and `hb_in`, `hb_chr`, `hb_eol`, `hb_hash` and `hb_ans` (the parser reads a byte: the
  byte).

`observe` turns the probes of a run into `Observation`: every select reached, in order (`Visit`),
with each look's window of cycles and the queue it saw, and the branch it took; and every byte
the serial handler received, with whether it was queued. `verify` then checks these against the
rules, and uses the branches taken to lay out the plan of the run.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from .sim import SimTrace

REACH, LOOK, EXIT, BRANCH, RX_GOT, RX_END = "reach", "look", "exit", "branch", "rx_got", "rx_end"
HOST_START, HOST_FRAME, HOST_BYTE, HOST_END = "host_start", "host_frame", "host_byte", "host_end"
PLAY_FRAME, PLAY_END = "play_frame", "play_end"      # the same, while a sequence `PL` started plays
PLAY_START, PLAY_CUT = "play_start", "play_cut"      # a sequence `PL` started begins; the host ends it
LISTEN = "listen"               # the UART's receiver is on (serial_init, `serial_on`)
HOST_BYTE_RAM = 0x02            # bank 0 R2: the byte host_byte is reading (`hb_in`)

# A listing line (sdas8051 -l, relocated .rst): address in columns 6..11, the source line's number
# in 34..38, the source from 40.
_LABEL = re.compile(r"^([A-Za-z_]\w*)::?\s*(.*)$")
_EQU = re.compile(r"^(RXQ|RXR|RXW|RXB|HLINE|TXW|TXR|HPLAY)\s*=\s*0x([0-9A-Fa-f]+)", re.M)
_QUEUE = re.compile(r"The receive ring: (\d+) slots at RXQ")


class ProbeError(Exception):
    """The firmware cannot be observed: its listing lacks what the probes need."""


@dataclass(frozen=True)
class Probes:
    """Where to probe a firmware and what each probe means."""
    points: tuple[tuple[int, int, tuple[int, ...]], ...]   # (address, tag, RAM bytes to read) for sim.run
    meaning: dict[int, list[tuple[str, str, int | None]]]  # tag -> what reaching it means, in order:
                                                           # (kind, select label, branch or outcome)
    selects: dict[str, object]                             # label -> its SelectStep
    queue: int = 0                                         # the receive ring's slots (0: no serial line)
    ring: int = 0                                          # its first slot's address (RXR, RXW name slots)
    code: dict[int, bytes] = field(default_factory=dict)   # address -> the code bytes there, to check a HEX


def listing_lines(listing: str):
    """(address or None, source text without comment) of each source line of a listing."""
    for line in listing.splitlines():
        head, src = line[:39], line[40:]
        if not head[34:39].strip().isdigit():
            continue
        addr = head[6:12].strip()
        code_bytes = bytes.fromhex("".join(head[13:30].split("[")[0].split())) if addr else b""
        yield (int(addr, 16) if addr else None), src.split(";", 1)[0].strip(), code_bytes


def probes_for(listing: str, asm_text: str, selects: tuple) -> Probes:
    """The probes of a firmware from its listing and assembly text; `selects`: (label, SelectStep)
    of `codegen.AsmUnit.selects`."""
    labels: dict[str, int] = {}
    order: list[tuple[str, int]] = []          # labels in listing order
    rets: dict[str, list[tuple[int, int | None]]] = {}
    code: dict[int, bytes] = {}
    current = None                             # the select label whose look routine we are in
    before = ""                                # the instruction before, in that routine
    names = {lab for lab, _ in selects}
    for addr, text, raw in listing_lines(listing):
        m = _LABEL.match(text)
        if m and addr is not None:
            lab = m.group(1)
            labels[lab] = addr
            order.append((lab, addr))
            text = m.group(2)
            if lab.endswith("_ev") and lab[:-3] in names:
                current, before = lab[:-3], ""
            elif current is not None and not lab.startswith(current + "_"):
                current = None
        if addr is not None and raw:
            code[addr] = raw
        if not text or current is None:
            continue
        op = text.split(None, 1)
        if op[0].upper() == "RET":
            k = None
            mv = re.match(r"MOV\s+A\s*,\s*#(0x[0-9A-Fa-f]+|\d+)$", before, re.I)
            if mv:
                k = int(mv.group(1), 0) - 1
            elif not re.match(r"CLR\s+A$", before, re.I):
                raise ProbeError(f"the look of {current} returns after `{before}`: cannot tell what it decided")
            rets.setdefault(current, []).append((addr, k))
        before = " ".join(text.split())
    equ = {name: int(v, 16) for name, v in _EQU.findall(asm_text)}
    queue = 0
    if "RXQ" in equ:
        q = _QUEUE.search(asm_text)
        if q is None or not {"RXR", "RXW", "RXB"} <= equ.keys():
            raise ProbeError("the serial line's RAM is not named in the assembly")
        queue = int(q.group(1))
    rx_state = (equ["RXR"], equ["RXW"]) if queue else ()
    look_ram = rx_state + tuple(equ["RXQ"] + i for i in range(queue)) if queue else ()
    if queue and "HPLAY" in equ:        # then whether a sequence `PL` started plays (its bytes are the host's)
        look_ram += (equ["HPLAY"],)
    points: list[tuple[int, int, tuple[int, ...]]] = []
    meaning: dict[int, list[tuple[str, str, int | None]]] = {}
    at: dict[int, int] = {}                    # address -> its tag: a branch whose body begins with
                                               # a select shares its first address with that select

    def add(address: int, kind: str, label: str, k: int | None, ram: tuple[int, ...]) -> None:
        if address in at:
            tag = at[address]
            if points[tag - 1][2] != ram:
                raise ProbeError(f"two probes at {address:#06x} read different RAM")
            meaning[tag].append((kind, label, k))
            return
        tag = at[address] = len(points) + 1
        points.append((address, tag, ram))
        meaning[tag] = [(kind, label, k)]

    by_label = {}
    for lab, st in selects:
        by_label[lab] = st
        need = [lab, f"{lab}_ev"] + [f"{lab}_b{k}" for k in range(len(st.branches))]
        missing = [n for n in need if n not in labels]
        if missing or not rets.get(lab):
            raise ProbeError(f"the listing has no {', '.join(missing) or lab + ' look return'}")
        add(labels[lab], REACH, lab, None, ())
        add(labels[f"{lab}_ev"], LOOK, lab, None, look_ram)
        for address, k in rets[lab]:
            add(address, EXIT, lab, k, rx_state)
        for k in range(len(st.branches)):
            add(labels[f"{lab}_b{k}"], BRANCH, lab, k, ())
    if "host_run" in labels:
        if not {"HLINE", "TXW", "TXR"} <= equ.keys():
            raise ProbeError("the host's RAM is not named in the assembly")
        ram = {HOST_BYTE: (HOST_BYTE_RAM,), HOST_FRAME: rx_state, HOST_START: (), PLAY_FRAME: rx_state,
               HOST_END: rx_state + (equ["HLINE"], equ["TXW"], equ["TXR"]), PLAY_START: (), PLAY_CUT: ()}
        ram[PLAY_END] = ram[HOST_END]
        # built for size, the reading while a sequence `PL` started plays is host_read itself: its
        # end tells the two apart by HPLAY (0 but while such a sequence plays)
        shared = "play_read" in labels and labels["play_read"] == labels.get("host_read")
        if shared:
            ram[HOST_END] += (equ["HPLAY"],)
        for lab, kind in (("host_run", HOST_START), ("host_read", HOST_FRAME), ("hb_in", HOST_BYTE),
                          ("hb_chr", HOST_BYTE), ("hb_eol", HOST_BYTE), ("hb_hash", HOST_BYTE), ("hb_ans", HOST_BYTE),
                          ("hp_end", HOST_END), ("play_read", PLAY_FRAME), ("pr_end", PLAY_END),
                          ("host_plays", PLAY_START), ("pc_go", PLAY_CUT)):
            if shared and kind in (PLAY_FRAME, PLAY_END):
                continue
            if lab in labels:
                add(labels[lab], kind, "", None, ram[kind])
            elif not lab.startswith(("play", "pr_", "host_plays", "pc_", "hb_hash", "hb_ans")):  # only with
                                                                                # sequences, holds, read-on
                raise ProbeError(f"the listing has no {lab}")
    if queue and "serial_on" in labels:
        add(labels["serial_on"], LISTEN, "", None, ())
    if queue:
        for lab in ("ui_got", "ui_drop"):
            if lab not in labels:
                raise ProbeError(f"the listing has no {lab}")
        add(labels["ui_got"], RX_GOT, "", None, (equ["RXB"],) + rx_state)
        add(labels["ui_drop"], RX_END, "", None, rx_state)
    for tag in meaning:                        # at one address, a branch is entered before a select in it is reached
        meaning[tag].sort(key=lambda m: (m[0] == REACH))
    return Probes(tuple(points), meaning, by_label, queue, equ.get("RXQ", 0),
                  {a: code[a] for a, _, _ in points if a in code})


def hex_matches(probes: Probes, hex_text: str) -> bool:
    """Whether a HEX image has, at every probed address, the code the probes were made for."""
    from intelhex import IntelHex
    import io
    ih = IntelHex(io.StringIO(hex_text))
    return all(bytes(ih[a + i] for i in range(len(raw))) == raw for a, raw in probes.code.items())


# ----------------------------------------------------------------- what the probes saw

@dataclass
class Look:
    """One look of a select: it began at `entry` and ended at `exit` (cycles), deciding `outcome`
    (the branch's index, or None: wait on). `queue`: the bytes queued as it began, oldest first;
    `rxr`/`rxw`: the queue's counters as it began (absolute: they do not wrap here), `rxr_after`
    as it ended."""
    entry: int
    queue: tuple[int, ...] = ()
    rxr: int = 0
    rxw: int = 0
    exit: int | None = None
    outcome: int | None = None
    playing: bool = False       # a sequence `PL` started plays: the bytes queued are the host's
    rxr_after: int = 0


@dataclass
class Visit:
    """A select reached: its label and step, the cycle, its looks, and the branch taken (None: it
    still waited when the run ended) with the cycle of the branch's first instruction."""
    label: str
    select: object
    reached: int
    looks: list[Look] = field(default_factory=list)
    branch: int | None = None
    taken: int | None = None
    cut: bool = False           # it waited in a meanwhile body that a select around it cut short


@dataclass(frozen=True)
class Received:
    """A byte the serial handler took from SBUF at `cycle`, with the queue's length then, and
    whether it queued it."""
    cycle: int
    byte: int
    queued_before: int
    queued: bool


@dataclass
class HostVisit:
    """A run of a `host` statement: the cycle it began, and per frame's reading (the cycle it began,
    the receive queue's read counter then, absolute) the bytes the parser read, in order; and per
    reading that ended, why it may have stopped (`Ended`). The readings while a sequence `PL`
    started plays are among them (`Ended.playing`)."""
    start: int
    frames: list[tuple[int, int, list[int]]] = field(default_factory=list)
    ends: list["Ended"] = field(default_factory=list)


@dataclass(frozen=True)
class Ended:
    """A frame's reading ended: the bytes queued as it began, those still queued from them, the
    lines host_step must carry out (HLINE: nonzero stops the reading), the answers waiting to be
    sent (4: the transmit queue is full)."""
    queued: int
    left: int
    hline: int
    answers: int
    playing: bool = False


@dataclass(frozen=True)
class Observation:
    visits: tuple[Visit, ...]
    received: tuple[Received, ...]
    problems: tuple[str, ...] = ()       # probes out of order: the firmware went where no select is
    hosts: tuple[HostVisit, ...] = ()
    listening: int | None = None         # the cycle from which the UART receives (None: not seen)


class _Counter:
    """Counts the slots a pointer into the receive ring has moved on (by less than a turn of the
    ring between two reads): the bytes put in (RXW) or taken out (RXR) since the reset."""

    def __init__(self, slots: int, base: int) -> None:
        self.value, self.slots, self.base = 0, max(1, slots), base

    def __call__(self, raw: int) -> int:
        self.value += (raw - self.base - self.value) % self.slots
        return self.value


def observe(probes: Probes, trace: SimTrace) -> Observation:
    visits: list[Visit] = []
    active: dict[str, Visit] = {}
    received: list[Received] = []
    problems: list[str] = []
    rxr, rxw = _Counter(probes.queue, probes.ring), _Counter(probes.queue, probes.ring)
    pending = None
    hosts: list[HostVisit] = []
    host_queued = 0
    played_from = None          # the cycle the sequence `PL` started last began
    listening = None
    for p, (kind, label, k) in ((p, m) for p in trace.probes for m in probes.meaning[p.tag]):
        if kind == REACH:
            if label in active:
                problems.append(f"the select {label} was reached again at cycle {p.cycle} while it waited")
            visit = Visit(label, probes.selects[label], p.cycle)
            visits.append(visit)
            active[label] = visit
        elif kind == LOOK:
            visit = active.get(label)
            if visit is None:
                problems.append(f"a look of {label} at cycle {p.cycle} with the select not reached")
                continue
            r = w = 0
            queued: tuple[int, ...] = ()
            if p.ram:
                r, w = rxr(p.ram[0]), rxw(p.ram[1])
                queued = tuple(p.ram[2 + ((r + i) % probes.queue)] for i in range(w - r))
            visit.looks.append(Look(p.cycle, queued, r, w,
                                    playing=len(p.ram) > 2 + probes.queue and p.ram[2 + probes.queue] != 0))
        elif kind == EXIT:
            visit = active.get(label)
            if visit is None or not visit.looks or visit.looks[-1].exit is not None:
                problems.append(f"a look of {label} ended at cycle {p.cycle} without beginning")
                continue
            look = visit.looks[-1]
            look.exit, look.outcome = p.cycle, k
            if p.ram:
                look.rxr_after = rxr(p.ram[0])
                rxw(p.ram[1])
        elif kind == BRANCH:
            visit = active.pop(label, None)
            if visit is None:
                problems.append(f"branch {k} of {label} entered at cycle {p.cycle} with the select not waiting")
                continue
            visit.branch, visit.taken = k, p.cycle
            for other in [v for v in active.values() if v.reached > visit.reached]:
                other.cut = True            # in its meanwhile body, which the branch cut short
                del active[other.label]
        elif kind == RX_GOT:
            pending = (p.cycle, p.ram[0], (p.ram[2] - p.ram[1]) % probes.queue, p.ram[2])
        elif kind == RX_END and pending is not None:
            received.append(Received(pending[0], pending[1], pending[2], p.ram[1] != pending[3]))
            rxw(p.ram[1])
            pending = None
        elif kind == LISTEN:
            listening = p.cycle
        elif kind == HOST_START:
            hosts.append(HostVisit(p.cycle))
        elif kind == PLAY_START:
            played_from = p.cycle
        elif kind == PLAY_CUT and played_from is not None:
            for other in [v for v in active.values() if v.reached > played_from]:
                other.cut = True            # waiting in the sequence the host ended (STOP, a group or PL line)
                del active[other.label]
        elif kind in (HOST_FRAME, PLAY_FRAME):
            if not hosts:
                problems.append(f"the host's reading began at cycle {p.cycle} with no `host` running")
                continue
            r = rxr(p.ram[0]) if p.ram else 0
            w = rxw(p.ram[1]) if p.ram else 0
            hosts[-1].frames.append((p.cycle, r, []))
            host_queued = w - r
        elif kind in (HOST_END, PLAY_END):
            if not hosts or not hosts[-1].frames:
                continue
            r = rxr(p.ram[0])
            rxw(p.ram[1])
            read = len(hosts[-1].frames[-1][2])
            hosts[-1].ends.append(Ended(host_queued, max(0, host_queued - read), p.ram[2], (p.ram[3] - p.ram[4]) & 0xFF,
                                        kind == PLAY_END or (len(p.ram) > 5 and p.ram[5] != 0)))
        elif kind == HOST_BYTE:
            if not hosts or not hosts[-1].frames:
                problems.append(f"the host parser read a byte at cycle {p.cycle} outside a frame's reading")
                continue
            hosts[-1].frames[-1][2].append(p.ram[0])
    return Observation(tuple(visits), tuple(received), tuple(problems), tuple(hosts), listening)
