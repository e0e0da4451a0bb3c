"""The firmware's layout: RAM map, record format and encoder, and how an image fits the chip.

Code generation and the templates take every address, flag and record byte
from here, and `api.assemble` reads the fit report from here, so each fact
about the firmware's memory is stated once.

RAM (AT89C52, 256 bytes):
    0x00-0x07  register bank 0 (the program and the runtime)
    0x08-0x0F  register bank 1 (the edge handler's)
    0x10-0x1F  sort buffer A: a port's N and lines in pairs, then its distinct N, for the handler
    0x20-0x2C  bit-addressable per-port masks (ACT, MOVB, DIRB, RMASK) and FLAGS
    0x2D-0x2F  F of the current move
    0x30-      CUR: the current N of pin p at CUR_BASE + p, 8 bytes for each port in use
               (p = 8 x the port's place among the ports in use + bit: `ram_pin`)
    then       direct variables (those the program uses), then the buffers reached only
               through @R0/@R1 (the handler's items, the transmit queue, the receive ring),
               allocated in order
    then       the stack, growing up from where they end to STATE: at least
               `costs.stack_room` (46 bytes with three ports, 40 more for each port fewer)
               less the serial line's and the selects' RAM; with three ports, where the
               program's stack leaves room, sort buffer B and its rise mask the last 17
    STATE-0xFF STATE: 4 bytes of motion state per pin at STATE + 4 p, 32 for each port in use
               (0xA0 with three ports; indirect only)

XRAM (page 0, MOVX @DPTR; only where flow.host_xram: `host` on an STC89 short of internal RAM):
    0x00-      the host's per-servo arrays HPW, HPS, HOF (5 bytes a servo)
    STATE-0xFF the motion state, at the addresses it has in internal RAM otherwise (`state_at`),
               which then keeps none: the stack reaches 0xFF

A record list is a run of move and hold records in code memory; each record
starts with a flags byte (RECORD_FLAGS) and a flags byte with ENDF ends the list.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from . import costs

RAM_SIZE = 256
HANDLER_BANK = 0x08             # register bank 1: the edge handler's
SORT_BASE = 0x10                # sort buffer A: 8 pairs (N, lines)
SORT_PAIR = 2                   # bytes of a pair: pair i at +2i, its N first
CUR_BASE = 0x30                 # current N per pin
STATE_BYTES = 4
STATE_BASE = RAM_SIZE - 24 * STATE_BYTES     # motion state, 4 bytes per pin, with three ports: 0xA0..0xFF
BUFB_BASE = STATE_BASE - 16     # sort buffer B (three ports, where the stack has room): 16 bytes
                                # at the top of the stack's room, its rise mask below; like A at
                                # 0x10 mod 0x20, so that bit 4 of a pointer just past either is clear
assert SORT_BASE % 0x20 == BUFB_BASE % 0x20 == 0x10
DIRECT_LIMIT = 0x80             # above it, RAM is reached only through @R0/@R1 (direct 0x80.. are the SFRs)
WORK_BASE = CUR_BASE + 24       # variables after CUR, with three ports


def state_at(ports: int) -> int:
    """Where the motion state starts with `ports` ports in use (8 pins each): in internal RAM, or
    at the same address of XRAM page 0 where `host` keeps its state there (flow.host_xram)."""
    return RAM_SIZE - 8 * ports * STATE_BYTES


HOLD_BYTES = 6          # a held entry in XRAM (host_xram): its line's generation, its servo, its S (2), its width or offset (2)
HOLDS_MOST = 3          # the entries held in one frame at the most, in XRAM (host_holds)


def hold_bytes(xram: bool) -> int:
    """The bytes of one hold (`host_holds`; in internal RAM `flow.HOLD_BYTES_IRAM`)."""
    from .flow import HOLD_BYTES_IRAM
    return HOLD_BYTES if xram else HOLD_BYTES_IRAM


def host_holds(plan, xram: bool | None = None) -> int:
    """The entries a frame can hold with `host`, K (`xram` given: as if the host's state were in
    XRAM, `host_xram`, or not): while a group waits, an entry that a '#' ends is held rather than
    written over the group's before its line is known to be good, until the commit (its line
    joined the group: before the group's entries are converted; its line still being read:
    after). In XRAM, where each entry keeps its line's generation, only those for a servo the
    group names are held (HOLD_BYTES, between the host's arrays and the motion state): HOLDS_MOST,
    or what XRAM page 0 has room for (2 at least: 16 bytes with 24 servos). In internal RAM, every
    one is held, and while any is, so is a line's last entry, at its end (`flow.iram_holds`:
    where a frame brings more bytes than the shortest line of two entries). 0 in a build that
    fits the chip's internal RAM or, built for size, its code memory only without them
    (`Plan.holds`, `api.choose_period`). Once the K are taken, the
    reading stops before a '#' that ends an open entry (in internal RAM also before the end of
    a line of entries)."""
    from .flow import HOST_XRAM_PER_SERVO, hosted, host_xram, iram_holds
    if not (hosted(plan) and plan.holds):
        return 0
    if xram is None:
        xram = host_xram(plan)
    if not xram:
        return iram_holds(plan)
    room = state_at(len(plan.ports)) - HOST_XRAM_PER_SERVO * len(plan.channels)
    return min(HOLDS_MOST, room // HOLD_BYTES)


def host_extras(plan) -> bool:
    """Whether the build has code that `Plan.holds` False leaves out: the holds (`host_holds`) or
    the reading on through answer lines after a group line (`flow.reads_answers`)."""
    from .flow import reads_answers
    return bool(host_holds(plan)) or reads_answers(plan)


def state_base(ports: int, xram: bool = False) -> int:
    """Where the motion state starts in internal RAM (the stack ends there): RAM_SIZE, none,
    where it is kept in XRAM (`xram`)."""
    return RAM_SIZE if xram else state_at(ports)


def work_base(ports: int) -> int:
    """Where the variables start, after CUR, with `ports` ports in use."""
    return CUR_BASE + 8 * ports


def ram_pin(ports: tuple[int, ...], port: int, bit: int) -> int:
    """A pin's index p in CUR and STATE: 8 x its port's place among the ports in use, + bit."""
    return 8 * ports.index(port) + bit

# Bit-addressable bytes: (name, address, what). A pin's bit address is (byte - 0x20) x 8 + pin.
MASK_BYTES = (
    ("ACT", 0x20, "per port: lines that have a target (the rise mask); bit address = pin"),
    ("MOVB", 0x23, "per port: lines moving in the current move; bit address 0x18 + pin"),
    ("DIRB", 0x26, "per port: lines moving down; bit address 0x30 + pin"),
    ("RMASK", 0x29, "per port: lines the current record names; bit address 0x48 + pin"),
    ("FLAGS", 0x2C, "move flags, bits below"),
)
ADDR = {name: addr for name, addr, _ in MASK_BYTES}


def bit_address(byte: int, bit: int) -> int:
    return (byte - 0x20) * 8 + bit


@dataclass(frozen=True)
class Flag:
    name: str
    bit: int
    what: str
    in_record: bool = True      # False: the runtime's own bit, records leave it 0

    @property
    def value(self) -> int:
        return 1 << self.bit


RECORD_FLAGS = (
    Flag("EASED", 0, "the current move is eased"),
    Flag("NODUR", 1, "F is found at run time"),
    Flag("LASTF", 2, "this is the move's last frame", in_record=False),
    Flag("DIRF", 3, "the pin being stepped moves down", in_record=False),
    Flag("F8", 4, "the record's F is one byte"),
    Flag("ALLF", 5, "the move names every servo: no masks"),
    Flag("HOLDF", 6, "the record is a hold"),
    Flag("ENDF", 7, "the end of a record list"),
)
FLAG = {f.name: f.value for f in RECORD_FLAGS}


def flag_equates() -> list[tuple[str, int, str]]:
    """(name, bit address in FLAGS, what) for the template's equates."""
    return [(f.name, bit_address(ADDR["FLAGS"], f.bit), f"FLAGS.{f.bit}: {f.what}") for f in RECORD_FLAGS]


