"""Worst-case cycle counts read from the generated assembly: AsmUnit text -> cycles.

The firmware's frame budget comes from here, not from measured constants:
`Code` parses the assembly that codegen wrote (the same text sdas8051
assembles), gives every instruction its machine cycles (the 8051's own table,
checked against the assembler's listing in the tests), and finds the longest
path between two frames.

A frame starts where the program calls `frame_io` (it hands the frame's N,
port by port, to the Timer0 edge handler). After a frame the firmware resumes
right behind one of those calls; the longest path from any resume point to
the next `LCALL frame_io` is the work that must fit in a frame (`costs.py`
adds each port's sort and the handler's load; `Code.longest` reads those
paths between labels). The analysis is interprocedural: a called routine is followed to
its RET and back; a RET of the routine the path started in goes on behind
every call of that routine. Conditional branches count both ways (so a move
record is charged as if every servo it names moved and every pin carried;
which servos it names is a fact from code generation: `Names`). Code
that loops without reaching a frame is an error, not a guess: the only
backward branches allowed are counted pad loops (`MOV Rn,#k` then `DJNZ
Rn,.`), counted loops (`MOV Rn,#k` right before the label `L` of a later
`DJNZ Rn,L`: k passes of the longest pass, none of which may take a frame,
write Rn, or write the flag byte or its bits) and paths that pass a frame.

A flag is followed along each path: FRAMED, which frame_io sets. A `loop`
whose pass can take no frame clears it at the top of each pass and, at the
end, waits for a frame only if it is still clear (`JB FRAMED`); the analysis
knows it is set right after a frame and clear after the `CLR`, so that test
goes one way on each path and the loop is bounded by the frame it reaches.

The bits of a move record's flags byte (FLAGS: eased, F found at run time, F in one byte, every
servo named, a hold) are followed the same way: run_list writes the byte whole from each record
(`MOV FLAGS, A`), and from there a path that went one way at a test of a bit goes the same way at
every later test of it until the byte is written again, so a record is charged for what one kind
of record does (a record without F is not also charged for reading one; a linear move not for the
eased table). Nothing else writes FLAGS: the handlers never touch it. A few bits of other bytes
(`state_bits`: PLAYH, set while a sequence the host's `PL` started plays) are followed the same
way from their `SETB`, `CLR` and tests, and stay known when FLAGS is written or a select cuts. A
second fact from code generation uses it (`barred`): while PLAYH is set, the stack holds return
addresses into the runtime, the host's code and the sequences `PL` can play only, so a RET on a
path that knows PLAYH set (one that read the host's bytes in frame_h) does not go on behind a call
in `main` or in a sequence `PL` cannot play. And host_run's start tests PLAYH: such a path does not
go on into `host`'s own reading either.

A select's meanwhile body is cut by frame_w, which runs right after each frame: an event sets
the stack back to where the select started the body (`MOV SP, ...`) and jumps to its branches
(`LJMP`); that path goes on as from the select, in the routine the select is in.

One fact comes from code generation rather than from the code: a record
list (`LCALL run_list`) is never empty and every record in it takes at least
one frame, so a call of `run_list` always reaches a frame before it returns.

Code generation lays out several texts for one program (the builds with rises
as steps, among the falls before them, or neither, at each period the period
stage tries) that differ in the engine's code (frame_io and the edge handler,
up to the label `engine_end`) and not between frames. `frames_code` reads the
work between frames from the text with the engine replaced by one indirect
jump, once for all of them; where a path would enter the engine that analysis
fails, and the caller reads the whole text instead.
"""

from __future__ import annotations

import functools
import re
import sys
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, NamedTuple

FRAME_ROUTINE = "frame_io"      # LCALL of it: a frame starts (the cut point)
ENGINE_END = "engine_end"       # the label right after the engine's code (frame_io's body, the edge handler)
FRAME_REACHING = {"run_list"}   # calls that always reach a frame before they return
WRITTEN = ("", True)            # a path's fact: it wrote the flag byte whole (a record read)
FRAME_FLAG = "FRAMED"           # set by frame_io; a loop clears it at the top of a pass and
                                # tests it at the end (`JB FRAMED`): a pass that took no frame waits for one

_REGS = {f"R{i}" for i in range(8)}
_INDIRECT = {"@R0", "@R1"}
_BRANCH2 = {"JC", "JNC", "JZ", "JNZ", "JB", "JNB", "JBC", "CJNE", "DJNZ"}
_JUMPS = {"SJMP", "LJMP", "AJMP"}
_CALLS = {"LCALL", "ACALL"}
_ONE = {"NOP", "RR", "RL", "RRC", "RLC", "SWAP", "DA", "XCH", "XCHD", "ADD", "ADDC", "SUBB", "CLR", "SETB", "CPL"}
_TWO = {"MOVC", "MOVX", "PUSH", "POP", "RET", "RETI", "JMP"} | _BRANCH2 | _JUMPS | _CALLS


class WcetError(Exception):
    """The code has a path the analysis cannot bound (an internal error of code generation)."""


def cycles_of(op: str, args: tuple[str, ...]) -> int:
    """Machine cycles of one 8051 instruction (12 clocks each)."""
    if op in ("MUL", "DIV"):
        return 4
    if op in _TWO:
        return 2
    if op in _ONE:
        return 1
    if op in ("INC", "DEC"):
        return 2 if args[0] == "DPTR" else 1
    if op in ("ANL", "ORL", "XRL"):
        if args[0] == "C":
            return 2
        return 2 if args[0] != "A" and args[1].startswith("#") else 1
    if op == "MOV":
        dst, src = args
        if dst == "DPTR" or src == "C":
            return 2
        if dst in ("A", "C"):
            return 1
        if dst in _REGS or dst in _INDIRECT:
            return 1 if src == "A" or src.startswith("#") else 2
        return 1 if src == "A" else 2
    raise WcetError(f"no cycle count for `{op} {', '.join(args)}`")


