"""The exact model of the SSC-32 host protocol (docs/host-protocol.md).

Pure Python, no I/O: `servoc verify` uses it to predict, frame by frame,
what the firmware (firmware_templates/host.asm.j2) does with the bytes a
host sends while `host` runs. All arithmetic is in integers.

- `LineParser` reads bytes one at a time and returns the command a line
  end completes (`Group` of `Entry`s, `Offset`, `Query`, `QueryPulse`,
  `Version`, `Stop`, `Play`), or None.
- `target_n` (with `output_n`), `group_move`, `frame_n` and the F terms
  (`time_factor`, `frames_t`, `speed_t`, `frames_s`,
  `frames_top`) are the rules of "A group move"; the code generator builds
  its tables with them.
- `Session` is the state machine over time at frame granularity;
  `stops_reading` says which lines end a frame's reading.

The rules, as the document states them:

- Bytes: CR or LF ends a line (an empty line does nothing); spaces and tabs
  are ignored anywhere, even inside a number or a word; ESC drops the line
  so far; letters are read in either case. Letters make the words `P`,
  `PO`, `S`, `T`, `Q`, `QP`, `VER`, `STOP`, `PL`, `SQ`: a letter goes on
  with the word before it while no digit has followed that word, else it
  starts a new word (`#1P O5` is `#1 PO5`; `#1PPO5`, `PLSQ3`, `VE` are bad).
  Digits make a number after `#` or a word: n = min(65535, 10 n + d); no
  digits is 0 (`QP` is `QP 0`, `#P1500` names channel 0). A digit before any
  `#` or word is bad. `+` or `-` may come once, right after `PO`, before its
  digits. Any other byte is bad; a bad line is ignored up to its end
  (`LineParser.dropped` tells a bad line's end and an ESC).
- An item is `#` and its number, or a word and its number.
- A group line: entries `#c` with `P w` and `S v` in any order (a second `P`
  or `S` in an entry replaces the first), then optionally `T t` (it needs a
  `P` or `S` before it in the line, and nothing but the line end follows
  it). An entry with `S` but no `P` does nothing; of a channel named twice,
  the later entry with `P` replaces the earlier (width and S: an entry
  without S then has no S). `Group.entries` holds the entries with `P`, in
  line order (`Entry.offset` None); a group line without one is None.
- An offset line: entries `#c PO o`, o clamped to -100..100 (a later entry
  of a channel replaces the earlier, and a second `PO` in an entry the
  first; `Offset.entries` are `Entry`s with width and speed None). A line
  with both `PO` and `P` or `S` is bad. Each named servo's offset is set
  before frame i + 1 is computed: it is added to its widths in later group
  lines.
- A command line: `Q`, `QP c`, `VER`, `STOP`, `STOP c`, `PL 0 SQ n`, the
  command word first; `Q` and `VER` take no number, `PL` only 0, `SQ` comes
  only right after `PL`'s item; a second command word or a `#` after one is
  bad. `PL 0` without `SQ` does nothing (None). `STOP c` with c past 255
  names no channel (`Stop(c)` with no servo on it).
- Widths: `P 0` stops the pulses; else w' = min(w, 2600) + offset clamped
  to 500..2500, N = (w' - 500 + 4) // 8, clamped to the limit, reversed,
  trimmed, clamped to 0..250.
- A group line that names a servo (an entry with `P` for a channel with a
  servo) is a move of its own, read in a frame of its own (below): each
  servo takes its width and S from the last entry naming it, t is the
  line's `T`. A group line that names no servo does nothing (its `T`
  neither). The move ends every move under way where frame i has the
  servos; the named servos without a pulse are set at once; the others go
  from N0 to N1 over F frames, the largest of 1; F_T = (t x RT + 32768)
  >> 16 with RT = round(65,536,000 / P), halves up (0 without T); for each
  such servo with `S v`, v > 0, F_S = min(65535, ceil(8,000,000 x |delta| /
  (v x P))), |delta| / v to the next whole frame; and its top speed,
  ceil(|delta| x t_DAV / P). Frame i + k is
  `frame_n(N0, N1, k, F)`.
- P, the frame period, is a whole number of us (an int, or a Fraction equal
  to one; anything else is a ValueError).
- `Q` answers `+` while the move has frames still to come after the frame
  computed last (k < F) and a servo of it still has its path (one not
  stopped with `STOP c`, not set at once, not `P0`, not already there; it
  may have reached N1 before frame F by the rounding), or while
  `Session.sequence_running` is set; else `.`.
- `STOP` ends the move (Q answers `.`); `STOP c` ends channel c's part of
  the move (its frame count goes on); both take effect at once, in the
  frame their line is read. `PL 0 SQ n` with n among the sequences it may
  play ends the move and records n in `Session.plays` (frame i + 1 repeats
  frame i; the sequence's frames, from frame i + 2, are `plan.expand`'s);
  other n do nothing. While a sequence `PL` started plays, `STOP` ends it
  (`Session.stop_play`) and `STOP c` holds channel c where it is until it
  ends (`Session.held`: `plan.expand` leaves it out of the sequence's moves);
  a group line that names a servo and a `PL 0 SQ n` line (any n) end it too
  (`Session.replace_play`), and are carried out in the next frame as if
  read in the sequence's last frame, with no frame repeating its end; an
  offset line sets its offsets in the frame it is read (`set_offsets`).
  ESC and a bad line drop only their own line.
- A group line that names a servo, an offset line and `PL 0 SQ n` (any n)
  end the frame's lines (`stops_reading`, `Session.read`): an offset line
  and `PL` end its reading, the bytes after them are read in the next frame;
  after a group line the reading goes on into the next lines, and stops
  before a byte that would end a command or offset line, drop a line with
  ESC or write an entry over the group's (`LineParser.stalls`: the CR or LF
  of a line that does not `joins`, the other control bytes 0x08-0x0F and
  0x18-0x1F, ESC among them, and a '#' after a '#' of the line, or with the
  host's state in XRAM a '#' that ends an entry for a channel the group
  names; with holds, `LineParser(holds)`, such an entry is held instead
  while one of the firmware's holds is free, in internal RAM every entry a
  '#' ends and, while one is held, a line's last at its end, whose line end
  then waits too once every hold is taken). A group line that names a
  servo and ends in the same frame joins
  the group (`join`: one group per frame, its entries in order, the last T
  given); an empty one does nothing; a bad line's end drops it and stops
  the reading until the next frame (`Session.dropped`). Where a frame
  brings more bytes than a group line and a `Q` line (`flow.reads_answers`,
  `LineParser(answers=True)`), `Q`, `QP` and `VER` lines after a group line
  are read too: a `Q`'s answer waits for the group's commit and is computed
  at the start of the next reading (`Session.deferred`, `answers`), and the
  answers after it in its frame go out behind it. So no `STOP`, `STOP c`,
  `PL` or offset line (nor, without that, `Q`, `QP` or `VER`), and no ESC,
  comes after a group or an offset line in its frame. The other lines (`Q`, `QP c`, `VER`,
  `STOP`, `STOP c`, a group line that names no servo, a line that does
  nothing, a bad line) do not end the reading, except that an answer that
  cannot be queued at its line end (the transmit queue full, or answers
  before it still waiting) waits, computed, in the firmware's queue of
  answers, and while that is full the reading stops until one is queued:
  the firmware's timing, which `Session` does not model (verify takes it
  from the firmware's probes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Iterable, Mapping, Union

from .units import DEFAULT_T_DAV_US

VERSION_REPLY = b"SSC32-servoc-0.1\r"

NUM_MAX = 65535
OFFSET_MAX = 100
N_MAX = 250
WIDTH_MIN = 500
WIDTH_MAX = 2500
WIDTH_CAP = 2600            # w is taken as min(w, 2600) before the offset is added
FRAMES_MAX = 65535          # F_S is at most this many frames

CR, LF, ESC, SPACE, TAB = 13, 10, 27, 32, 9

WORDS = ("P", "PO", "S", "T", "Q", "QP", "VER", "STOP", "PL", "SQ")
COMMAND_WORDS = ("Q", "QP", "VER", "STOP", "PL")        # a command line's first item
_PREFIXES = frozenset(w[:i] for w in WORDS for i in range(1, len(w) + 1))


# ----------------------------------------------------------------- commands

@dataclass(frozen=True)
class Entry:
    """An entry `#c ...`. In a group line: width w of `P w`, speed v of `S v` (None without
    S; 0 for `S0`: no speed), offset None. In an offset line: width and speed None, offset o
    of `PO o` clamped to -100..100."""
    channel: int
    width: int | None
    speed: int | None
    offset: int | None = None


@dataclass(frozen=True)
class Group:
    """A group line: its entries with `P`, in line order, and `T t` in ms (None without T)."""
    entries: tuple[Entry, ...]
    time_ms: int | None


@dataclass(frozen=True)
class Offset:
    """An offset line: its `#c PO o` entries, in line order."""
    entries: tuple[Entry, ...]


@dataclass(frozen=True)
class Query:
    """`Q`."""


@dataclass(frozen=True)
class QueryPulse:
    """`QP c`."""
    channel: int


@dataclass(frozen=True)
class Version:
    """`VER`."""


@dataclass(frozen=True)
class Stop:
    """`STOP c` (channel None: `STOP` alone, every servo)."""
    channel: int | None


@dataclass(frozen=True)
class Play:
    """`PL 0 SQ n`."""
    seq: int


Command = Union[Group, Offset, Query, QueryPulse, Version, Stop, Play]


# ----------------------------------------------------------------- the parser

class LineParser:
    """The firmware's line parser, byte by byte.

    `feed(byte)` returns the command a CR or LF completes, else None (also for a bad
    line, an empty line, a line that does nothing whatever the servos, and every byte
    that is no line end); after it, `dropped` is True when the byte was an ESC or a bad
    line's end (the firmware then drops the entries of the line read so far). The state
    carries over from one call to the next, so a line may come in pieces (over several
    frames).

    `holds` (K, `layout.host_holds`): while a group waits, an entry that a '#' ends for a channel
    of `feed`'s `waiting` (where the host's state is in XRAM, the channels the group names; in
    internal RAM, `iram`, every channel with a servo) is held rather than written over the
    group's, K at most until the commit (`commit`); in internal RAM, while an entry is held, so
    is a line's last entry at its end. `held` counts those taken, `joined` those of lines that
    have ended (a line dropped gives back its own)."""

    def __init__(self, holds: int = 0, iram: bool = False, answers: bool = False) -> None:
        self._reset()
        self.dropped = False
        self.holds = holds
        self.iram = iram                # the host's state is in internal RAM (`waiting`)
        self.answers = answers          # Q, QP and VER lines after a group line are read (`joins`)
        self.held = self.joined = 0

    def _reset(self) -> None:
        self.bad = False                # the line is ignored up to its end
        self.hashed = False             # a '#' has been read in the line (an entry begun)
        self.item: str | None = None    # the open item: "#" (a channel number) or a word's letters
        self.digits = False             # a digit has followed the open item
        self.num = 0
        self.sign = 0                   # after PO: +1 for '+', -1 for '-'
        self.items = 0                  # items closed so far in the line
        self.kind: str | None = None    # "group" once a P or S is read, "offset" once a PO is
        self.entry: dict[str, int] | None = None   # the open entry: "C", and "P", "S", "PO"
        self.channel: int | None = None # the open entry's channel until the next '#' or the line end, a T
                                        # read or not (the firmware's HST bit 4 and HCH)
        self.entries: list[Entry] = []
        self.time: int | None = None    # T's number, once T's item has ended
        self.cmd: str | None = None     # the command word (SQ once it follows PL)
        self.arg: int | None = None

    def commit(self) -> None:
        """The group is committed: the entries held are written, every hold is free."""
        self.held = self.joined = 0

    def feed(self, byte: int, waiting: frozenset[int] | None = None) -> Command | None:
        """`waiting`: while a group waits, the channels whose entries are held (`group_waiting`: the
        group's where the state is in XRAM, every servo's in internal RAM with holds; None
        without holds in internal RAM): the entry a '#' ends is held if it is for one of them and
        writes a width or an offset, K at most (`stalls` says where the reading stops first)."""
        hold = waiting is not None and byte == 35 and self.clashes(waiting)
        n = len(self.entries)
        if byte in (CR, LF):
            last = waiting is not None and self.iram and self.held > 0 and self.clashes(waiting)
            cmd = self._end()
            self.dropped = self.bad
            if self.dropped:
                self.held = self.joined
            else:
                self.held += last and len(self.entries) > n
                self.joined = self.held
            self._reset()
            return cmd
        self.dropped = byte == ESC
        if byte == ESC:
            self.held = self.joined
            self._reset()
            return None
        if byte in (SPACE, TAB) or self.bad:
            return None
        if 48 <= byte <= 57:                            # a digit: after '#' or a word
            if self.item is None:
                self.bad = True
            else:
                self.num = min(NUM_MAX, 10 * self.num + byte - 48)
                self.digits = True
        elif byte == 35:                                # '#': an entry starts
            self.hashed = True
            self._close_item()
            if self.cmd is not None or self.time is not None:
                self.bad = True
            if not self.bad:
                self._close_entry()
                self.item = "#"
            if hold and len(self.entries) > n:
                self.held += 1
            self.channel = None
        elif byte in (43, 45):                          # '+' '-': once, right after PO
            if self.item == "PO" and not self.digits and not self.sign:
                self.sign = -1 if byte == 45 else 1
            else:
                self.bad = True
        elif 65 <= byte <= 90 or 97 <= byte <= 122:     # a letter, in either case
            letter = chr(byte).upper()
            if self.item not in (None, "#") and not self.digits:
                self.item += letter                     # the word goes on
            else:
                self._close_item()
                if self.bad:
                    return None
                self.item = letter
            if self.item not in _PREFIXES:
                self.bad = True
        else:
            self.bad = True
        return None

    def stalls(self, byte: int, waiting: frozenset[int] | None = None) -> bool:
        """While a group line read in this frame waits for its commit, the reading stops before
        this byte (it stays queued for the next frame): a '#' that would write an entry where the
        waiting group's are before its line is known to be good; the CR or LF of a line that does
        not `joins` (a command line, an offset line), and in internal RAM with holds (`iram`) the
        end of a line of entries not gone bad once every hold is taken (its last entry would be
        held); and any other control byte 0x08-0x0F or 0x18-0x1F (byte AND 0xE8 is 0x08, the
        firmware's one test): ESC drops a line, the others make one bad or are ignored (TAB).

        The '#': with holds (`holds`), once every hold is taken, a '#' that ends an open entry of
        a line not gone bad (the firmware's test: HST bit 4 and not 5), whatever its servo.
        Without holds: without `waiting` (the host's state in internal RAM), a '#' after a '#' of
        the line being read (it would end that '#''s entry; also once the line has gone bad, as
        the firmware does not look at that); with `waiting`, the channels (with a servo) the
        group gives a width (the state in XRAM, where each entry keeps the generation of its
        line), a '#' that `clashes`."""
        full = self.held >= self.holds and not self.bad
        if byte == 35:
            if self.holds:
                return full and self.channel is not None
            if waiting is None:
                return self.hashed
            return self.clashes(waiting)
        if byte in (CR, LF):
            return not self.joins() or (self.iram and self.holds > 0 and full and self.hashed)
        return byte & 0xE8 == 0x08

    def clashes(self, waiting: frozenset[int]) -> bool:
        """An open entry of a line not gone bad for a channel of `waiting` (with P or not): the
        entry a '#' or line end now ends would be written over one of the group's."""
        return not self.bad and self.channel is not None and self.channel in waiting

    def joins(self) -> bool:
        """A line end now would not end a command or offset line: the line is bad (dropped),
        or has a '#' and no PO (while a group waits it has one entry at most, still open; a word
        after PO makes the line bad), or has nothing (no '#', no word open); with `answers`
        (`flow.reads_answers`), or its open word is Q, QP or VER. The firmware's test: HST bit 5,
        or bit 0 or 4 and HW not PO, or neither and HW 0 (or Q, QP, VER)."""
        if self.bad:
            return True
        if self.hashed:
            return self.item != "PO"
        return self.item is None or (self.answers and self.item in ("Q", "QP", "VER"))

    def _close_item(self) -> None:
        """The open item ends (at '#', at a letter that starts a word, at the line end)."""
        item, n, digits, sign = self.item, self.num, self.digits, self.sign
        if item is None or self.bad:
            return
        self.item, self.num, self.digits, self.sign = None, 0, False, 0
        first = self.items == 0
        self.items += 1
        if item == "#":
            self.entry = {"C": n}
            self.channel = n
            return
        if item not in WORDS or self.time is not None:  # an unfinished word; anything after T
            self.bad = True
        elif item in ("P", "PO", "S"):                  # an entry's field
            kind = "offset" if item == "PO" else "group"
            if self.entry is None or self.kind not in (None, kind):
                self.bad = True
                return
            self.kind = kind
            self.entry[item] = max(-OFFSET_MAX, min(OFFSET_MAX, (sign or 1) * n)) if item == "PO" else n
        elif item == "T":
            if self.kind != "group":                    # T needs a P or S before it
                self.bad = True
                return
            self._close_entry()
            self.time = n
        elif item == "SQ":
            if self.cmd != "PL":
                self.bad = True
                return
            self.cmd, self.arg = "SQ", n
        else:                                           # Q, QP, VER, STOP, PL: the line's first item
            if not first or (item in ("Q", "VER") and digits) or (item == "PL" and n != 0):
                self.bad = True
                return
            self.cmd = item
            self.arg = None if item == "STOP" and not digits else n

    def _close_entry(self) -> None:
        e, self.entry = self.entry, None
        if e is None:
            return
        if "PO" in e:
            self.entries.append(Entry(e["C"], None, None, e["PO"]))
        elif "P" in e:
            self.entries.append(Entry(e["C"], e["P"], e.get("S")))
        # an entry with S only, or with nothing: it does nothing

    def _end(self) -> Command | None:
        self._close_item()
        if self.bad:
            return None
        self._close_entry()
        cmd, arg = self.cmd, self.arg
        if cmd == "Q":
            return Query()
        if cmd == "QP":
            assert arg is not None
            return QueryPulse(arg)
        if cmd == "VER":
            return Version()
        if cmd == "STOP":
            return Stop(arg)
        if cmd == "SQ":
            assert arg is not None
            return Play(arg)
        if cmd == "PL":
            return None                                 # PL 0 without SQ: nothing
        if self.kind == "offset":
            return Offset(tuple(self.entries))
        if self.kind == "group" and self.entries:
            return Group(tuple(self.entries), self.time)
        return None                                     # empty line, `#c` only, entries with S only


def group_waiting(named: frozenset[int], servos: Iterable[int], xram: bool, holds: int) -> frozenset[int] | None:
    """`LineParser.feed`'s and `stalls`' `waiting` while a group waits: `named` (the channels it
    names) where the host's state is in XRAM; in internal RAM, with holds, every channel with a
    servo (`servos`: every entry is held), else None."""
    if xram:
        return named
    return frozenset(servos) if holds else None


def parse_lines(data: bytes) -> list[Command]:
    """The commands a byte string holds (a convenience over `LineParser`)."""
    p = LineParser()
    out = []
    for b in data:
        cmd = p.feed(b)
        if cmd is not None:
            out.append(cmd)
    return out


# ----------------------------------------------------------------- a group move

@dataclass
class Servo:
    """A servo as the host protocol sees it: its channel, its `limit` as inclusive N bounds
    (before reverse and trim), `reverse`, `trim` and its top speed t_DAV (us per N)."""
    channel: int
    lo: int = 0
    hi: int = N_MAX
    reverse: bool = False
    trim: int = 0
    t_dav_us: Fraction = DEFAULT_T_DAV_US


def _clamp(x: int, lo: int, hi: int) -> int:
    return max(lo, min(hi, x))


def _period(period_us: int | Fraction) -> int:
    """P as an int: the frame period is a whole number of us."""
    p = Fraction(period_us)
    if p.denominator != 1 or p <= 0:
        raise ValueError(f"the frame period must be a whole number of us, not {period_us}")
    return p.numerator


def output_n(n: int, lo: int, hi: int, reverse: bool, trim: int) -> int:
    """A servo's output N for the N (0..250) a width gives: clamped to its limit lo..hi,
    reversed (250 - N), + trim, clamped to 0..250 (the firmware computes it as `output_by`)."""
    n = _clamp(n, lo, hi)
    if reverse:
        n = N_MAX - n
    return _clamp(n + trim, 0, N_MAX)


def output_params(lo: int, hi: int, reverse: bool, trim: int) -> tuple[int, int, int, int]:
    """(lo', hi', K, m) with which the firmware computes `output_n` in 8 bits: n' = n clamped to
    lo'..hi', then (K + (n' xor m)) mod 256. lo'..hi' is the part of the limit whose output needs
    no clamp (g(n) = (250 - n if reverse else n) + trim within 0..250: g falls or rises by 1 a
    step, so the clamped ends are where g is 0 or 250); m = 0xFF reverses (K + ~n' = K - 1 - n').
    When no N of the limit gives an output in 0..250, every N gives the same one."""
    def g(n: int) -> int:
        return (N_MAX - n if reverse else n) + trim
    inside = [n for n in range(lo, hi + 1) if 0 <= g(n) <= N_MAX]
    if not inside:
        return lo, lo, (output_n(lo, lo, hi, reverse, trim) - lo) % 256, 0
    if reverse:
        return inside[0], inside[-1], (N_MAX + trim + 1) % 256, 0xFF
    return inside[0], inside[-1], trim % 256, 0


def output_by(params: tuple[int, int, int, int], n: int) -> int:
    """`output_n` as the firmware computes it from `output_params`."""
    lo, hi, k, m = params
    return (k + (_clamp(n, lo, hi) ^ m)) % 256


def target_n(servo: Servo, width: int, offset: int) -> int | None:
    """The output N a width `P w` commands (None for w = 0: pulses stop).

    w' = min(w, 2600) + offset, clamped to 500..2500; N = floor((w' - 500 + 4) / 8);
    then `output_n`: N clamped to the limit; reversed (250 - N); + trim; clamped to 0..250."""
    if width == 0:
        return None
    w = _clamp(min(width, WIDTH_CAP) + offset, WIDTH_MIN, WIDTH_MAX)
    return output_n((w - WIDTH_MIN + 4) // 8, servo.lo, servo.hi, servo.reverse, servo.trim)


def line_offsets(line: Offset, servos_by_channel: Mapping[int, Servo],
                 offsets: Mapping[int, int]) -> dict[int, int]:
    """The offsets after an offset line: its entries in line order (channels with a servo
    only). `offsets` is not changed."""
    out = dict(offsets)
    for e in line.entries:
        if e.offset is not None and e.channel in servos_by_channel:
            out[e.channel] = e.offset
    return out


def time_factor(period_us: int | Fraction) -> int:
    """RT = round(65,536,000 / P), halves up: 65536 x the frames per ms."""
    p = _period(period_us)
    return (2 * 65_536_000 + p) // (2 * p)


def frames_t(time_ms: int, period_us: int | Fraction) -> int:
    """F_T = (t x RT + 32768) >> 16: t ms to the nearest whole frame."""
    return (time_ms * time_factor(period_us) + 32768) >> 16


def speed_t(delta: int, period_us: int | Fraction) -> int:
    """T(|delta|) = ceil(8,000,000 x |delta| / P): |delta| N at 1 us/s, in frames."""
    p = _period(period_us)
    return -(-8_000_000 * abs(delta) // p)


def speed_t_parts(period_us: int | Fraction) -> tuple[int, list[int]]:
    """T(|delta|) as the firmware computes it: |delta| x Q + E(|delta|), Q = 8,000,000 div P and
    E(d) = ceil(d x (8,000,000 mod P) / P) (at most 250: a byte), which is T exactly, since
    d x Q is whole."""
    p = _period(period_us)
    q, r = divmod(8_000_000, p)
    return q, [-(-d * r // p) for d in range(251)]


def frames_s(delta: int, speed: int, period_us: int | Fraction) -> int:
    """F_S = min(65535, ceil(T(|delta|) / v)) = min(65535, ceil(8 |delta| us / (v us/s) / P))
    for `S v` (0 for v = 0: no speed)."""
    if speed == 0:
        return 0
    return min(FRAMES_MAX, -(-speed_t(delta, period_us) // speed))


def frames_top(delta: int, t_dav_us: Fraction, period_us: int | Fraction) -> int:
    """ceil(|delta| x t_DAV / P): the servo's top speed."""
    return math.ceil(abs(delta) * Fraction(t_dav_us) / _period(period_us))


def _widths(group: Group, servos_by_channel: Mapping[int, Servo]) -> dict[int, Entry]:
    """Per channel with a servo, its last entry with P."""
    out: dict[int, Entry] = {}
    for e in group.entries:
        if e.width is not None and e.channel in servos_by_channel:
            out[e.channel] = e
    return out


def names_a_servo(group: Group, servos_by_channel: Mapping[int, Servo]) -> bool:
    """The group has an entry with P for a channel with a servo."""
    return bool(_widths(group, servos_by_channel))


def named(group: Group, servos_by_channel: Mapping[int, Servo]) -> frozenset[int]:
    """The channels with a servo that the group gives a width (its entries where the firmware keeps
    them: `LineParser.stalls`' `waiting`)."""
    return frozenset(_widths(group, servos_by_channel))


def group_move(group: Group, servos_by_channel: Mapping[int, Servo], now: Mapping[int, int | None],
               offsets: Mapping[int, int], period_us: int | Fraction) -> tuple[int, dict[int, int | None]]:
    """F and the targets of a group line.

    `now`: per channel its N in frame i (None or missing: no pulse); `offsets`: per channel
    its offset (missing: 0). Returns (F >= 1, {channel: target N, or None for `P0`}) for
    every channel with a servo that the line gives a width (its last entry with P wins,
    with its S). An empty dict: the line names no servo (a line that does nothing). F is
    the largest of 1, F_T (0 without T), and for each named servo that has a pulse and a
    target N1 (N0 = now): F_S of its `S v` and its top speed. Servos without a pulse are
    set at once and do not count, nor do servos sent `P0`; channels without a servo are
    ignored."""
    frames = 1
    if group.time_ms is not None:
        frames = max(frames, frames_t(group.time_ms, period_us))
    targets: dict[int, int | None] = {}
    for ch, e in _widths(group, servos_by_channel).items():
        servo = servos_by_channel[ch]
        assert e.width is not None
        n1 = target_n(servo, e.width, offsets.get(ch, 0))
        targets[ch] = n1
        n0 = now.get(ch)
        if n1 is None or n0 is None:
            continue
        delta = n1 - n0
        frames = max(frames, frames_top(delta, servo.t_dav_us, period_us))
        if e.speed:
            frames = max(frames, frames_s(delta, e.speed, period_us))
    return frames, targets


def join(first: Group, later: Group) -> Group:
    """Two group lines whose ends are read in one frame, carried out as one: the later line's
    entries after the first's (a channel in both: the later entry), and the last T given."""
    return Group(first.entries + later.entries, later.time_ms if later.time_ms is not None else first.time_ms)


def frame_n(n0: int, n1: int, k: int, frames: int) -> int:
    """Frame k (0..F) of a move: N0 + sgn(delta) x floor(|delta| x k / F + 1/2)."""
    delta = n1 - n0
    step = (2 * abs(delta) * k + frames) // (2 * frames)
    return n0 + step if delta >= 0 else n0 - step


def stops_reading(cmd: Command | None, servos_by_channel: Mapping[int, Servo] | None = None,
                  playing: bool = False) -> bool:
    """The line ends its frame's reading (the bytes after it are read in the next frame): a
    group line that names a servo, an offset line, `PL 0 SQ n` (any n), and `STOP` alone while a
    sequence `PL` started plays (`playing`: it ends the sequence). Without `servos_by_channel`
    every channel counts as one with a servo (a group line with an entry with P stops the
    reading)."""
    if isinstance(cmd, Group):
        if servos_by_channel is None:
            return any(e.width is not None for e in cmd.entries)
        return names_a_servo(cmd, servos_by_channel)
    if isinstance(cmd, Stop):
        return playing and cmd.channel is None
    return isinstance(cmd, (Offset, Play))


# ----------------------------------------------------------------- the session

@dataclass
class Move:
    """The move under way: frame k (0 before its first frame) of F, and per channel still
    moving its (N0, N1)."""
    frames: int
    paths: dict[int, tuple[int, int]]
    k: int = 0


class Session:
    """The firmware's host state over time, frame by frame.

    Between two `frame()` calls (frame i is the one `frame()` returned last, or the start),
    call `line(cmd)` for each command whose line end is read in that frame, in order; it
    returns the reply bytes (b"" for a command without one). A line that `stops_reading`
    must be the frame's last but for group lines after a group line, which join it (`join`):
    `line` raises RuntimeError for another command after it. So a frame holds at most one
    group (`pending`, the group lines that name a servo, joined) or one offset line
    (`pending_offsets`), as its last line. `read` does all this from bytes. `frame()`
    computes frame i + 1: the group line read in frame i makes the move that starts there
    (or the offset line read in frame i sets its offsets), then the move under way advances
    by one frame; it returns {channel: N or None (no pulse)} for every servo.

    `start`: the N at the start (None or missing: no pulse). `sequences`: how many there are
    (n < it), or the numbers `PL 0 SQ n` plays. `plays` records the sequence numbers of
    `PL 0 SQ n` it played: frame i + 1 repeats frame i, and the sequence's own frames, from
    frame i + 2, are `plan.expand`'s (it sets `now` to where they leave the servos, and
    `sequence_running` while they play, to make `Q` answer `+`). Not modelled
    either: the transmit queue (an answer that finds it full, or finds answers before it still
    waiting, waits in the firmware's queue of answers, and while that is full the reading stops:
    then the bytes after it wait more than a frame) and a receive queue that overflows."""

    def __init__(self, servos: Iterable[Servo], period_us: int | Fraction, sequences: int | Iterable[int] = 0,
                 start: Mapping[int, int | None] | None = None, xram: bool = False) -> None:
        self.servos = tuple(servos)
        self.xram = xram                      # the host's state in XRAM: `LineParser.stalls`' `waiting`
        self.period_us = _period(period_us)
        # the sequences `PL 0 SQ n` plays: n < a count, or the numbers given (a sequence that runs `host`
        # itself is not among them)
        self.sequences = frozenset(range(sequences)) if isinstance(sequences, int) else frozenset(sequences)
        self.by_channel: dict[int, Servo] = {}
        for s in self.servos:
            if s.channel in self.by_channel:
                raise ValueError(f"two servos on channel {s.channel}")
            self.by_channel[s.channel] = s
        start = start or {}
        self.now: dict[int, int | None] = {ch: start.get(ch) for ch in self.by_channel}
        self.offsets: dict[int, int] = {ch: 0 for ch in self.by_channel}
        self.move: Move | None = None         # the move under way
        self.pending: Group | None = None     # the group line (naming a servo) read in this frame
        self.pending_offsets: Offset | None = None   # the offset line read in this frame
        self.plays: list[int] = []
        self.sequence_running = False
        self.stop_play = False                # STOP was read while a sequence played: it ends there
        self.replace_play = False             # a group or PL line was read while a sequence played: it ends
                                              # there, and the line is carried out in the next frame
        self.held: set[int] = set()           # channels STOP c holds where they are while a sequence plays
        self.frames = 0                       # frames computed so far
        self.reading_stopped = False          # a line that stops the reading was read in this frame
        self.dropped = False                  # a line was dropped (a bad line's end) after the group
        self.deferred: list[bytes | None] = []  # answers waiting for the group's commit (None: a Q's)

    def moving(self) -> bool:
        """A move has a frame still to come after frame i (k < F) and a servo still on its path, or
        a sequence runs."""
        m = self.move
        return self.sequence_running or (m is not None and m.k < m.frames and bool(m.paths))

    def stops_reading(self, cmd: Command | None) -> bool:
        """The line ends this frame's reading (the module's `stops_reading`, with this session's
        servos)."""
        return stops_reading(cmd, self.by_channel, self.sequence_running)

    def line(self, cmd: Command) -> bytes:
        if not isinstance(cmd, (Group, Offset, Query, QueryPulse, Version, Stop, Play)):
            raise TypeError(f"not a command: {cmd!r}")
        if self.pending is not None and isinstance(cmd, Group):
            if names_a_servo(cmd, self.by_channel):     # it joins the group waiting (else does nothing)
                self.pending = join(self.pending, cmd)
            return b""
        answer = isinstance(cmd, (Query, QueryPulse, Version))
        if self.reading_stopped and not (answer and self.pending is not None):
            raise RuntimeError(f"{cmd!r} read after a line that ends the frame's reading")
        later = self.pending is not None and isinstance(cmd, Query)
        if answer and (later or self.deferred):
            # a Q after a group line: its answer once the group is committed (`answers`); the answers
            # after it go out behind it (theirs as they are read)
            self.deferred.append(None if later else self._answer(cmd))
            return b""
        self.reading_stopped = self.stops_reading(cmd)
        if self.sequence_running and self.reading_stopped and isinstance(cmd, (Group, Play)):
            self.replace_play = True
        if answer:
            return self._answer(cmd)
        if isinstance(cmd, Stop):
            if self.sequence_running:           # STOP ends the sequence in frame i; STOP c holds its
                if cmd.channel is None:         # channel where frame i has it until the sequence ends
                    self.stop_play = True
                elif cmd.channel in self.by_channel:
                    self.held.add(cmd.channel)
            elif cmd.channel is None:
                self.move = None                # every move ends where frame i has it
            elif self.move is not None:
                self.move.paths.pop(cmd.channel, None)
            return b""
        if isinstance(cmd, Play):
            if cmd.seq in self.sequences:
                self.move = None
                self.plays.append(cmd.seq)
            return b""
        if isinstance(cmd, Offset):
            self.pending_offsets = cmd
        elif self.reading_stopped:              # a group line that names a servo
            self.pending = cmd
        return b""

    def _answer(self, cmd: Command) -> bytes:
        """The answer to a `Q`, `QP` or `VER` line now."""
        if isinstance(cmd, Query):
            return b"+" if self.moving() else b"."
        if isinstance(cmd, QueryPulse):
            n = self.now.get(cmd.channel)
            return b"\x00" if n is None else bytes([(WIDTH_MIN + 8 * n) // 10])
        return VERSION_REPLY

    def answers(self) -> bytes:
        """At the start of a reading, the answers that waited for a group's commit (a `Q` line read
        after a group line, where the firmware reads on through it, `LineParser.answers`, and the
        `Q`, `QP` and `VER` lines after it in its frame), once `frame` has committed it, the `Q`'s
        as a `Q` read now answers: they go out before the reading's. The firmware's HAQ entries
        0xFE until host_qs."""
        if self.pending is not None:
            return b""
        q = b"+" if self.moving() else b"."
        out = b"".join(q if a is None else a for a in self.deferred)
        self.deferred = []
        return out

    def read(self, parser: LineParser, data: bytes, limit: int | None = None) -> tuple[bytes, int]:
        """This frame's reading from bytes: `data` (the bytes received, oldest first) goes to
        `parser` byte by byte, each command to `line`, until an offset, `PL` or (while a sequence
        plays) `STOP` line has ended, or, after a group line, before a byte the parser `stalls` at
        (`waiting`: the group's channels, where the state is in XRAM) or after a line dropped (a
        bad line's end); or the bytes run out, or `limit` bytes are read. Returns the replies and
        the number of bytes read; the others wait for the next frame (pass them again after
        `frame()`)."""
        if self.pending is None:
            parser.commit()                     # no group waits: no entry is held
        first = self.answers()
        if (self.reading_stopped and self.pending is None) or self.dropped:
            return first, 0
        out = [first]
        n = len(data) if limit is None else min(limit, len(data))
        for i in range(n):
            waiting = None
            if self.pending is not None:
                if parser.holds and parser.iram == self.xram:
                    raise ValueError("the parser's holds are for the host's state in the other RAM")
                waiting = group_waiting(named(self.pending, self.by_channel), self.by_channel, self.xram,
                                        parser.holds)
                if parser.stalls(data[i], waiting):
                    return b"".join(out), i     # a group waits: the reading stops before this byte
            cmd = parser.feed(data[i], waiting)
            if cmd is not None:
                out.append(self.line(cmd))
            elif self.pending is not None and parser.dropped:
                self.dropped = True             # the group stays; the reading stops until it is committed
                return b"".join(out), i + 1
            if self.reading_stopped and self.pending is None:
                return b"".join(out), i + 1
        return b"".join(out), n

    def _commit(self, group: Group) -> None:
        """The frame's group line becomes the move: the move under way ends."""
        frames, targets = group_move(group, self.by_channel, self.now, self.offsets, self.period_us)
        paths: dict[int, tuple[int, int]] = {}
        for ch, n1 in targets.items():
            n0 = self.now[ch]
            if n1 is None or n0 is None:
                self.now[ch] = n1               # off, or set at once
            elif n1 != n0:
                paths[ch] = (n0, n1)
        self.move = Move(frames, paths)         # the move under way before it ends here

    def set_offsets(self) -> None:
        """The offset line read in this frame sets its offsets (`frame` does it; while a sequence
        `PL` started plays, `plan.expand` does it after each of the sequence's frames' reading)."""
        if self.pending_offsets is not None:
            self.offsets = line_offsets(self.pending_offsets, self.by_channel, self.offsets)
        self.pending_offsets = None

    def frame(self) -> dict[int, int | None]:
        if self.pending is not None:
            self._commit(self.pending)
        self.set_offsets()
        self.pending = None
        m = self.move
        if m is not None:
            m.k += 1
            for ch, (n0, n1) in m.paths.items():
                self.now[ch] = frame_n(n0, n1, m.k, m.frames)
            if m.k >= m.frames:
                self.move = None
        self.reading_stopped = self.dropped = False
        self.frames += 1
        return dict(self.now)