@dataclass(frozen=True)
class Bit:
    """A bit of a flags byte the firmware keeps: its name, number and meaning."""
    name: str
    bit: int
    what: str

    @property
    def mask(self) -> int:
        return 1 << self.bit

    @property
    def clear(self) -> int:
        """The AND mask that clears it."""
        return 0xFF ^ self.mask


# HLINE (host.asm.j2): the lines the host parser has read that host_step (or frame_h) must carry
# out; verify reads it at the end of each frame's reading.
HLINE_BITS = (
    Bit("GROUP", 0, "a group to commit (SEGF: its T)"),
    Bit("ANSQ", 1, "answers waiting: VER's being queued, or some in HAQ (the reading goes on)"),
    Bit("OFFS", 2, "offsets to set"),
    Bit("PLAY", 3, "a sequence to play (PL 0 SQ n)"),
    Bit("HANS", 4, "the answers waiting for room in the transmit queue fill HAQ"),
    Bit("STOP", 5, "STOP read while a sequence `PL` started plays"),
    Bit("VERQ", 6, "VER's answer being queued (the reading goes on)"),
    Bit("DROP", 7, "a line dropped while a group waits: the reading stops until the group is committed"),
)
HLINE = {b.name: b for b in HLINE_BITS}


# ----------------------------------------------------------------- errors