@dataclass(frozen=True)
class Names:
    """A fact of code generation about a build for speed without a host: which servos each move
    record names. do_move writes each port's byte of RMASK from the record (`MOV RMASK+k, ...`,
    the first port's first), and clears MOVB (`MOV MOVB+k, #0`) before any servo's setup writes
    its bit; it then tests each servo's bit of them. Nothing else in such a build writes those
    bytes, and no indirect write reaches them (no buffer is bit-addressable). So a path forks at
    the first port's RMASK write into the records (`sets`: each distinct pair of the servos a
    record names and its flags, those whose flags agree with what the path knows of the flag
    byte), each known as ("REC", index) from there to the next frame, and every later test of a
    servo's RMASK or MOVB bit whose value the path knows goes that way: a record is charged for
    the servos it names, not for every servo. Where every start of a record's move has a servo
    with a target, or every one without (`acts`), its ACT bit is known from the fork on too (only
    the set-up's `SETB` writes it), and with it the carry flag that `MOV C, bit` copies from it,
    until an instruction that may write the carry: a servo's first target is charged as set at once."""
    first: str                                          # the first port's RMASK byte: the fork
    rmask: tuple[tuple[str, tuple[str | None, ...]], ...]   # per port: its RMASK byte, bit 0..7's names
    movb: tuple[tuple[str, tuple[str | None, ...]], ...]    # per port: its MOVB byte, bit 0..7's names
    sets: tuple[tuple[int, ...], ...]                   # each distinct record's masks, per port
    flags: tuple[frozenset, ...]                        # and its flag bits, (name, value)
    act: tuple[tuple[str, tuple[str | None, ...]], ...] = ()    # per port: its ACT byte, bit 0..7's names
    acts: tuple[tuple[tuple[int, int], ...], ...] = ()  # per record, per port: the servos that have a
                                                        # target, and those that have none, wherever it starts


REC = "REC"         # a path's fact: ("REC", i), it reads a record that names Names.sets[i]
CARRY = "CARRY"     # a path's fact: ("CARRY", value), the carry flag as `MOV C, bit` set it from a known bit

# Instructions that leave the carry flag as it is (and do not write PSW): anything else may write it.
_CARRY_KEPT = {"MOV", "MOVC", "MOVX", "INC", "DEC", "CLR", "SETB", "CPL", "PUSH", "POP", "NOP", "LCALL", "ACALL",
               "RET", "SJMP", "LJMP", "AJMP", "JMP", "JZ", "JNZ", "JB", "JNB", "JC", "JNC", "DJNZ", "XCH", "XCHD",
               "SWAP", "RL", "RR", "ANL", "ORL", "XRL"}


def _keeps_carry(ins: Instr) -> bool:
    """Whether `ins` surely leaves the carry flag as it is."""
    return ins.op in _CARRY_KEPT and not any(a in ("C", "CY", "PSW", "PSW.7", "0xD7", "0xD0") for a in ins.args)


class Instr(NamedTuple):        # (a tuple: the texts of a program's builds have thousands each)
    index: int
    op: str
    args: tuple[str, ...]
    cycles: int
    line: int          # 1-based line of the assembly text


_LABEL = re.compile(r"^([A-Za-z_.$][\w.$]*)::?\s*(.*)$")


def same_cycles(a: str, b: str) -> bool:
    """Whether two assembly texts surely take the same cycles on every path: line for line the
    same but for comments and the values of immediates (`#...`), none of them a counted or pad
    loop's count (a `MOV Rn,#k` right before `DJNZ Rn,.` or before the label of a `DJNZ Rn,label`)
    nor a byte written whole (`MOV direct,#k`: the analysis follows what some such writes say).
    False says nothing: measure both."""
    lines_a, lines_b = a.splitlines(), b.splitlines()
    if len(lines_a) != len(lines_b):
        return False
    counts = None
    for i, (x, y) in enumerate(zip(lines_a, lines_b)):
        if x == y:
            continue
        x, y = x.split(";", 1)[0], y.split(";", 1)[0]
        if x == y:
            continue
        if _IMMEDIATE.sub("#", x) != _IMMEDIATE.sub("#", y) or x.lstrip().startswith(".") or _WHOLE.match(x):
            return False
        if _COUNT.match(x):
            counts = _loop_counts([line.split(";", 1)[0] for line in lines_a]) if counts is None else counts
            if i in counts:
                return False
    return True


def _loop_counts(code: list[str]) -> set[int]:
    """The lines (comments cut) that give a counted or pad loop its count: a `MOV Rn,#k` whose next
    line with code is `DJNZ Rn,.`, or carries a label that some `DJNZ Rn,label` jumps to."""
    loops = {(m.group(1).upper(), m.group(2)) for line in code if (m := _DJNZ.search(line))}
    out = set()
    for i, line in enumerate(code):
        m = _COUNT.match(line)
        if not m:
            continue
        reg = m.group(2).upper()
        after = next((x for x in code[i + 1:] if x.strip()), "")
        label = _LABEL_AT.match(after)
        djnz = _DJNZ.search(after)
        if (djnz and djnz.group(1).upper() == reg and djnz.group(2) == ".") or (label and (reg, label.group(1)) in loops):
            out.add(i)
    return out


_IMMEDIATE = re.compile(r"#[^,\s]+")
_COUNT = re.compile(r"\s*(\w+:\s*)?MOV\s+(R[0-7])\s*,", re.I)
_WHOLE = re.compile(r"\s*(\w+:\s*)?MOV\s+(?!(?:A|R[0-7]|@R[01]|DPTR)\s*,)\S[^,]*,\s*#", re.I)
_DJNZ = re.compile(r"\bDJNZ\s+(R[0-7])\s*,\s*(\S+)", re.I)
_LABEL_AT = re.compile(r"\s*(\w+):")


@functools.lru_cache(maxsize=4)
def _parse(text: str) -> tuple[tuple[Instr, ...], dict[str, int]]:
    """The instructions of an assembly text, in order, and its code labels (the index of the
    instruction each names); the same text is read once for the analyses of one code generation."""
    instrs: list[Instr] = []
    labels: dict[str, int] = {}
    pending: list[str] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        label, kind, op, args, cycles = _read_line(raw)
        if label is not None:
            pending.append(label)
        if kind is not _CODE:
            if kind is _DATA:
                pending = []        # labels on data are not code labels
            continue
        for lab in pending:
            labels[lab] = len(instrs)
        pending = []
        instrs.append(Instr(len(instrs), op, args, cycles, lineno))
    return tuple(instrs), labels