class LayoutError(Exception):
    """A valid program that does not fit the firmware's resources: a code and a help line (the
    class's, unless the message comes with a help of its own)."""
    code = "resources"
    help = "simplify the program"

    def __init__(self, message: str, help: str | None = None, span=None, labels: tuple = ()):
        super().__init__(message)
        if help is not None:
            self.help = help
        self.span = span            # where in the program (None: `main`)
        self.labels = labels        # (span, text) of the other places it comes from


class Several(LayoutError):
    """More than one limit, each said (`errors`): the first one's code, message and place. Only
    the serial line's limits come together (serial-too-fast, send-overrun)."""
    code = "serial-too-fast"

    def __init__(self, errors: list[LayoutError]):
        first = errors[0]
        super().__init__(str(first), first.help, first.span, first.labels)
        self.code = first.code
        self.errors = errors


def each(exc: LayoutError) -> list[LayoutError]:
    """The limits an error says: itself, or those of `Several`."""
    return list(exc.errors) if isinstance(exc, Several) else [exc]


def forget_frames(exc: BaseException) -> None:
    """Drop the tracebacks of `exc`, of the limits it holds (`each`) and of what they came from:
    code generation keeps the limits it finds in a local list, so a traceback through its frame
    would hold them in a reference cycle (the period search builds, and is refused, many times)."""
    seen: set[int] = set()
    work = [exc, *(each(exc) if isinstance(exc, LayoutError) else ())]
    while work:
        e = work.pop()
        if e is None or id(e) in seen:
            continue
        seen.add(id(e))
        e.__traceback__ = None
        work += [e.__context__, e.__cause__]


class RamFull(LayoutError):
    code = "ram-overflow"
    help = "use fewer ports or servos"


FLATTEN = "flatten the program: play a sequence once with a larger repeat count instead of nesting"


class StackTooDeep(LayoutError):
    code = "too-deep"
    help = f"nest `repeat` and `play` at most {costs.max_nesting()} levels deep"


class HostRam(LayoutError):
    """The RAM the firmware allocates for `host`, and the stack a program without nesting needs, go
    past internal RAM (flow.host_ram_text says by how much)."""
    code = "host-ram"
    help = "use fewer servos, or put them on fewer ports (each port in use takes 40 bytes of RAM)"


class SlowServo(LayoutError):
    code = "too-slow"
    help = "give the move a duration, or a `speed` the frames-needed table can hold (F < 65536)"


class HandlerTooSlow(LayoutError):
    """The edge handler's run at a port's rise would not end before the earliest fall (N = 0)."""
    code = "bad-clock"
    help = "use a faster crystal (or 6T mode), or fewer lines on the port"


class SerialTooFast(LayoutError):
    """A byte could complete before the one before it was taken from the UART."""
    code = "serial-too-fast"
    help = "use a slower rate, fewer servo lines on one port, or a faster crystal"


class SendOverrun(LayoutError):
    """`send` could find the transmit queue full."""
    code = "send-overrun"
    help = "put a frame (a move or a hold) between the sends, or send fewer bytes at a time"
    shortest_us: int | None = None      # the shortest period at which the build that raised it holds the sends


# A select's `after` F is counted in 16 bits: F + 1 looks (one as it is reached, one after each
# frame), the last of which takes it.
MAX_AFTER_FRAMES = 0xFFFE

# A repeat whose pass can take no frame (a select whose event is already there) is written out
# pass by pass, so that the work between two frames stays bounded: at most this many passes.
MAX_FRAMELESS_PASSES = 16


class FramelessRepeat(LayoutError):
    code = "too-long"
    help = "put a frame in each pass (a `hold` of one frame), or use fewer passes"


class AfterTooLong(LayoutError):
    code = "too-long"
    help = "wait in several steps: an inner `select` in the `after` branch"