_CODE, _DATA, _NONE = "code", "data", "none"


@functools.lru_cache(maxsize=1 << 16)
def _read_line(raw: str) -> tuple[str | None, str, str, tuple[str, ...], int]:
    """One line of assembly: (its label or None, _CODE for an instruction, _DATA for data or an
    origin, else _NONE, and the instruction's op, args and cycles). Most lines recur in the texts of
    one program's builds (the runtime's), so each is read once."""
    code = raw.split(";", 1)[0].strip()
    label = None
    m = _LABEL.match(code)
    if m and not code.startswith("."):
        label = m.group(1)
        code = m.group(2).strip()
    words = code.split()
    if not code or code.startswith(".") or "=" in words[0] or (len(words) > 1 and words[1] == "="):
        kind = _DATA if code.startswith((".org", ".db", ".bndry")) else _NONE
        return label, kind, "", (), 0
    parts = code.split(None, 1)
    op = parts[0].upper()
    args = tuple(a.strip() for a in parts[1].split(",")) if len(parts) > 1 else ()
    return label, _CODE, op, args, cycles_of(op, args)


_NAME = re.compile(r"[A-Za-z_.$][\w.$]*")     # a name in an operand (`#<win_p0`, `RMASK+1`)
_FRAMES_MOST = 8        # the texts `frames_code` keeps the analysis of
_frames_codes: OrderedDict = OrderedDict()


def frames_code(text: str, flag_byte: str = "", flag_bits: frozenset[str] = frozenset(),
                state_bits: frozenset[str] = frozenset(), barred: tuple[str, tuple[tuple[str, str], ...]] | None = None,
                names: Names | None = None) -> tuple[Code, Callable[[int], int]]:
    """A Code whose `between_frames` and `by_record` are those of `Code(text, ...)` where they do
    not fail, shared by the texts that differ only in the engine's code, from `frame_io` up to
    ENGINE_END: the builds of one program (with rises as steps or among the falls before them, or
    neither, at each period the period stage tries). The paths between frames stop at frame_io's
    call and never enter the engine, so the analysis of the text with the engine's code replaced
    by one indirect jump (`_STUB`, where every label of the engine leads) is theirs: a path that
    would enter it fails there instead. That holds where the engine calls no routine outside it,
    nor frame_io (so the call sites of every routine outside it, and the points where a frame
    resumes, are the same), nothing outside it names its labels but frame_io's calls and the
    interrupt vectors (so no path but one that runs into it from the code before reaches the
    stub), and the code after it starts with a routine the code outside it calls (so every
    instruction outside it is in the same routine); elsewhere this is the Code of the whole text. Its instructions keep the first such text's lines: where its analysis fails, the
    caller reads the whole text's, for the message. With it, the index in `text` of each of its
    instructions (outside the engine)."""
    instrs, labels = _parse(text)
    s, e = labels.get(FRAME_ROUTINE), labels.get(ENGINE_END)
    facts = (flag_byte, flag_bits, state_bits, barred, names)
    if s is None or e is None or not _engine_apart(instrs, labels, s, e):
        return Code(text, *facts), _same
    outside = tuple((n, j if j < s else j - (e - s) + 1) for n, j in labels.items() if not s <= j < e)
    key = (tuple((ins.op, ins.args, ins.cycles) for ins in instrs[:s]),
           tuple((ins.op, ins.args, ins.cycles) for ins in instrs[e:]), outside, facts)
    code = _frames_codes.get(key)
    if code is None:
        stub = Instr(s, *_STUB, instrs[s].line)
        kept = instrs[:s] + (stub,) + tuple(ins._replace(index=k) for k, ins in enumerate(instrs[e:], s + 1))
        kept_labels = {n: s for n, j in labels.items() if s <= j < e} | dict(outside)
        code = _frames_codes[key] = Code("", *facts, parsed=(kept, kept_labels))
        while len(_frames_codes) > _FRAMES_MOST:
            _frames_codes.popitem(last=False)
    else:
        _frames_codes.move_to_end(key)
    return code, lambda i: i if i < s else i - 1 + e - s


def _same(i: int) -> int:
    return i


_STUB = ("JMP", ("@A+DPTR",), 2)        # the engine's code, in `frames_code`: no path goes on from it


@functools.lru_cache(maxsize=1 << 16)
def _names_in(args: tuple[str, ...]) -> frozenset[str]:
    """The names in an instruction's operands (the texts of a program's builds share most)."""
    return frozenset(n for a in args for n in _NAME.findall(a))


def _engine_apart(instrs: tuple[Instr, ...], labels: dict[str, int], s: int, e: int) -> bool:
    """Whether the engine's code (instructions s to e - 1) calls only its own routines, never
    frame_io; no code outside it names one of its labels but frame_io's calls and the interrupt
    vectors (before `reset`, which only an interrupt reaches), so that the only way in from the
    rest is a frame; and the code after it starts with a routine the code outside it calls
    (`frames_code`)."""
    inside = {n for n, j in labels.items() if s <= j < e}
    if any(ins.op in _CALLS and (ins.args[0] not in inside or ins.args[0] == FRAME_ROUTINE) for ins in instrs[s:e]):
        return False
    vectors = labels.get("reset", 0)
    if any(not (ins.op in _CALLS and ins.args[0] == FRAME_ROUTINE) and not inside.isdisjoint(_names_in(ins.args))
           for ins in instrs[vectors:s] + instrs[max(vectors, e):]):
        return False
    return any(ins.op in _CALLS and labels.get(ins.args[0]) == e for ins in instrs[:s] + instrs[e:]) or \
        labels.get("main") == e