class PeriodTooLong(LayoutError):
    code = "period-too-long"
    help = "use a shorter `frame`: Timer0 counts at most 65535 machine cycles from edge to edge"


class RamAllocator:
    """A bump allocator over RAM from WORK_BASE up to `end` (where the stack the program needs
    starts). A variable the code names directly must end by DIRECT_LIMIT; buffers reached only
    through @R0/@R1 (direct=False) may go past it."""

    def __init__(self, end: int, start: int = WORK_BASE, full=None) -> None:
        self.next = start
        self.end = end
        self.symbols: list[tuple[str, int, str]] = list(MASK_BYTES)
        self.xsymbols: list[tuple[str, int, str]] = []     # in XRAM (flow.host_xram)
        self.full = full            # the error for the bytes past `end` all the allocations ask for
                                    # (raised by `check`), or None: RamFull at the first one past it

    def alloc(self, name: str, size: int, what: str, direct: bool = True) -> int:
        addr = self.next
        self.next += size
        if self.next > self.end:
            if self.full is None:
                raise RamFull(f"RAM is full: {name} does not fit below the stack at 0x{self.end:02X}")
        elif direct and self.next > DIRECT_LIMIT:
            raise RamFull(f"direct RAM is full: {name} does not fit below 0x{DIRECT_LIMIT:02X}")
        self.symbols.append((name, addr, what))
        return addr

    def check(self) -> None:
        """After the last allocation: `full`'s error when the allocations went past `end`, counting
        every byte past it."""
        if self.full is not None and self.next > self.end:
            raise self.full(self.next - self.end)

    def total(self, pins: int, stack: int, xram: bool = False) -> int:
        """Bytes of internal RAM in use: direct RAM, the motion state of every pin (none where it
        is in XRAM) and the stack."""
        return self.next + (0 if xram else STATE_BYTES * pins) + stack


# ----------------------------------------------------------------- records

def hex8(v: int) -> str:
    return f"0x{v & 0xFF:02X}"


def one_byte_f(frames: int) -> bool:
    """Whether a record's F is one byte (flag F8): its code reads a byte less, and a linear move's
    first frame takes a DIV (`api._least_period` follows it)."""
    return frames < 0x100


def frames_bytes(frames: int) -> tuple[int, list[str]]:
    """F as one byte (flag F8) when it fits, else two (low, high)."""
    if one_byte_f(frames):
        return FLAG["F8"], [hex8(frames)]
    return 0, [hex8(frames), hex8(frames >> 8)]


def move_record(frames: int | None, ease_label: str | None, targets: dict[int, int],
                masks: list[int] | None) -> tuple[int, list[str]]:
    """(flags, bytes) of a move record: flags, [F], [curve table], [per-port masks], target N per named pin.
    `masks` is None when the move names every servo."""
    flags = (FLAG["EASED"] if ease_label else 0) | (FLAG["NODUR"] if frames is None else 0)
    data: list[str] = []
    if frames is not None:
        f8, fb = frames_bytes(frames)
        flags |= f8
        data += fb
    if ease_label:
        data += [f"<{ease_label}", f">{ease_label}"]
    if masks is None:
        flags |= FLAG["ALLF"]
    else:
        data += [hex8(m) for m in masks]
    data += [str(n) for _, n in sorted(targets.items())]
    return flags, [hex8(flags)] + data


MORE_BIT = 2        # FLAGS.2 of a move record built for size (LASTF's bit once the move runs): a
                    # count follows the flags byte, of the records after it that share its flags and F
MORE_MOST = 255     # records a count can name


def share_headers(records: list[dict]) -> list[dict]:
    """The records of one list built for size: each run of move records with the same flags and F
    (F given, not found at run time) is written as the first, with MORE set and the count of the
    others right behind its flags byte, then the others without their flags and F."""
    def head(r: dict) -> int:      # the flags byte and F
        return 0 if r["flags"] & FLAG["HOLDF"] or r["flags"] & FLAG["NODUR"] else \
            2 if r["flags"] & FLAG["F8"] else 3
    out: list[dict] = []
    i = 0
    while i < len(records):
        h = head(records[i])
        j = i + 1
        while (h and j < len(records) and j - i <= MORE_MOST and head(records[j]) == h
               and records[j]["data"][:h] == records[i]["data"][:h]):
            j += 1
        if j - i == 1:
            out.append(records[i])
        else:
            first = records[i]
            data = [hex8(first["flags"] | 1 << MORE_BIT), str(j - i - 1)] + first["data"][1:]
            out.append({**first, "data": data, "more": True,
                        "notes": first["notes"] + [f"its flags and F shared by the {j - i - 1} records after it"]})
            out += [{**r, "data": r["data"][h:], "notes": r["notes"] + ["flags and F as the record before"]}
                    for r in records[i + 1:j]]
        i = j
    return out


def hold_record(frames: int) -> tuple[int, list[str]]:
    f8, fb = frames_bytes(frames)
    flags = FLAG["HOLDF"] | f8
    return flags, [hex8(flags)] + fb


# ----------------------------------------------------------------- fit report

@dataclass(frozen=True)
class Fit:
    """How an assembled image uses code memory (bytes)."""
    runtime: int          # the runtime routines
    program: int          # the program's native control flow
    data: int             # move records, curve tables and frames-needed tables
    end: int              # first address after the motion data
    limit: int            # the motion data must end at or below this address
    needed: int           # code memory the image needs in all

    @property
    def fits(self) -> bool:
        return self.end <= self.limit


def fit(symbols: dict[str, int], fneed_pages: tuple[int, ...], rom_size: int) -> Fit:
    """The fit report from the image's section labels (runtime_start, runtime_end, program_end,
    data_start, data_end) and the pages the frames-needed tables take at the top."""
    runtime = symbols["runtime_end"] - symbols["runtime_start"]
    program = symbols["program_end"] - symbols["runtime_end"]
    tables = 512 * len(fneed_pages)
    data = symbols["data_end"] - symbols["data_start"] + tables
    end = symbols["data_end"]
    limit = min(fneed_pages) * 256 if fneed_pages else rom_size
    return Fit(runtime, program, data, end, limit, end + (rom_size - limit))


_NO_BYTES = {"A", "C", "AB", "DPTR", "@A+DPTR", "@A+PC", "@DPTR", "@R0", "@R1",
             "R0", "R1", "R2", "R3", "R4", "R5", "R6", "R7"}


def instruction_bytes(op: str, args: list[str]) -> int:
    """The bytes of one 8051 instruction as the assembler encodes it: the opcode, then a byte for
    each direct address, bit address, relative jump or 8-bit immediate, two for a 16-bit address
    (LJMP, LCALL) or immediate (MOV DPTR,#); registers, A, C, AB, DPTR and indirect operands are
    in the opcode."""
    op = op.upper()
    n = 1
    for a in args:
        a = a.strip()
        if a.upper() in _NO_BYTES:
            continue
        wide = op in ("LJMP", "LCALL") or (a.startswith("#") and op == "MOV" and args[0].strip().upper() == "DPTR")
        n += 2 if wide else 1
    return n


def _data_items(rest: str) -> list[str]:
    """The items of a .db / .ascii operand list, quoted strings kept whole."""
    return [m.group(0).strip() for m in re.finditer(r'"[^"]*"|[^,]+', rest) if m.group(0).strip()]


_STATEMENT = re.compile(r"^[ \t]*(?:(\w+)::?)?[ \t]*([^;\n]*)", re.M)


@functools.lru_cache(maxsize=16)
def rom_end(text: str) -> int:
    """The end of the code and data the assembly text lays out, as the assembler lays them out
    (`instruction_bytes`, each .db item a byte or a string's characters, .bndry padding to its
    boundary, .org): the address of `data_end` (the frames-needed tables after it have pages of
    their own, `fit`), or of the text's end. Without the toolchain, so that a build can be chosen
    by its size."""
    at = 0
    sizes: dict[str, int] = {}      # an instruction's operands as written: its bytes
    for label, line in _STATEMENT.findall(text):
        if label == "data_end":
            return at
        line = line.strip()
        if not line:
            continue
        if line in sizes:
            at += sizes[line]
            continue
        op, _, rest = line.partition(" ")
        op = op.lower()
        if op == ".org":
            at = int(rest.strip(), 0)
        elif op == ".bndry":
            size = int(rest.strip(), 0)
            at += -at % size
        elif op in (".db", ".ascii"):
            at += (sum(len(item) - 2 if item.startswith('"') else 1 for item in _data_items(rest)) if '"' in rest
                   else rest.count(",") + 1)
        elif op == ".dw":
            at += 2 * len(_data_items(rest))
        elif not op.startswith(".") and "=" not in line:
            sizes[line] = instruction_bytes(op, [a for a in rest.split(",") if a.strip()])
            at += sizes[line]
    return at