class Code:
    """The instructions of one assembly text, with their labels."""

    def __init__(self, text: str, flag_byte: str = "", flag_bits: frozenset[str] = frozenset(),
                 state_bits: frozenset[str] = frozenset(), barred: tuple[str, tuple[tuple[str, str], ...]] | None = None,
                 names: Names | None = None,
                 parsed: tuple[tuple[Instr, ...], dict[str, int]] | None = None) -> None:
        self.flag_byte = flag_byte      # a byte whose bits a path learns from its branches (`walk`)
        self.flag_bits = flag_bits
        self.state_bits = state_bits    # bits of other bytes a path learns the same way, which a write
                                        # of the flag byte leaves known
        instrs, labels = _parse(text) if parsed is None else parsed     # (`parsed`: `frames_code`'s)
        self.instrs: tuple[Instr, ...] = instrs     # (shared by the Codes of one text: read only)
        self.labels: dict[str, int] = labels
        # (bit, ranges): while the state bit is known set, a RET never returns behind a call in one of
        # the ranges (from label to label): a fact of code generation (codegen.frame_budget)
        self._barred_bit = barred[0] if barred else None
        self._barred = frozenset(i for a, b in (barred[1] if barred else ()) for i in range(self.labels[a], self.labels[b]))
        self._call_targets = sorted({self.labels[i.args[0]] for i in self.instrs
                                     if i.op in _CALLS and i.args[0] in self.labels}
                                    | ({self.labels["main"]} if "main" in self.labels else set()))
        self.names = names
        self._fact_bytes: dict[str, tuple[str | None, ...]] = dict(names.rmask + names.movb + names.act) if names else {}
        self._rm_port = {byte: k for k, (byte, _) in enumerate(names.rmask)} if names else {}
        self._fact_bits = {b for bits in self._fact_bytes.values() for b in bits if b is not None}
        self._walk_memo: dict[tuple, dict] = {}
        self._touch: list[bool] | None = None
        self._plains: dict[int, bool] = {}     # `_plain` of each instruction asked about
        self._frames: dict[int, dict] | None = None
        self._on_path: set[int] = set()
        self._f0_memo: dict[int, bool] = {}
        # counted loops: the head (the instruction after `MOV Rn,#k`) -> its `DJNZ Rn,head`
        self._loops: dict[int, int] = {}
        for ins in self.instrs:
            if ins.op == "DJNZ" and ins.args[-1] != "." and ins.args[-1] in self.labels:
                head = self.labels[ins.args[-1]]
                prev = self.instrs[head - 1] if head else None
                if head <= ins.index and prev is not None and prev.op == "MOV" and prev.args[0] == ins.args[0] \
                        and prev.args[1].startswith("#"):
                    self._loops[head] = ins.index

    # ---------------------------------------------------------------- helpers

    def target(self, ins: Instr) -> int:
        if not ins.args:
            raise WcetError(f"line {ins.line}: {ins.op} without a target")
        name = ins.args[-1]
        if name not in self.labels:
            raise WcetError(f"line {ins.line}: unknown label `{name}`")
        return self.labels[name]

    def routine_of(self, i: int) -> int | None:
        """Entry of the called routine that instruction i belongs to (None: not in one)."""
        entry = None
        for t in self._call_targets:
            if t > i:
                break
            entry = t
        return entry

    def call_sites(self, entry: int) -> list[int]:
        return [ins.index for ins in self.instrs if ins.op in _CALLS and self.labels.get(ins.args[0]) == entry]

    def label_at(self, i: int) -> str:
        names = [n for n, j in self.labels.items() if j == i]
        return names[0] if names else f"instruction {i}"

    # ---------------------------------------------------------------- analysis

    def walk(self, i: int, clear: bool = False, known: frozenset = frozenset()) -> dict:
        """Longest cycles from instruction i to each way out: 'frame' (the LCALL frame_io,
        its 2 cycles included) and ('ret', clear, known) (the RET of the routine i is in, included,
        with what is known of FRAMED and the flag bits there). `clear`: the path has passed a
        `CLR FRAMED` since its last frame, so FRAMED is 0 (frame_io sets it): a `JB FRAMED` there
        falls through. `known`: (bit, value) of the flag byte's bits the path has learned (from a
        `JB`/`JNB` on them, or a `SETB`/`CLR`) since the byte was last written whole: a later test of
        such a bit goes one way only."""
        if self._fact_bits and known and not self._touches(i):
            kept = frozenset(f for f in known if f[0] in self._fact_bits or f[0] == REC)
            if kept:        # the walk from here is shared by every record: then each gets its own back
                            # (the carry stays: it lives a few instructions)
                rec = frozenset(f for f in kept if f[0] == REC)
                out: dict = {}
                for key, v in self.walk(i, clear, known - kept).items():
                    key = (("frame", None if key[1] is None else key[1] | rec) if key[0] == "frame"
                           else ("ret", key[1], key[2] | kept))
                    out[key] = max(out.get(key, v), v)
                return out
        key = (i, clear, known)
        if key in self._walk_memo:
            return self._walk_memo[key]
        if key in self._on_path:
            raise WcetError(f"a loop through {self.label_at(i)} (line {self.instrs[i].line}) reaches no frame")
        if i >= len(self.instrs):
            raise WcetError("a path runs off the end of the code")
        self._on_path.add(key)
        try:
            out = self._walk(self.instrs[i], clear, known)
        finally:
            self._on_path.discard(key)
        self._walk_memo[key] = out
        return out

    def _walk(self, ins: Instr, clear: bool, known: frozenset) -> dict:
        c = ins.cycles
        nxt = ins.index + 1
        if ins.op in _CALLS:
            name = ins.args[0]
            if name == FRAME_ROUTINE:
                return {("frame", self._tag(known) if WRITTEN in known else None): c}
            callee = self.walk(self.target(ins), clear, known)
            out = {key: c + v for key, v in callee.items() if key[0] == "frame"}
            if name in FRAME_REACHING:
                return out
            for key, v in callee.items():
                if key[0] == "ret":
                    out = _merge(out, _plus(self.walk(nxt, key[1], key[2]), c + v))
            return out
        if ins.op in ("RET", "RETI"):
            return {("ret", clear, known): c}
        if ins.op == "MOV" and ins.args[0] == "SP":
            # a cut (frame_w): the stack as a select left it, and on at its branches, right after a
            # frame (FRAMED set); a RET there returns to the callers of the routine the select is in
            jump = self.instrs[nxt]
            if jump.op != "LJMP":
                raise WcetError(f"line {ins.line}: `MOV SP` between frames must be followed by an LJMP")
            state = frozenset(f for f in known if f[0] in self.state_bits)     # the state bits stay known
            return {("frame", tag): c + jump.cycles + v
                    for tag, v in self.resume(self.target(jump), False, state).items()}
        if ins.op == "JMP":
            raise WcetError(f"line {ins.line}: an indirect jump between frames")
        if ins.op in _JUMPS:
            return _plus(self.walk(self.target(ins), clear, known), c)
        if ins.args and ins.args[0] == FRAME_FLAG:
            if ins.op == "CLR":
                return _plus(self.walk(nxt, True, known), c)
            if ins.op == "JB":      # set (behind a frame) unless cleared since
                return _plus(self.walk(nxt if clear else self.target(ins), clear, known), c)
            raise WcetError(f"line {ins.line}: `{ins.op} {FRAME_FLAG}` outside frame_io")
        if self._fact_bits and any(f[0] == CARRY for f in known):
            was = dict(known)[CARRY]
            if ins.op in ("JC", "JNC"):
                taken = was == (ins.op == "JC")
                return _plus(self.walk(self.target(ins) if taken else nxt, clear, known), c)
            if not _keeps_carry(ins):
                known = frozenset(f for f in known if f[0] != CARRY)
        if self._fact_bits and ins.op == "MOV" and ins.args[0] == "C" and ins.args[1] in self._fact_bits:
            value = dict(known).get(ins.args[1])
            if value is not None:
                return _plus(self.walk(nxt, clear, known | {(CARRY, value)}), c)
        if ins.args and (ins.args[0] in self._fact_bits or ins.args[0] in self._fact_bytes):
            facts = self._facts(ins, clear, known)
            if isinstance(facts, dict):
                return facts
            known = facts
        if ins.args and (ins.args[0] in self.flag_bits or ins.args[0] in self.state_bits):
            bit = ins.args[0]
            rest = frozenset(f for f in known if f[0] != bit)
            if ins.op in ("JB", "JNB"):
                was = dict(known).get(bit)
                ways = []
                for value in (False, True) if was is None else (was,):
                    taken = value == (ins.op == "JB")
                    ways.append(self.walk(self.target(ins) if taken else nxt, clear, rest | {(bit, value)}))
                out = ways[0] if len(ways) == 1 else _merge(*ways)
                return _plus(out, c)
            if ins.op in ("SETB", "CLR"):
                return _plus(self.walk(nxt, clear, rest | {(bit, ins.op == "SETB")}), c)
            known = rest           # any other write (JBC, CPL, MOV bit,C): its value unknown
        elif ins.args and ins.args[0] == self.flag_byte:
            known = frozenset({WRITTEN} | {f for f in known if f[0] in self.state_bits})  # the byte written
                                            # whole (a record read)
        loop = self._counted(ins)
        if loop:
            end, k = loop
            return _plus(self.walk(end + 1, clear, known), c + k * self.one_pass(nxt, end))
        if ins.op == "DJNZ" and ins.args[-1] == ".":
            prev = self.instrs[ins.index - 1]
            if not (prev.op == "MOV" and prev.args[0] == ins.args[0] and prev.args[1].startswith("#")):
                raise WcetError(f"line {ins.line}: a pad loop needs `MOV {ins.args[0]},#k` right before it")
            k = int(prev.args[1][1:], 0) or 256
            return _plus(self.walk(nxt, clear, known), c * k)
        if ins.op in _BRANCH2:
            return _plus(_merge(self.walk(nxt, clear, known), self.walk(self.target(ins), clear, known)), c)
        # on through the plain instructions after it (each would only add its cycles) to the next
        # one that does more, or to where `walk` shares the walk among records: the same cycles,
        # without a step of the recursion and a memo entry for each
        n = len(self.instrs)
        while nxt < n and self._plain(nxt):
            if self._fact_bits and known:
                if not self._touches(nxt) and any(f[0] in self._fact_bits or f[0] == REC for f in known):
                    break
                if any(f[0] == CARRY for f in known) and not _keeps_carry(self.instrs[nxt]):
                    known = frozenset(f for f in known if f[0] != CARRY)
            c += self.instrs[nxt].cycles
            nxt += 1
        return _plus(self.walk(nxt, clear, known), c)

    def _plain(self, i: int) -> bool:
        """Whether `_walk` at instruction i only adds its cycles and goes on to the next one (and
        drops a known carry it does not keep), whatever the path knows."""
        got = self._plains.get(i)
        if got is None:
            ins = self.instrs[i]
            a = ins.args
            got = self._plains[i] = not (
                ins.op in _CALLS or ins.op in _JUMPS or ins.op in _BRANCH2 or ins.op in ("RET", "RETI", "JMP")
                or a and (a[0] in ("SP", FRAME_FLAG, self.flag_byte) or a[0] in self._fact_bits
                          or a[0] in self._fact_bytes or a[0] in self.flag_bits or a[0] in self.state_bits)
                or ins.op == "MOV" and len(a) > 1 and a[0] == "C" and a[1] in self._fact_bits
                or self._counted(ins) is not None or ins.op == "DJNZ" and a and a[-1] == ".")
        return got

    def _acts(self, rec: int) -> frozenset:
        """The ACT bits record `rec` knows at its fork: set where every start of its move has a target."""
        if self.names is None or not self.names.acts:
            return frozenset()
        out = set()
        for (_, bits), (on, off) in zip(self.names.act, self.names.acts[rec]):
            for k, b in enumerate(bits):
                if b is not None and (on >> k & 1 or off >> k & 1):
                    out.add((b, bool(on >> k & 1)))
        return frozenset(out)

    def _touches(self, i: int) -> bool:
        """Whether a path from instruction i, until its frame or the RET of the routine i is in
        (calls followed), may read or write a servo's RMASK or MOVB bit or byte or the flag byte,
        or cut to a select: where it may not, what the path knows of them and its record cannot
        change its cycles, and the walk from i is shared by every record."""
        if self._touch is None:
            n = len(self.instrs)
            touch = [any(a in self._fact_bits or a in self._fact_bytes for a in ins.args)
                     or (bool(ins.args) and ins.args[0] == self.flag_byte)
                     or (ins.op == "MOV" and bool(ins.args) and ins.args[0] == "SP") for ins in self.instrs]

            def after(j: int) -> list[int]:
                ins = self.instrs[j]
                if ins.op in _CALLS and ins.args[0] == FRAME_ROUTINE:
                    return []
                if ins.op in _CALLS and ins.args[0] in FRAME_REACHING:
                    return [self.target(ins)]
                return [k for k in self._next(j) if k < n]
            before: list[list[int]] = [[] for _ in range(n)]
            for j in range(n):
                for k in after(j):
                    before[k].append(j)
            work = [j for j in range(n) if touch[j]]
            while work:         # every instruction with a path to one that touches them
                for j in before[work.pop()]:
                    if not touch[j]:
                        touch[j] = True
                        work.append(j)
            self._touch = touch
        return i < len(self._touch) and self._touch[i]

    def _tag(self, known: frozenset) -> frozenset:
        """What a path knows at its frame, as `by_record` tells it: the flag bits and the record
        read (REC), not the servos' bits."""
        return frozenset(f for f in known if f[0] not in self._fact_bits) if self._fact_bits else known

    def _facts(self, ins: Instr, clear: bool, known: frozenset) -> dict | frozenset:
        """`Names`: a test of a servo's RMASK or MOVB bit, or a write of one or of their bytes. The
        paths out (as `_walk` gives them) where this instruction decides them, else what the path
        knows after it (the bits it writes no longer known, unless from the value written)."""
        arg, nxt, c = ins.args[0], ins.index + 1, ins.cycles
        if arg in self._fact_bits:
            was = dict(known).get(arg)
            if ins.op in ("JB", "JNB") and was is not None:
                taken = was == (ins.op == "JB")
                return _plus(self.walk(self.target(ins) if taken else nxt, clear, known), c)
            if ins.op in ("JB", "JNB"):
                return known
            rest = frozenset(f for f in known if f[0] != arg)
            if ins.op in ("SETB", "CLR"):
                return _plus(self.walk(nxt, clear, rest | {(arg, ins.op == "SETB")}), c)
            return rest
        bits = self._fact_bytes[arg]
        rest = frozenset(f for f in known if f[0] not in bits)
        if ins.op != "MOV":
            return rest
        def of(value: int) -> frozenset:
            return frozenset((b, bool(value >> k & 1)) for k, b in enumerate(bits) if b is not None)
        if arg in self._rm_port and self.names is not None:
            k = self._rm_port[arg]
            if arg == self.names.first:     # a record read: what was known of the one before goes
                acts = {b for _, bits in self.names.act for b in bits if b is not None}
                rest = frozenset(f for f in rest if f[0] != REC and f[0] not in acts)
                ways = [self.walk(nxt, clear, rest | {(REC, i)} | of(masks[k]) | self._acts(i))
                        for i, (masks, flags) in enumerate(zip(self.names.sets, self.names.flags))
                        if not any((bit, not value) in known for bit, value in flags)]
                if not ways:
                    return {}       # no record has the flags this path knows
                out: dict = {}
                for way in ways:
                    out = _merge(out, way)
                return _plus(out, c)
            rec = dict(known).get(REC)
            return rest if rec is None else _plus(self.walk(nxt, clear, rest | of(self.names.sets[rec][k])), c)
        if ins.args[1].startswith("#"):
            try:
                return _plus(self.walk(nxt, clear, rest | of(int(ins.args[1][1:], 0))), c)
            except ValueError:
                pass
        return rest

    def resume(self, i: int, clear: bool = False, known: frozenset = frozenset()) -> dict:
        """Longest cycles from instruction i to the next frame, going on behind the callers
        of the routine i is in when it returns: by what the path learned of the flag byte when it
        wrote it (`between_frames`; None: it did not)."""
        r = self.walk(i, clear, known)
        best = {key[1]: v for key, v in r.items() if key[0] == "frame"}
        for key, v in r.items():
            if key[0] != "ret":
                continue
            entry = self.routine_of(i)
            if entry is None and i < self.labels.get("runtime_end", 0):
                continue        # a runtime routine nobody calls (the record runner without moves)
            if entry is None:
                raise WcetError(f"a RET at {self.label_at(i)} outside any routine")
            # a routine nobody calls (the record runner of a program without moves) never returns
            for s in self.call_sites(entry):
                if s in self._barred and (self._barred_bit, True) in key[2]:
                    continue
                best = _merge(best, _plus(self.resume(s + 1, key[1], key[2]), v))
        return best

    def _counted(self, ins: Instr) -> tuple[int, int] | None:
        """(its DJNZ, k) when `ins` is the `MOV Rn,#k` that starts a counted loop."""
        end = self._loops.get(ins.index + 1)
        if end is None or ins.op != "MOV" or not ins.args[1].startswith("#") or ins.args[0] != self.instrs[end].args[0]:
            return None
        return end, int(ins.args[1][1:], 0) or 256

    def one_pass(self, head: int, end: int) -> int:
        """The longest pass of the counted loop from `head` to its `DJNZ` at `end` (included): no
        frame in it, and neither its counter nor the flag byte or its bits written on the way."""
        counter = self.instrs[end].args[0]
        seen: set[int] = set()
        work = [head]
        while work:
            i = work.pop()
            if i in seen or i == end:
                continue
            seen.add(i)
            if i >= len(self.instrs):
                raise WcetError("a path runs off the end of the code")
            ins = self.instrs[i]
            if ins.op in _CALLS and ins.args[0] == FRAME_ROUTINE:
                raise WcetError(f"line {ins.line}: a frame inside the counted loop at line {self.instrs[head].line}")
            if ins.args and (ins.args[0] in (counter, self.flag_byte, FRAME_FLAG) or ins.args[0] in self.flag_bits
                             or ins.args[0] in self.state_bits
                             or (ins.op == "XCH" and ins.args[-1] == counter)) \
                    and not ins.op.startswith("J") and ins.op != "CJNE":
                raise WcetError(f"line {ins.line}: `{ins.op} {', '.join(ins.args)}` inside the counted loop at "
                                f"line {self.instrs[head].line}")
            work += self._next(i)
        return self._longest(head, {end}) + self.instrs[end].cycles

    def _next(self, i: int) -> list[int]:
        """The instructions a path can take after instruction `i`: for a call, the routine called and
        the instruction its return comes back to; none after a RET, a RETI or an indirect jump."""
        ins = self.instrs[i]
        if ins.op in ("RET", "RETI", "JMP"):
            return []
        if ins.op in _CALLS:
            return [self.target(ins), i + 1]
        if ins.op in _JUMPS:
            return [self.target(ins)]
        if ins.op in _BRANCH2 and ins.args[-1] != ".":
            return [i + 1, self.target(ins)]
        return [i + 1]

    def _reach(self, start: int, stop: int | None = None) -> set[int]:
        """The instructions the paths from `start` can reach (calls followed), up to `stop`."""
        seen: set[int] = set()
        work = [start]
        while work:
            i = work.pop()
            if i in seen or i == stop or i >= len(self.instrs):
                continue
            seen.add(i)
            work += self._next(i)
        return seen

    def longest(self, start: str, stops: set[str]) -> int:
        """Longest cycles from label `start` until a label in `stops` is reached (its instruction
        not counted) or the routine returns (its RET or RETI counted)."""
        if start not in self.labels:
            raise WcetError(f"no label `{start}`")
        with _deep(4 * len(self.instrs)):      # a path's depth: its instructions
            return self._longest(self.labels[start], {self.labels[s] for s in stops if s in self.labels})

    def loop_cycles(self, head: int, end: int, k: int) -> int:
        """The longest k passes of the counted loop from `head` to its `DJNZ` at `end`: k times its
        longest pass, except that a call made at most once in the whole loop (`_once_calls`) is
        charged for one pass only."""
        full = self.one_pass(head, end)
        once = self._once_calls(head, end)
        if not once:
            return k * full
        return (k - 1) * self._without(head, end, once) + full

    def passes(self, head: str, calls: set[str]) -> tuple[int, int, int, int, int]:
        """The counted loop whose pass starts at label `head`: its count, its longest pass
        (`one_pass`), the longest that makes none of the calls made at most once in the loop
        (`_once_calls`), and the same two again on the paths that call no routine in `calls`."""
        first = self.labels[head]
        end, count = self._counted(self.instrs[first - 1])
        once = self._once_calls(first, end)
        barred = frozenset(i for i in self._reach(first, end) if i < end and self.instrs[i].op in _CALLS
                           and self.instrs[i].args[0] in calls)
        djnz = self.instrs[end].cycles
        with _deep(4 * len(self.instrs)):
            return (count, self.one_pass(first, end), self._without(first, end, once),
                    self._longest(first, {end}, once | barred) + djnz, self._longest(first, {end}, barred) + djnz)

    def _without(self, head: int, end: int, once: frozenset[int]) -> int:
        """The longest pass of a counted loop that makes none of the calls in `once`."""
        return self._longest(head, {end}, once) + self.instrs[end].cycles

    def _touches_f0(self, entry: int) -> bool:
        """Whether the routine at `entry` (or what it calls) may write F0 (or PSW)."""
        if entry not in self._f0_memo:
            self._f0_memo[entry] = any(self._writes_f0(self.instrs[i]) for i in self._reach(entry))
        return self._f0_memo[entry]

    @staticmethod
    def _writes_f0(ins: Instr) -> bool:
        return bool(ins.args) and ins.args[0] in ("F0", "PSW") and not ins.op.startswith("J")

    def _once_calls(self, head: int, end: int) -> frozenset[int]:
        """The calls in a counted loop's pass made at most once in the loop: the routine called
        starts with `CLR F0`, no `SETB F0` is on any path of the pass (nor in what it calls), and
        the call is reached only by falling through a `JNB F0` (F0 set): once it has run, every
        later pass jumps past it."""
        reach = self._reach(head, end)
        if any((self.instrs[i].op, self.instrs[i].args) == ("SETB", ("F0",)) for i in reach):
            return frozenset()
        calls = {i for i in reach if self.instrs[i].op in _CALLS and i < end
                 and (self.instrs[self.target(self.instrs[i])].op,
                      self.instrs[self.target(self.instrs[i])].args) == ("CLR", ("F0",))}
        # reachable in the pass itself (calls stepped over) with F0 clear: a JNB F0 jumps
        clear: set[int] = set()
        work = [head]
        while work:
            i = work.pop()
            if i in clear or not head <= i < end:
                continue
            clear.add(i)
            ins = self.instrs[i]
            if ins.op == "JNB" and ins.args[0] == "F0":
                work.append(self.target(ins))
            else:
                work += [j for j in self._next(i) if not (ins.op in _CALLS and j == self.target(ins))]
        return frozenset(calls - clear)

    def _longest(self, first: int, stop_at: set[int], dead: frozenset[int] = frozenset()) -> int:
        """`longest` from instruction `first`; paths through the instructions in `dead` left out.
        F0 is followed along each path from its SETB and CLR (a call of a routine that starts with
        CLR F0 leaves it clear; one that may write it, or PSW, leaves it unknown), so that a test of
        it goes one way where it is known, and a counted loop whose calls are made once
        (`_once_calls`) is charged for such a call only on the paths where F0 was set before it."""
        memo: dict[tuple[int, int | None], int] = {}
        on_path: set[tuple[int, int | None]] = set()

        def go(i: int, f0: int | None = None) -> int:
            if i in stop_at and i != first:
                return 0
            if i in dead:
                return -(1 << 30)
            if (i, f0) in memo:
                return memo[(i, f0)]
            if (i, f0) in on_path:
                raise WcetError(f"a loop through {self.label_at(i)}")
            if i >= len(self.instrs):
                raise WcetError("a path runs off the end of the code")
            on_path.add((i, f0))
            ins = self.instrs[i]
            c = ins.cycles
            after = f0
            if self._writes_f0(ins):
                after = 1 if (ins.op, ins.args) == ("SETB", ("F0",)) else \
                    0 if (ins.op, ins.args) == ("CLR", ("F0",)) else None
            loop = self._counted(ins)
            if loop:
                end, k = loop
                once = self._once_calls(i + 1, end)
                if not once:
                    touched = any(self._writes_f0(self.instrs[j]) for j in self._reach(i + 1, end))
                    out = c + k * self.one_pass(i + 1, end) + go(end + 1, None if touched else f0)
                else:
                    without = self._without(i + 1, end, once)
                    out = c + k * without + go(end + 1, f0)      # no pass makes the call
                    if f0 != 0:                                     # one pass makes it: F0 clear after
                        out = max(out, c + (k - 1) * without + self.one_pass(i + 1, end) + go(end + 1, 0))
            elif ins.op in ("RET", "RETI"):
                out = c
            elif ins.op in _CALLS:
                rets = [v for k, v in self.walk(self.target(ins)).items() if k[0] == "ret"]
                if not rets:
                    raise WcetError(f"line {ins.line}: a call that does not return")
                callee = self.instrs[self.target(ins)]
                after = 0 if (callee.op, callee.args) == ("CLR", ("F0",)) and not self._sets_f0(self.target(ins)) \
                    else None if self._touches_f0(self.target(ins)) else f0
                out = c + max(rets) + go(i + 1, after)
            elif ins.op == "JMP":
                raise WcetError(f"line {ins.line}: an indirect jump")
            elif ins.op in _JUMPS:
                out = c + go(self.target(ins), after)
            elif ins.op in ("JB", "JNB") and ins.args[0] == "F0" and f0 is not None:
                taken = (f0 == 1) == (ins.op == "JB")
                out = c + (go(self.target(ins), f0) if taken else go(i + 1, f0))
            elif ins.op in _BRANCH2:
                out = c + max(go(i + 1, after), go(self.target(ins), after))
            else:
                out = c + go(i + 1, after)
            on_path.discard((i, f0))
            memo[(i, f0)] = out
            return out

        try:
            return go(first)
        finally:
            del go      # it calls itself through its closure: no cycle is left for the collector

    def _sets_f0(self, entry: int) -> bool:
        """Whether the routine at `entry` (or what it calls) has a `SETB F0`."""
        return any((self.instrs[i].op, self.instrs[i].args) == ("SETB", ("F0",)) for i in self._reach(entry))

    def straight(self, start: str, end: str) -> int:
        """Cycles of the instructions from label `start` up to label `end` in the order written (the
        path that falls through every conditional branch between them)."""
        a, b = self.labels[start], self.labels[end]
        if any(ins.op in _JUMPS or ins.op in ("RET", "RETI", "JMP") for ins in self.instrs[a:b]):
            raise WcetError(f"no straight path from {start} to {end}")
        return sum(ins.cycles for ins in self.instrs[a:b])

    def longest_exit(self, labels: set[str]) -> int:
        """The longest of the paths from each label to its RETI."""
        return max(self.longest(name, set()) for name in labels)

    def stack_below(self, name: str, memo: dict[int, int] | None = None) -> int:
        """The most bytes a call of routine `name` puts on the stack, its return address and
        everything it pushes and calls included, until it returns. A `MOV SP` (frame_w's cut)
        ends a path: the stack goes back to where a select left it, in the program."""
        memo = {} if memo is None else memo
        entry = self.labels.get(name)
        if entry is None:
            raise WcetError(f"no label `{name}`")
        if entry in memo:
            if memo[entry] < 0:
                raise WcetError(f"`{name}` calls itself")
            return memo[entry]
        memo[entry] = -1
        deepest = 0
        seen: dict[int, int] = {}
        work = [(entry, 0)]
        while work:
            i, depth = work.pop()
            if seen.get(i, -1) >= depth:
                continue
            if i in seen and depth > seen[i] and self.instrs[i].op != "RET":
                raise WcetError(f"the stack grows on a loop through {self.label_at(i)}")
            seen[i] = depth
            if i >= len(self.instrs):
                raise WcetError("a path runs off the end of the code")
            ins = self.instrs[i]
            deepest = max(deepest, depth)
            if ins.op in ("RET", "RETI") or (ins.op == "MOV" and ins.args[0] == "SP"):
                continue
            if ins.op == "JMP":
                raise WcetError(f"line {ins.line}: an indirect jump in a called routine")
            if ins.op in _CALLS:
                deepest = max(deepest, depth + self.stack_below(ins.args[0], memo))
                work.append((i + 1, depth))
            elif ins.op in ("PUSH", "POP"):
                work.append((i + 1, depth + (1 if ins.op == "PUSH" else -1)))
            elif ins.op in _JUMPS:
                work.append((self.target(ins), depth))
            elif ins.op in _BRANCH2 and ins.args[-1] != ".":
                work.extend([(i + 1, depth), (self.target(ins), depth)])
            else:
                work.append((i + 1, depth))
        memo[entry] = 2 + deepest
        return memo[entry]

    def between_frames(self) -> tuple[int, int]:
        """(cycles, resume instruction) of the longest path from any frame to the next."""
        return max((max(by.values(), default=0), i) for i, by in self._from_frames().items())

    def by_record(self) -> dict:
        """The longest path from any frame to the next by what it learned of the flag byte: None for
        the paths that do not write it, else the (bit, value) it knows at the frame (with WRITTEN)."""
        out: dict = {}
        for by in self._from_frames().values():
            out = _merge(out, by)
        return out

    def _from_frames(self) -> dict[int, dict]:
        """Per resume point (behind an LCALL frame_io), its longest paths to the next frame by tag."""
        if self._frames is None:
            self._frames = self._walk_frames()
        return self._frames

    def _walk_frames(self) -> dict[int, dict]:
        resumes = [ins.index + 1 for ins in self.instrs if ins.op in _CALLS and ins.args[0] == FRAME_ROUTINE]
        if not resumes:
            raise WcetError("the code never calls frame_io")
        # a path visits each instruction once in each state (FRAMED, the flag bits it knows)
        with _deep(32 * len(self.instrs)):
            return {i: self.resume(i) for i in resumes}


@contextmanager
def _deep(depth: int):
    """Python's recursion limit raised for a walk `depth` calls deep (and 1000 more), then put back."""
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, depth + 1000))
    try:
        yield
    finally:
        sys.setrecursionlimit(limit)


def _plus(d: dict[str, int], c: int) -> dict[str, int]:
    return {k: v + c for k, v in d.items()}


def _merge(a: dict[str, int], b: dict[str, int]) -> dict[str, int]:
    out = dict(a)
    for k, v in b.items():
        out[k] = max(out.get(k, v), v)
    return out
