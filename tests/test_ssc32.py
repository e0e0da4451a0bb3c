"""servoc.ssc32: the model of the SSC-32 host protocol (docs/host-protocol.md).

Every expected value is computed by hand in a comment. P = 20000 us unless said
(RT = round(3276.8) = 3277; T(|d|) = ceil(8,000,000 |d| / 20000) = 400 |d|);
P53 = 5299 us is a whole-us period near the 11.0592 MHz one (4884 machine cycles,
254375/48 = 5299.48 us).
"""

from __future__ import annotations

import re
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servoc.ssc32 import (VERSION_REPLY, Entry, Group, LineParser, Offset, Play, Query, QueryPulse, Servo,
                          Session, Stop, Version, frame_n, frames_s, frames_t, frames_top, group_move,
                          line_offsets, names_a_servo, output_by, output_n, output_params, parse_lines, speed_t,
                          stops_reading, target_n, time_factor)

P20 = 20000
P53 = 5299
FAST = Fraction(1)          # a t_DAV so small that the top speed never decides F (ceil(d/20000) = 1)
HG = Fraction(7400, 3)      # the default t_DAV: 0.74 x 200000 / 60 us per N


# ----------------------------------------------------------------- the parser

def _one(line: bytes):
    """The command of one line (None: bad, or nothing)."""
    p = LineParser()
    out = [p.feed(b) for b in line]
    assert out[:-1] == [None] * (len(line) - 1)
    return out[-1]


def test_a_group_compact():
    assert parse_lines(b"#5P1500S100#6P900T1000\r") == [
        Group((Entry(5, 1500, 100), Entry(6, 900, None)), 1000)]


def test_spaces_tabs_and_case_are_ignored_everywhere():
    # spaces even inside numbers and words: "9 00" is 900, "v e r" is VER
    assert parse_lines(b" # 5 p 1500\ts 100 # 6 P9 00 t 1000\n") == [
        Group((Entry(5, 1500, 100), Entry(6, 900, None)), 1000)]
    assert parse_lines(b"v e r\r\tq\rs T o P\rq p 1 2\r") == [Version(), Query(), Stop(None), QueryPulse(12)]
    # "P O" is PO: the letter O goes on with the word P (no digit after it)
    assert parse_lines(b"#1P O5\r") == [Offset((Entry(1, None, None, 5),))]


def test_feed_returns_a_command_only_at_the_line_end():
    p = LineParser()
    out = [p.feed(b) for b in b"#1P1500\r"]
    assert out[:-1] == [None] * 7
    assert out[-1] == Group((Entry(1, 1500, None),), None)


def test_cr_lf_crlf_and_empty_lines():
    # CR LF is a line end then an empty line; LF CR as well; empty lines do nothing.
    assert parse_lines(b"Q\r\nQ\n\rQ\rQ\n\r\r\n\n") == [Query()] * 4
    # no line end: no command
    assert parse_lines(b"Q") == []


def test_esc_drops_the_line_so_far():
    assert parse_lines(b"#5P1500\x1bQ\r") == [Query()]
    # even a bad line: ESC starts afresh
    assert parse_lines(b"#5P1\xff\x1b#5P1500\r") == [Group((Entry(5, 1500, None),), None)]
    assert parse_lines(b"VER\x1b\r") == []


def test_numbers_saturate_at_65535():
    for line in (b"#1P65535\r", b"#1P65536\r", b"#1P99999\r", b"#1P1234567\r"):
        assert _one(line) == Group((Entry(1, 65535, None),), None)
    # leading zeros do not count
    assert _one(b"#1P00000001500\r") == Group((Entry(1, 1500, None),), None)
    assert _one(b"QP70000\r") == QueryPulse(65535)
    assert _one(b"STOP 70000\r") == Stop(65535)
    # a channel saturates too (no servo has it)
    assert _one(b"#99999P1500\r") == Group((Entry(65535, 1500, None),), None)


def test_a_number_of_no_digits_is_0():
    assert _one(b"#P1500\r") == Group((Entry(0, 1500, None),), None)
    assert _one(b"QP\r") == QueryPulse(0)
    assert _one(b"#3P\r") == Group((Entry(3, 0, None),), None)
    assert _one(b"#3P1500T\r") == Group((Entry(3, 1500, None),), 0)
    assert _one(b"#3P1500S\r") == Group((Entry(3, 1500, 0),), None)
    assert _one(b"PL0SQ\r") == Play(0)
    assert _one(b"#0PO\r") == Offset((Entry(0, None, None, 0),))


def test_offset_lines_with_signs_and_clamped():
    assert parse_lines(b"#0PO-25\r#0PO+25\r#0PO25\r#0 p o - 2 5\r") == [
        Offset((Entry(0, None, None, -25),)), Offset((Entry(0, None, None, 25),)),
        Offset((Entry(0, None, None, 25),)), Offset((Entry(0, None, None, -25),))]
    # clamped to -100..100; a sign without digits is 0
    assert parse_lines(b"#0PO150\r#0PO-99999\r#0PO-\r#0PO+101\r") == [
        Offset((Entry(0, None, None, 100),)), Offset((Entry(0, None, None, -100),)),
        Offset((Entry(0, None, None, 0),)), Offset((Entry(0, None, None, 100),))]
    # several entries, in line order; a channel twice; a second PO in an entry replaces the first
    assert _one(b"#0PO-5#1PO3#0PO7\r") == Offset(
        (Entry(0, None, None, -5), Entry(1, None, None, 3), Entry(0, None, None, 7)))
    assert _one(b"#1PO1PO-2\r") == Offset((Entry(1, None, None, -2),))
    # an entry with nothing in an offset line does nothing
    assert _one(b"#0PO5#1\r") == Offset((Entry(0, None, None, 5),))


def test_a_second_p_or_s_in_an_entry_replaces_the_first():
    assert _one(b"#1P1500P1600\r") == Group((Entry(1, 1600, None),), None)
    assert _one(b"#1P1500S1S2\r") == Group((Entry(1, 1500, 2),), None)
    assert _one(b"#1S5P1500S0\r") == Group((Entry(1, 1500, 0),), None)
    assert _one(b"#1S100P1500\r") == Group((Entry(1, 1500, 100),), None)


def test_a_channel_named_twice_keeps_both_entries_in_line_order():
    # the parser keeps both: group_move takes the later one with P
    assert _one(b"#0P900S1#0P1500\r") == Group((Entry(0, 900, 1), Entry(0, 1500, None)), None)


def test_entries_with_s_only_or_nothing_do_nothing():
    # "#1 S100" has S but no P: dropped; "#3" has nothing
    assert _one(b"#1S100#2P900#3\r") == Group((Entry(2, 900, None),), None)
    # a group line left with no entry with P does nothing: None
    assert _one(b"#1S100\r") is None
    assert _one(b"#1S100T50\r") is None
    assert _one(b"#1\r") is None
    assert _one(b"#\r") is None


def test_t():
    # T needs a P or S before it in the line (not necessarily in its own entry)
    assert _one(b"#1P5#2T10\r") == Group((Entry(1, 5, None),), 10)
    assert _one(b"#1P5 T 1 0\n") == Group((Entry(1, 5, None),), 10)


@pytest.mark.parametrize("line", [
    b"#1P1500X\r",      # a letter that makes no word
    b"#1PPO5\r",        # PP is no word: the O does not save it
    b"#1PP1500\r",
    b"#1PS100\r",       # PS
    b"#1P15O5\r",       # after P's digits O starts a word: O is none
    b"#1P1500Q\r",      # a command word after a group
    b"#1P15\x8000\r",   # a byte 128-255
    b"#1P15\xb200\r",   # 0xB2 is a superscript 2 in Latin-1: no digit
    b"#1P15\x0100\r",   # a control byte
    b"#1P1500,\r",      # punctuation
    b"#1PO--5\r",       # a second sign
    b"#1PO+-5\r",
    b"#1PO5-\r",        # a sign after the digits
    b"#1PO-S5\r",       # letters after the sign go on with PO: POS
    b"#1P-1500\r",      # a sign after P
    b"#1-5\r",
    b"-5\r",
    b"#1P1500PO5\r",    # PO and P in one line
    b"#1PO5P1500\r",
    b"#1PO5S5\r",       # PO and S
    b"#1P1500#2PO5\r",
    b"#1PO5T10\r",      # T after an offset line
    b"#1T100\r",        # T without a P or S before it
    b"T1000\r",
    b"#1P1500T10T20\r",  # T twice
    b"#1P1500T10#2P900\r",  # an entry after T
    b"#1P1500T10S5\r",
    b"#1P1500T10P5\r",
    b"P1500\r",         # P without #
    b"S100\r",
    b"PO5\r",
    b"1500\r",          # a digit with no # or word before it
    b"Q1\r", b"Q0\r", b"QQ\r", b"VE\r", b"VER0\r", b"VERX\r", b"STO\r", b"STOPP\r", b"STOP1#\r",
    b"STOP1Q\r", b"QP1QP2\r", b"Q#1\r", b"#1Q\r", b"#Q\r", b"QPT\r",
    b"PLSQ\r", b"PL SQ 3\r",   # PL SQ is one word: PLSQ
    b"PL0S\r", b"PL0SQ1X\r", b"SQ1\r", b"PL1SQ3\r", b"PL 1 SQ 3\r", b"PL 65536 SQ 0\r",
    b"PL0SQ1SQ2\r", b"PL0SQ1#\r", b"PL0#1P1500\r", b"PL0P1500\r",
])
def test_bad_lines_are_ignored(line):
    p = LineParser()
    assert [p.feed(b) for b in line] == [None] * len(line)
    # and the next line is read afresh
    assert [p.feed(b) for b in b"Q\r"] == [None, Query()]


def test_command_lines():
    assert parse_lines(b"Q\rq\rQP 7\rqp12\rVER\rver\rSTOP\rstop\rSTOP 3\rSTOP0\rSTOP 300\r") == [
        Query(), Query(), QueryPulse(7), QueryPulse(12), Version(), Version(), Stop(None), Stop(None),
        Stop(3), Stop(0), Stop(300)]
    assert parse_lines(b"PL 0 SQ 3\rpl0sq0\rPL 00 SQ 65536\r") == [Play(3), Play(0), Play(65535)]
    # PL 0 without SQ does nothing
    assert _one(b"PL0\r") is None


# A second parser, by regular expressions over the whole line, to compare with the byte-by-byte one.

_WORDS = {"P", "PO", "S", "T", "Q", "QP", "VER", "STOP", "PL", "SQ"}
_COMMANDS = {"Q", "QP", "VER", "STOP", "PL"}
BAD = "bad"                 # a bad line (None: a line that does nothing)


def _reference(raw: bytes):
    """The command of a line (no line end, no ESC in it), BAD or None."""
    raw = bytes(b for b in raw if b not in (9, 32))
    if any(b >= 128 for b in raw):
        return BAD
    s = raw.decode("ascii").upper()
    # items: '#' and digits; letters (and signs) then digits: a letter after digits starts an item
    pieces = re.findall(r"#\d*|[A-Z][A-Z+\-]*\d*", s)
    if "".join(pieces) != s:
        return BAD
    items = []
    for piece in pieces:
        m = re.fullmatch(r"(#|[A-Z]+)([+\-]?)(\d*)", piece)
        if not m or m[1] not in _WORDS | {"#"} or (m[2] and m[1] != "PO"):
            return BAD
        n = min(65535, int(m[3] or "0"))
        items.append((m[1], -n if m[2] == "-" else n, bool(m[3])))
    if not items:
        return None
    word, n, digits = items[0]
    if word in _COMMANDS:
        rest = items[1:]
        if word == "PL":
            if n != 0 or len(rest) > 1 or (rest and rest[0][0] != "SQ"):
                return BAD
            return Play(rest[0][1]) if rest else None
        if rest or (word in ("Q", "VER") and digits):
            return BAD
        return {"Q": Query(), "VER": Version(), "QP": QueryPulse(n), "STOP": Stop(n if digits else None)}[word]
    words = [w for w, _, _ in items]
    if _COMMANDS & set(words) or "SQ" in words or words[0] != "#":
        return BAD
    time = None
    if "T" in words:
        if words.index("T") != len(words) - 1 or not {"P", "S"} & set(words):
            return BAD
        time = items.pop()[1]
    has_po, has_ps = "PO" in words, bool({"P", "S"} & set(words))
    if has_po and has_ps:
        return BAD
    entries: list[tuple[int, dict]] = []
    for w, n, _ in items:
        if w == "#":
            entries.append((n, {}))
        else:
            entries[-1][1][w] = n
    if has_po:
        return Offset(tuple(Entry(c, None, None, max(-100, min(100, f["PO"]))) for c, f in entries if "PO" in f))
    group = tuple(Entry(c, f["P"], f.get("S")) for c, f in entries if "P" in f)
    return Group(group, time) if group else None


def _reference_events(data: bytes):
    """("cmd", command) at each line end with a command, ("drop",) at each ESC and bad line's end."""
    out = []
    pieces = re.split(rb"[\r\n]", data)
    for k, piece in enumerate(pieces):
        out += [("drop",)] * piece.count(27)
        if k == len(pieces) - 1:
            break                                   # no line end
        cmd = _reference(piece[piece.rindex(27) + 1:] if 27 in piece else piece)
        if cmd == BAD:
            out.append(("drop",))
        elif cmd is not None:
            out.append(("cmd", cmd))
    return out


def _events(data: bytes):
    p = LineParser()
    out = []
    for b in data:
        cmd = p.feed(b)
        if p.dropped:
            out.append(("drop",))
        if cmd is not None:
            out.append(("cmd", cmd))
    return out


def _reference_stream(data: bytes):
    return [e[1] for e in _reference_events(data) if e[0] == "cmd"]


def test_the_reference_parser_agrees_on_the_examples():
    data = (b"#5P1500S100#6P900T1000\r#1PPO5\rPL 0 SQ 3\r#1P15O5\rQP\r#1S100#2P900#3\r"
            b"#0PO-99999\r\x1bVER\n#1P1500T10T20\rstop 4\r#1P O-5\rPLSQ\r#1S5T9\rPL0\r\r")
    assert _reference_events(data) == _events(data)
    assert _reference_stream(data) == parse_lines(data)
    # #1PPO5, #1P15O5, T twice, PLSQ are bad, and the ESC drops; #1S5T9, PL0 and the empty line do nothing
    assert len(parse_lines(data)) == 8
    assert _events(data).count(("drop",)) == 5


def test_dropped_tells_esc_and_bad_line_ends():
    p = LineParser()
    assert [(p.feed(b), p.dropped) for b in b"X\r"] == [(None, False), (None, True)]
    # lines that do nothing are not bad; ESC drops
    assert [p.dropped for b in b"#1S5\rPL0\r\r\x1b" if p.feed(b) is None] == [False] * 10 + [True]
    # VE is bad only when its item ends, at the line end
    assert [p.dropped for b in b"VE\r" if p.feed(b) is None] == [False, False, True]


TOKENS = [b"#", b"P", b"p", b"O", b"o", b"S", b"T", b"Q", b"V", b"E", b"R", b"L", b"+", b"-",
          b"0", b"1", b"5", b"9", b"15", b"99999", b"123456", b" ", b"\t", b"\r", b"\n", b"\x1b",
          b"PO", b"PL", b"SQ", b"QP", b"VER", b"STOP", b"PL0", b"PL0SQ", b"#1P1500", b"#2 PO-25",
          b"S100", b"T1000", b"#3S5", b"PP", b"x", b",", b"\x00", b"\xb2", b"\xff", b"\r\n"]


@settings(max_examples=800, deadline=None)
@given(st.lists(st.sampled_from(TOKENS), max_size=40))
def test_parser_matches_the_reference_on_token_streams(tokens):
    data = b"".join(tokens)
    assert _events(data) == _reference_events(data)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=60))
def test_parser_matches_the_reference_on_any_bytes(data):
    assert _events(data) == _reference_events(data)


# ----------------------------------------------------------------- widths

@pytest.mark.parametrize("width, n", [
    (1500, 125),    # (1000 + 4) // 8 = 125
    (900, 50),      # 404 // 8 = 50
    (1000, 63),     # 504 // 8 = 63: 62.5 rounds up
    (999, 62),      # 503 // 8 = 62: 62.375
    (1504, 126),    # 1008 // 8
    (2500, 250),    # 2004 // 8
    (2600, 250),    # clamped to 2500
    (3000, 250),    # min(3000, 2600) = 2600 -> 2500
    (65535, 250),
    (1, 0),         # clamped to 500: 4 // 8 = 0
    (499, 0),
])
def test_width_to_n(width, n):
    assert target_n(Servo(0), width, 0) == n


def test_width_0_stops_the_pulses():
    assert target_n(Servo(0), 0, 0) is None
    assert target_n(Servo(0), 0, 100) is None


def test_limits_reverse_trim():
    lim = Servo(0, lo=50, hi=200)
    assert target_n(lim, 800, 0) == 50      # (300 + 4) // 8 = 38 -> 50
    assert target_n(lim, 2400, 0) == 200    # (1900 + 4) // 8 = 238 -> 200
    assert target_n(lim, 1500, 0) == 125
    assert target_n(Servo(0, reverse=True), 900, 0) == 200      # 250 - 50
    assert target_n(Servo(0, trim=-3), 900, 0) == 47
    assert target_n(Servo(0, trim=5), 2500, 0) == 250           # 255 -> 250
    assert target_n(Servo(0, trim=-5), 500, 0) == 0             # -5 -> 0
    # all: 2400 -> 238 -> limit 200 -> reverse 50 -> trim 60
    assert target_n(Servo(0, lo=50, hi=200, reverse=True, trim=10), 2400, 0) == 60


def test_output_n():
    # the per-servo step after the width's N: limit, reverse, trim, 0..250
    assert output_n(38, 50, 200, False, 0) == 50
    assert output_n(238, 50, 200, True, 10) == 60      # 200 -> 50 -> 60
    assert output_n(0, 0, 250, True, 0) == 250
    assert output_n(250, 0, 250, False, 5) == 250      # 255 -> 250
    assert output_n(3, 0, 250, False, -5) == 0         # -2 -> 0


def test_offsets_are_added_before_the_clamp():
    assert target_n(Servo(0), 1500, 4) == 126        # 1504
    assert target_n(Servo(0), 1500, -4) == 125       # 1496: (996 + 4) // 8
    assert target_n(Servo(0), 1500, -5) == 124       # 1495: 999 // 8
    assert target_n(Servo(0), 2490, 100) == 250      # 2590 -> 2500
    assert target_n(Servo(0), 550, -100) == 0        # 450 -> 500
    assert target_n(Servo(0), 590, -100) == 0        # 490 -> 500
    assert target_n(Servo(0), 604, -100) == 1        # 504: 8 // 8
    assert target_n(Servo(0), 65535, -100) == 250    # 2600 - 100 = 2500
    assert target_n(Servo(0), 1, -100) == 0          # -99 -> 500


@given(st.integers(1, 65535), st.integers(1, 65535), st.integers(-100, 100), st.integers(-10, 10))
def test_width_to_n_is_monotone_and_in_range(w1, w2, offset, trim):
    s = Servo(0, trim=trim)
    a, b = target_n(s, min(w1, w2), offset), target_n(s, max(w1, w2), offset)
    assert 0 <= a <= b <= 250
    r = Servo(0, reverse=True, trim=trim)
    assert target_n(r, min(w1, w2), offset) >= target_n(r, max(w1, w2), offset)


# ----------------------------------------------------------------- the F terms

def test_time_factor():
    assert time_factor(20000) == 3277                 # 3276.8
    assert time_factor(Fraction(20000)) == 3277
    assert time_factor(P53) == 12368                  # 12367.6165
    assert time_factor(1048576) == 63                 # 62.5 exactly: halves go up
    assert time_factor(5242880) == 13                 # 12.5
    assert time_factor(65536000) == 1


def test_a_period_of_no_whole_us_is_refused():
    for bad in (Fraction(254375, 48), Fraction(1, 2), 0, -20000):
        with pytest.raises(ValueError):
            time_factor(bad)
    with pytest.raises(ValueError):
        Session([Servo(0)], Fraction(254375, 48))


def test_frames_t():
    # (t x 3277 + 32768) >> 16
    assert frames_t(1000, P20) == 50      # 3,309,768 / 65536 = 50.50
    assert frames_t(2000, P20) == 100     # 6,586,768 / 65536 = 100.51
    assert frames_t(500, P20) == 25       # 1,671,268 / 65536 = 25.50
    assert frames_t(100, P20) == 5        # 360,468 / 65536 = 5.50
    assert frames_t(30, P20) == 2         # 131,078 / 65536 = 2.0001
    assert frames_t(29, P20) == 1         # 127,801 / 65536 = 1.95
    assert frames_t(10, P20) == 1         # 65,538 / 65536
    assert frames_t(9, P20) == 0          # 62,261 / 65536
    assert frames_t(0, P20) == 0
    assert frames_t(65535, P20) == 3277   # 214,791,963 / 65536 = 3277.47
    assert frames_t(1000, P53) == 189     # (12,368,000 + 32768) / 65536 = 189.22


def test_speed_t():
    assert speed_t(0, P20) == 0
    assert speed_t(1, P20) == 400         # 8,000,000 / 20,000
    assert speed_t(-25, P20) == 10000
    assert speed_t(250, P20) == 100000
    assert speed_t(1, P53) == 1510        # 8,000,000 / 5299 = 1509.72
    assert speed_t(250, P53) == 377430    # 2,000,000,000 / 5299 = 377429.7


def test_speed_t_fits_three_bytes_at_the_shortest_period():
    assert speed_t(250, 2000) < 1 << 24


def test_frames_s_and_top():
    assert frames_s(25, 100, P20) == 100      # 200 us at 100 us/s: 2 s, 100 frames exactly
    assert frames_s(-25, 100, P20) == 100
    assert frames_s(25, 96, P20) == 105       # 2.0833 s: 104.17 frames, to the next whole one
    assert frames_s(25, 1, P20) == 10000      # 200 s
    assert frames_s(25, 15, P20) == 667       # 13.33 s: 666.67 frames
    assert frames_s(1, 500, P53) == 4         # ceil(1510 / 500): 16 ms is 3.02 frames of 5.299 ms
    assert frames_s(250, 1, P53) == 65535     # 377,430 frames: at most 65535
    assert frames_s(250, 5, P53) == 65535     # 75,486
    assert frames_s(250, 6, P53) == 62905     # ceil(377430 / 6) = 62905
    assert frames_s(25, 0, P20) == 0
    assert frames_s(0, 100, P20) == 0
    assert frames_top(25, HG, P20) == 4       # ceil(185000/3 / 20000) = ceil(3.08)
    assert frames_top(-125, HG, P20) == 16    # ceil(925000/3 / 20000) = ceil(15.42)
    assert frames_top(10, HG, P53) == 5       # ceil(74000/3 / 5299) = ceil(4.65)


# ----------------------------------------------------------------- F of a group

def _g(line: bytes) -> Group:
    (g,) = parse_lines(line + b"\r")
    return g


def _move(line, servos, now, period=P20, offsets=None):
    by = {s.channel: s for s in servos}
    return group_move(_g(line), by, now, offsets or {}, period)


def test_f_from_t_only():
    fast = [Servo(0, t_dav_us=FAST)]
    assert _move(b"#0P1500T1000", fast, {0: 100}) == (50, {0: 125})
    assert _move(b"#0P1500T30", fast, {0: 100})[0] == 2
    assert _move(b"#0P1500T29", fast, {0: 100})[0] == 1
    assert _move(b"#0P1500T9", fast, {0: 100})[0] == 1       # F_T = 0: 1
    assert _move(b"#0P1500T0", fast, {0: 100})[0] == 1
    # even when nothing moves
    assert _move(b"#0P1500T1000", fast, {0: 125}) == (50, {0: 125})
    assert _move(b"#0P1500T1000", fast, {0: 100}, P53) == (189, {0: 125})


def test_f_from_s_only():
    fast = [Servo(0, t_dav_us=FAST)]
    # S100, |d| = 25: 200 us at 100 us/s, 2 s: ceil(10000 / 100) = 100
    assert _move(b"#0P1500S100", fast, {0: 100}) == (100, {0: 125})
    # S99: ceil(10000 / 99) = ceil(101.01) = 102
    assert _move(b"#0P1500S99", fast, {0: 100}) == (102, {0: 125})
    # S1: 10000; S15: ceil(666.67) = 667
    assert _move(b"#0P1500S1", fast, {0: 100})[0] == 10000
    assert _move(b"#0P1500S15", fast, {0: 100})[0] == 667
    # S0: no speed
    assert _move(b"#0P1500S0", fast, {0: 100})[0] == 1
    # S1000, |d| = 125: ceil(50000 / 1000) = 50
    assert _move(b"#0P1500S1000", fast, {0: 0})[0] == 50
    # S5000: 10; S65535 (and anything above, read as 65535): ceil(50000 / 65535) = 1
    assert _move(b"#0P1500S5000", fast, {0: 0})[0] == 10
    assert _move(b"#0P1500S99999", fast, {0: 0})[0] == 1
    # at P53: S100, |d| = 10: T = ceil(80,000,000 / 5299) = 15098: ceil(150.98) = 151
    assert _move(b"#0P580S100", fast, {0: 0}, P53) == (151, {0: 10})


def test_f_from_the_top_speed_only():
    hg = [Servo(0)]
    assert _move(b"#0P1500", hg, {0: 100}) == (4, {0: 125})      # |d| 25: ceil(3.08)
    assert _move(b"#0P1500", hg, {0: 0}) == (16, {0: 125})       # |d| 125: ceil(15.42)
    assert _move(b"#0P580", hg, {0: 0}, P53) == (5, {0: 10})     # ceil(4.65)
    assert _move(b"#0P1500", hg, {0: 125}) == (1, {0: 125})      # no move: 1


def test_f_the_largest_wins():
    hg = [Servo(0)]
    # 0 -> 125: top 16, S1000 50, T500 25 -> 50
    assert _move(b"#0P1500S1000T500", hg, {0: 0})[0] == 50
    # T2000: 100 wins
    assert _move(b"#0P1500S1000T2000", hg, {0: 0})[0] == 100
    # S5000 10, T100 5; top 16 wins
    assert _move(b"#0P1500S5000T100", hg, {0: 0})[0] == 16
    # across servos: #0 top 4 (|d| 25), #1 S99 |d| 50: ceil(20000 / 99) = ceil(202.02) = 203
    two = [Servo(0), Servo(1, t_dav_us=FAST)]
    assert _move(b"#0P1500#1P900S99", two, {0: 100, 1: 0}) == (203, {0: 125, 1: 50})


def test_new_servos_are_set_at_once_and_off_servos_do_not_count():
    two = [Servo(0), Servo(1)]
    # #0 has no pulse: it does not count; #1 0 -> 50: ceil(50 x 7400/3 / 20000) = ceil(6.17) = 7
    assert _move(b"#0P2500S1#1P900", two, {0: None, 1: 0}) == (7, {0: 250, 1: 50})
    assert _move(b"#0P2500S1", two, {0: None, 1: 0}) == (1, {0: 250})
    assert _move(b"#0P2500S1", two, {1: 0}) == (1, {0: 250})     # missing: no pulse
    # P0: off, no part in F (S1 ignored)
    assert _move(b"#0P0S1#1P900", two, {0: 200, 1: 0}) == (7, {0: None, 1: 50})


def test_channels_without_a_servo_and_channels_named_twice():
    one = [Servo(0)]
    by = {0: one[0]}
    assert _move(b"#7P900S1#0P1500", one, {0: 125}) == (1, {0: 125})
    assert _move(b"#7P900", one, {0: 125}) == (1, {})       # names no servo: nothing
    assert not names_a_servo(_g(b"#7P900"), by) and names_a_servo(_g(b"#7P900#0P0"), by)
    # the later entry with P replaces the earlier, its S with it (none: top 4 for |d| 25)
    assert _move(b"#0P900S1#0P1500", one, {0: 100}) == (4, {0: 125})
    # |d| 50, S100: 400 us at 100 us/s: 200 (top 7)
    assert _move(b"#0P1500#0P900S100", one, {0: 100}) == (200, {0: 50})


def test_offsets_in_a_group_move():
    by = {0: Servo(0), 1: Servo(1)}
    # 1510 -> (1010 + 4) // 8 = 126
    assert group_move(_g(b"#0P1500"), by, {0: 125}, {0: 10}, P20)[1] == {0: 126}
    assert group_move(_g(b"#0P1500"), by, {0: 125}, {}, P20)[1] == {0: 125}
    (off,) = parse_lines(b"#0PO10#1PO-3#7PO5#0PO20\r")
    # line order, channels with a servo only
    assert line_offsets(off, by, {0: 0, 1: 0}) == {0: 20, 1: -3}


# ----------------------------------------------------------------- frames

def test_frame_n_by_hand():
    # 0 -> 10 in 4: floor(2.5 + .5) = 3, 5, floor(7.5 + .5) = 8, 10
    assert [frame_n(0, 10, k, 4) for k in range(5)] == [0, 3, 5, 8, 10]
    assert [frame_n(10, 0, k, 4) for k in range(5)] == [10, 7, 5, 2, 0]
    assert [frame_n(7, 7, k, 3) for k in range(4)] == [7, 7, 7, 7]
    assert frame_n(0, 250, 1, 1) == 250


@given(st.integers(0, 250), st.integers(0, 250), st.integers(1, 2000))
def test_frame_n_lands_and_is_monotone(n0, n1, frames):
    ns = [frame_n(n0, n1, k, frames) for k in range(frames + 1)]
    assert ns[0] == n0 and ns[-1] == n1
    steps = [b - a for a, b in zip(ns, ns[1:])]
    assert all(s * (n1 - n0) >= 0 for s in steps)            # never backwards
    assert all(abs(s) <= -(-abs(n1 - n0) // frames) for s in steps)   # at most ceil(|d| / F) a frame


# ----------------------------------------------------------------- the session

def _line(session, text: bytes) -> bytes:
    return b"".join(session.line(c) for c in parse_lines(text))


def _two():
    # t_DAV = P/10 = 2000 us: |d| N take ceil(|d| / 10) frames at P20
    return Session([Servo(0, t_dav_us=Fraction(2000)), Servo(1, t_dav_us=Fraction(2000))], P20,
                   start={0: 0, 1: 250})


def test_a_move_frame_by_frame_and_q():
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, start={0: 0})
    p = LineParser()
    # Q before the group sees no move; the group ends the frame's lines: the reading goes on into
    # the Q after it and stops before its CR, which waits for the next frame
    assert s.read(p, b"Q\r#0P900\rQ\r") == (b".", 10)
    assert s.pending == Group((Entry(0, 900, None),), None)
    # 0 -> 50 in F = 5: (100k + 5) // 10 = 10, 20, 30, 40, 50
    assert s.frame() == {0: 10}
    assert s.pending is None
    assert s.read(p, b"\r") == (b"+", 1)
    got = []
    for _ in range(4):
        got.append(s.frame()[0])
        got.append(_line(s, b"Q\r"))
    assert got == [20, b"+", 30, b"+", 40, b"+", 50, b"."]
    assert s.frame() == {0: 50}
    assert s.frames == 6


def test_a_new_group_replaces_the_move_under_way():
    s = _two()
    # #0 0 -> 50 (5 frames), #1 250 -> (1200 + 4) // 8 = 150 (10 frames): F = 10
    _line(s, b"#0P900#1P1700\r")
    # #0: (100k + 10) // 20 -> 5, 10; #1: 250 - (200k + 10) // 20 -> 240, 230
    assert s.frame() == {0: 5, 1: 240}
    assert s.frame() == {0: 10, 1: 230}
    assert _line(s, b"Q\r") == b"+"
    # #0 10 -> 0: F = 1; #1 is not named: its move ends at 230
    _line(s, b"#0P500\r")
    assert s.frame() == {0: 0, 1: 230}
    assert _line(s, b"Q\r") == b"."
    assert s.frame() == {0: 0, 1: 230}


def test_group_lines_that_end_in_one_frame_join_into_one_group():
    s = _two()
    p = LineParser()
    data = b"#0P900\r#1P1700T200\rQ\r#7P2500T5000\r#0P1000\rQ\r"
    # the first group line ends the frame's lines; the second ends in the same frame and joins it;
    # the reading stops before the Q's CR (7 + 12 + 1 bytes)
    assert s.read(p, data) == (b"", 20)
    assert s.pending == Group((Entry(0, 900, None), Entry(1, 1700, None)), 200)
    # one group: #0 0 -> 50, top 5; #1 250 -> 150, top 10; T200: (655,400 + 32768) >> 16 = 10:
    # F = 10; #0: (100k + 10) // 20 = 5, #1: 250 - (200k + 10) // 20 = 240
    assert s.frame() == {0: 5, 1: 240}
    # Q's CR (k = 1 < 10), #7 names no servo: it does not stop the reading, its T5000 counts for
    # nothing; #0P1000 does, and the last Q is read up to its CR (1 + 13 + 8 + 1 bytes)
    data = data[20:]
    assert s.read(p, data) == (b"+", 23)
    assert s.pending == Group((Entry(0, 1000, None),), None)
    # #0 5 -> (500 + 4) // 8 = 63, |d| 58: F = ceil(5.8) = 6; #1's move ends at 240
    # #0: 5 + (116k + 6) // 12 = 15, 24, 34, 44, 53, 63
    assert s.frame() == {0: 15, 1: 240}
    assert s.read(p, data[23:]) == (b"+", 1)
    assert [s.frame() for _ in range(5)] == [{0: n, 1: 240} for n in (24, 34, 44, 53, 63)]
    assert _line(s, b"Q\r") == b"."


def test_a_joined_group_takes_the_last_t_given():
    s = Session([Servo(0, t_dav_us=FAST), Servo(1, t_dav_us=FAST)], P20, start={0: 0, 1: 0})
    p = LineParser()
    data = b"#0P900T400\r#1P900T100\r"
    assert s.read(p, data) == (b"", 22)
    # T100, not the longest: (327,700 + 32768) >> 16 = 5; both 0 -> 50: (100k + 5) // 10
    frames, _ = group_move(s.pending, s.by_channel, s.now, s.offsets, P20)
    assert frames == 5
    assert [s.frame() for _ in range(5)] == [{0: n, 1: n} for n in (10, 20, 30, 40, 50)]
    # a line without T keeps the T of the lines before it: T400, (1,310,800 + 32768) >> 16 = 20;
    # 50 -> 0: 50 - (100k + 20) // 40 = 47 first
    assert s.read(p, b"#0P500T400\r#1P500\r") == (b"", 18)
    assert s.pending.time_ms == 400
    assert s.frame() == {0: 47, 1: 47}
    assert [s.frame()[0] for _ in range(19)][-1] == 0
    assert _line(s, b"Q\r") == b"."


def test_a_second_group_replaces_the_first_from_where_its_frame_left_the_servos():
    s = _two()
    p = LineParser()
    assert s.read(p, b"#0P900\r") == (b"", 7)
    # 0 -> 50 in 5
    assert s.frame() == {0: 10, 1: 250}
    assert s.read(p, b"#0P1500S1000\r") == (b"", 13)
    # from 10, not 0: 10 -> 125, |d| 115: top ceil(11.5) = 12; S1000: 920 us at 1000 us/s:
    # 0.92 s, 46 frames: F = 46; 10 + (230k + 46) // 92: k = 1: 276 // 92 = 3
    assert s.frame() == {0: 13, 1: 250}
    ns = [s.frame()[0] for _ in range(45)]
    # k = 45: 10 + (10,350 + 46) // 92 = 10 + 113 = 123; k = 46: 125
    assert ns[-2] == 123 and ns[-1] == 125


def test_a_group_that_names_no_servo_does_nothing():
    s = _two()
    _line(s, b"#0P900\r")
    assert s.frame() == {0: 10, 1: 250}
    # channel 7 has no servo: the move goes on, its T counts for nothing, the reading goes on
    assert _line(s, b"#7P1500T5000\rQ\r") == b"+"
    assert s.pending is None and not s.reading_stopped
    assert s.frame() == {0: 20, 1: 250}


def test_stop_one_and_stop_all_at_once():
    s = _two()
    _line(s, b"#0P900#1P1700\r")
    s.frame()
    s.frame()
    # STOP 1 takes effect at once; the move has frames to come
    assert _line(s, b"STOP 1\rQ\r") == b"+"
    # #0 goes on: (300 + 10) // 20 = 15
    assert s.frame() == {0: 15, 1: 230}
    assert _line(s, b"Q\r") == b"+"
    # STOP: the move ends at once, Q in the same frame sees it
    assert _line(s, b"STOP\rQ\r") == b"."
    assert s.frame() == {0: 15, 1: 230}
    assert _line(s, b"Q\r") == b"."
    assert s.frame() == {0: 15, 1: 230}
    # STOP of a channel without a servo, past 255, or without a move: nothing
    _line(s, b"STOP 9\rSTOP 300\rSTOP 0\r")
    assert s.frame() == {0: 15, 1: 230}


def test_stop_after_a_group_is_read_in_the_next_frame():
    s = _two()
    p = LineParser()
    data = b"#1P1700\rSTOP\rQ\r"
    # the group ends the frame's lines: the STOP after it is read up to its CR, and cannot drop it
    assert s.read(p, data) == (b"", 12)
    # #1 250 -> 150 in 10
    assert s.frame() == {0: 0, 1: 240}
    # STOP, in the next frame, ends the move where frame 1 left #1; Q in the same frame sees it
    assert s.read(p, data[12:]) == (b".", 3)
    assert s.frame() == {0: 0, 1: 240}
    # STOP, then a group in the same frame: the group stays; #1 240 -> 250, |d| 10: F = 1
    assert s.read(p, b"STOP\r#1P2500\r") == (b"", 13)
    assert s.frame() == {0: 0, 1: 250}


def test_stop_c_after_a_group_is_read_in_the_next_frame():
    s = _two()
    p = LineParser()
    data = b"#0P900#1P1700\rSTOP 1\r"
    # the group (14 bytes), F = 10: #0 (100k + 10) // 20, #1 250 - (200k + 10) // 20
    assert s.read(p, data) == (b"", 20)       # and STOP 1 up to its CR
    assert s.frame() == {0: 5, 1: 240}
    # STOP 1 in the next frame: #1 stops at 240, #0 goes on
    assert s.read(p, data[20:]) == (b"", 1)
    assert s.frame() == {0: 10, 1: 240}
    for _ in range(7):
        s.frame()
    assert _line(s, b"Q\r") == b"+"
    assert s.frame() == {0: 50, 1: 240}
    assert _line(s, b"Q\r") == b"."
    # P0 then STOP 0: the P0 is read first, in a frame of its own: #0's pulses stop
    assert s.read(p, b"#0P0\rSTOP 0\r") == (b"", 11)
    assert s.frame() == {0: None, 1: 240}
    assert s.read(p, b"\r") == (b"", 1)
    assert s.frame() == {0: None, 1: 240}


def test_stop_c_of_every_servo_leaves_no_move_under_way():
    # STOP 0 ends the only servo's part of the move: its frames go on, but no servo is on its way,
    # so Q answers '.'; with a second servo still moving it answers '+' until its last frame
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, start={0: 0})
    _line(s, b"#0P900\r")                 # F = 5
    assert s.frame() == {0: 10}
    assert _line(s, b"STOP 0\rQ\r") == b"."
    got = []
    for _ in range(4):                    # frames 2..5 of 5: #0 stays at 10
        got.append(s.frame()[0])
        got.append(_line(s, b"Q\r"))
    assert got == [10, b".", 10, b".", 10, b".", 10, b"."]
    s = Session([Servo(0, t_dav_us=Fraction(2000)), Servo(1, t_dav_us=Fraction(2000))], P20, start={0: 0, 1: 0})
    _line(s, b"#0P900#1P900\r")
    s.frame()
    assert _line(s, b"STOP 0\rQ\r") == b"+"
    answers = []
    for _ in range(4):
        s.frame()
        answers.append(_line(s, b"Q\r"))
    assert answers == [b"+", b"+", b"+", b"."]


def test_new_servo_set_at_once_and_t_holds_q():
    s = Session([Servo(0), Servo(1, t_dav_us=Fraction(2000))], P20, start={1: 0})
    # #0 has no pulse: 125 at once; #1 0 -> 50 takes 5; T1000 gives 50 frames
    _line(s, b"#0P1500#1P900T1000\r")
    # #1: floor(50 x 1/50 + 1/2) = 1
    assert s.frame() == {0: 125, 1: 1}
    for _ in range(48):
        s.frame()
    assert _line(s, b"Q\r") == b"+"       # after frame 49 of 50
    assert s.frame() == {0: 125, 1: 50}
    assert _line(s, b"Q\r") == b"."


def test_a_move_in_which_nothing_moves_is_no_move_under_way():
    # #0 goes 0 -> 0, #1 is turned off: F = F_T(100) = 5 frames, but no servo is on its way: '.'
    s = _two()
    _line(s, b"#0P500#1P0T100\r")
    assert s.frame() == {0: 0, 1: None}
    answers = []
    for _ in range(4):
        answers.append(_line(s, b"Q\r"))
        s.frame()
    assert answers == [b"."] * 4 and _line(s, b"Q\r") == b"."
    assert s.move is None


def test_p0_turns_the_pulses_off_and_qp():
    s = _two()
    # QP: 500 + 8 x 0 = 500 -> 50; 500 + 8 x 250 = 2500 -> 250; no servo: 0
    assert _line(s, b"QP0\rQP1\rQP5\rQP300\r") == bytes([50, 250, 0, 0])
    # QP in the group's frame (before it): frame i's N
    assert _line(s, b"QP0\r#0P0#1P1500\r") == bytes([50])
    # #1 250 -> 125 in 13: 250 - (250 + 13) // 26 = 250 - 10 = 240
    assert s.frame() == {0: None, 1: 240}
    # no pulse: 0; 500 + 8 x 240 = 2420 -> 242
    assert _line(s, b"QP0\rQP1\r") == bytes([0, 242])
    # #0 has no pulse now: set at once; the group ends #1's move at 240
    _line(s, b"#0P580\r")
    assert s.frame() == {0: 10, 1: 240}
    # 580 -> 58 = ":"
    assert _line(s, b"QP0\r") == b":"


def test_qp_floor():
    s = Session([Servo(0)], P20, start={0: 1})
    # 508 / 10 -> 50
    assert _line(s, b"QP\r") == bytes([50])
    s = Session([Servo(0)], P20)
    assert _line(s, b"QP\r") == b"\x00"


def test_offsets_persist_and_apply_to_later_groups():
    s = Session([Servo(0, t_dav_us=FAST)], P20, start={0: 0})
    _line(s, b"#0PO4\r")
    assert s.frame() == {0: 0}          # an offset line is no move
    assert s.offsets == {0: 4}
    _line(s, b"#0P1500\r")
    assert s.frame() == {0: 126}        # 1504
    _line(s, b"#7PO4\r")                # no servo: ignored
    s.frame()
    assert s.offsets == {0: 4}
    _line(s, b"#0PO-100#0PO-60\r")      # the later entry wins
    s.frame()
    assert s.offsets == {0: -60}
    _line(s, b"#0P560\r")               # 500 -> (0 + 4) // 8 = 0
    assert s.frame() == {0: 0}


def test_an_offset_line_after_a_group_is_read_in_the_next_frame():
    s = Session([Servo(0, t_dav_us=FAST)], P20, start={0: 0})
    p = LineParser()
    data = b"#0P1500\r#0PO40\r"
    # the group uses the offset before the line: 1500 -> 125
    assert s.read(p, data) == (b"", 14)       # and the offset line up to its CR
    assert s.frame() == {0: 125}
    assert s.offsets == {0: 0}
    # then the offset line ends, alone in its frame: no move
    assert s.read(p, data[14:]) == (b"", 1)
    assert s.pending_offsets == Offset((Entry(0, None, None, 40),))
    assert s.frame() == {0: 125}
    assert s.offsets == {0: 40} and s.pending_offsets is None
    # 1540: (1040 + 4) // 8 = 130
    _line(s, b"#0P1500\r")
    assert s.frame() == {0: 130}


def test_an_offset_line_does_not_stop_the_move():
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, start={0: 0})
    _line(s, b"#0P900\r")
    assert s.frame() == {0: 10}
    _line(s, b"#0PO50\r")
    assert s.frame() == {0: 20}
    assert _line(s, b"Q\r") == b"+"


def test_version_and_play():
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, sequences=2, start={0: 0})
    assert VERSION_REPLY == b"SSC32-servoc-0.1\r"
    assert _line(s, b"VER\r") == VERSION_REPLY
    s.frame()
    _line(s, b"#0P900\r")                # F = 5
    assert s.frame() == {0: 10}
    # no sequence 2: nothing, the move goes on
    assert _line(s, b"PL 0 SQ 2\r") == b""
    assert s.frame() == {0: 20}
    assert s.plays == []
    # a bad line does nothing
    assert _line(s, b"PL 1 SQ 0\rQ\r") == b"+"
    # sequence 1: the move under way ends, the play is recorded; frame i + 1 repeats frame i
    assert _line(s, b"PL 0 SQ 1\r") == b""
    assert s.plays == [1]
    assert s.frame() == {0: 20}
    assert _line(s, b"Q\r") == b"."
    s.sequence_running = True
    assert _line(s, b"Q\r") == b"+"


def test_stop_while_a_sequence_plays_ends_it_and_the_reading():
    # while a sequence plays, STOP c does nothing and reads on; STOP asks for the sequence's end
    # (plan.expand ends it in that frame) and ends the frame's reading
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, sequences=1, start={0: 0})
    p = LineParser()
    s.sequence_running = True
    assert s.read(p, b"STOP 0\rQ\rSTOP\rQ\r") == (b"+", 14)
    assert s.stop_play and s.reading_stopped
    assert stops_reading(Stop(None), playing=True) and not stops_reading(Stop(None))
    assert not stops_reading(Stop(0), playing=True)


def test_play_after_a_group_is_read_in_the_next_frame():
    s = Session([Servo(0, t_dav_us=Fraction(2000))], P20, sequences=1, start={0: 0})
    p = LineParser()
    data = b"#0P900\rPL0SQ1\rPL0SQ0\rQ\r"
    # the group (F = 5) and the first PL line up to its CR, then each PL line in a frame of its own
    assert s.read(p, data) == (b"", 13)
    assert s.frame() == {0: 10}
    # no sequence 1: nothing, but it ends the reading
    assert s.read(p, data[13:]) == (b"", 1)
    assert s.frame() == {0: 20}
    assert s.plays == []
    # sequence 0: the move ends, frame i + 1 repeats frame i
    assert s.read(p, data[14:]) == (b"", 7)
    assert s.plays == [0]
    assert s.frame() == {0: 20}
    assert s.read(p, data[21:]) == (b".", 2)


def test_esc_and_bad_lines_drop_only_their_own_line():
    s = _two()
    p = LineParser()
    # a bad line whose first entry has ended (at the second '#'): nothing
    assert s.read(p, b"#0P900#1P1700X\r") == (b"", 15)
    assert s.pending is None and not s.reading_stopped
    assert s.frame() == {0: 0, 1: 250}
    # ESC drops the line so far, the rest is a line of its own: #1 250 -> 240 (F = 1)
    assert s.read(p, b"#0P900#1P17\x1b#1P2420\r") == (b"", 20)
    assert s.pending == Group((Entry(1, 2420, None),), None)
    assert s.frame() == {0: 0, 1: 240}
    # a bad line, a line with S only, PL 0 and an empty line before a group: the group stays
    assert s.read(p, b"VE\r#1S5\rPL0\r\r#0P900\r") == (b"", 20)
    # #0 0 -> 50 in 5
    assert s.frame() == {0: 10, 1: 240}
    # a group, then ESC and a bad line: read in the next frame, they do not touch it
    data = b"#1P2500\r\x1bX\r"
    assert s.read(p, data) == (b"", 8)
    assert s.read(p, data[8:]) == (b"", 0)      # the reading has stopped
    # #1 240 -> 250 (F = 1); #0's move ends at 10
    assert s.frame() == {0: 10, 1: 250}
    assert s.read(p, data[8:]) == (b"", 3)
    assert s.pending is None and not s.reading_stopped
    assert s.frame() == {0: 10, 1: 250}


def test_an_unfinished_line_does_nothing_yet():
    s = _two()
    p = LineParser()
    # the first group line ends the frame's lines: the unfinished line after it is read up to the
    # '#' that would end its first entry
    assert s.read(p, b"#0P900\r#1P1700#2") == (b"", 14)
    assert s.frame() == {0: 10, 1: 250}
    # the next frame reads on: #1's entry has ended at the '#', its line has not: #0's move goes on
    assert s.read(p, b"#2") == (b"", 2)
    assert s.pending is None
    assert s.frame() == {0: 20, 1: 250}
    # its line end, the next frame: a new move (#0's ends at 20); #1 250 -> 150, F = 10: 240
    assert s.read(p, b"\r") == (b"", 1)
    assert s.pending == Group((Entry(1, 1700, None),), None)
    assert s.frame() == {0: 20, 1: 240}


def test_lines_that_stop_the_reading():
    by = {0: Servo(0), 1: Servo(1)}
    stops = parse_lines(b"#0P900\r#7P900#1P0\r#0PO5\r#7PO5\rPL0SQ0\rPL0SQ9\r")
    assert [stops_reading(c, by) for c in stops] == [True] * 6
    goes = parse_lines(b"#7P900\r#7P900#1S5\rQ\rQP0\rSTOP\rSTOP 1\rVER\r")
    assert [stops_reading(c, by) for c in goes] == [False] * 7
    # without the servos, every channel counts as one with a servo
    assert stops_reading(goes[0]) and stops_reading(goes[1])
    assert [stops_reading(c) for c in stops] == [True] * 6
    assert [stops_reading(c) for c in goes[2:]] == [False] * 5
    assert not stops_reading(None) and not stops_reading(None, by)
    s = Session([Servo(0), Servo(1)], P20, start={0: 0, 1: 0})
    assert s.stops_reading(goes[0]) is False and s.stops_reading(stops[0]) is True
    for text in (b"#0P900\r", b"#0PO5\r", b"PL0SQ0\r"):
        _line(s, b"#7P900\rQ\r" + text)
        assert s.reading_stopped
        if text == b"#0P900\r":         # after a group line (where the firmware reads on): its
            assert _line(s, b"Q\r") == b""                # answer once the group is committed
        else:
            with pytest.raises(RuntimeError):
                _line(s, b"Q\r")
        with pytest.raises(RuntimeError):
            _line(s, b"STOP\r")
        s.frame()
        assert s.answers() == (b"+" if text == b"#0P900\r" else b"")
        assert not s.reading_stopped
    assert _line(s, b"Q\r") == b"+"


def test_read_frame_by_frame():
    s = _two()
    p = LineParser()
    # a Q, the first group; the LF after it (an empty line) and the second group join it; VER up
    # to its CR, which waits (2 + 7 + 1 + 8 + 3 bytes)
    data = b"Q\r#0P900\r\n#1P1700\rVER\rQ\r"
    assert s.read(p, data) == (b".", 21)
    # #0 0 -> 50, top 5; #1 250 -> 150, top 10: F = 10; #0 (100k + 10) // 20, #1 250 - 10k
    assert s.frame() == {0: 5, 1: 240}
    # the VER and the Q after it (whose answer goes out after VER's, when there is room: the
    # firmware's timing)
    data = data[21:]
    assert s.read(p, data) == (VERSION_REPLY + b"+", 3)
    assert s.frame() == {0: 10, 1: 230}
    assert s.frame() == {0: 15, 1: 220}
    # an offset line stops the reading too
    assert s.read(p, b"#0PO5\rQ\r") == (b"", 6)
    assert s.frame() == {0: 20, 1: 210}
    # at most `limit` bytes; a line in pieces over frames
    assert s.read(p, b"QP1\r", limit=2) == (b"", 2)
    assert s.frame() == {0: 25, 1: 200}
    # #1 after 5 frames of 10: 200: (500 + 1600) // 10 = 210
    assert s.read(p, b"1\r") == (bytes([210]), 2)


def test_two_servos_on_one_channel():
    with pytest.raises(ValueError):
        Session([Servo(3), Servo(3)], P20)


def test_not_a_command():
    with pytest.raises(TypeError):
        Session([Servo(0)], P20).line("Q")


def test_session_at_another_period():
    s = Session([Servo(0)], P53, start={0: 0})
    # 0 -> 10, top speed: F = 5; (20k + 5) // 10 = 2, 4, 6, 8, 10
    _line(s, b"#0P580\r")
    assert [s.frame()[0] for _ in range(5)] == [2, 4, 6, 8, 10]
    # back with S100: 80 us at 100 us/s, 0.8 s: ceil(800,000 / 5299) = ceil(150.97) = 151 frames;
    # 10 - floor(10k/151 + 1/2): 9 first at k = 8 (80/151 = 0.53)
    _line(s, b"#0P500S100\r")
    ns = [s.frame()[0] for _ in range(151)]
    assert ns[6] == 10 and ns[7] == 9
    # k = 143: floor(9.47 + .5) = 9 -> 1; k = 144: floor(9.54 + .5) = 10 -> 0
    assert ns[142] == 1 and ns[143] == 0 and ns[-1] == 0
    assert _line(s, b"Q\r") == b"."


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.none(), st.integers(0, 250)), min_size=3, max_size=3),
       st.lists(st.tuples(st.integers(0, 4), st.integers(0, 3000), st.integers(0, 500)), min_size=1, max_size=5),
       st.integers(0, 600), st.integers(1, 3))
def test_group_lines_one_a_frame_land_on_their_targets(start, entries, t, lines):
    servos = [Servo(0), Servo(1, reverse=True, trim=3), Servo(2, lo=20, hi=200, t_dav_us=Fraction(900))]
    s = Session(servos, P20, start=dict(enumerate(start)))
    # the entries over `lines` group lines, the T on the first; a line that names no servo
    # (channels 3 and 4 only) does nothing, its T included, and does not stop the reading
    cut = [k * len(entries) // lines for k in range(lines + 1)]
    texts = [b"".join(b"#%dP%dS%d" % e for e in entries[a:b]) + (b"T%d" % t if a == 0 else b"") + b"\r"
             for a, b in zip(cut, cut[1:]) if a < b]
    # each frame reads up to the end of the next line that names a servo (sent after the frame
    # before: lines that end in one frame join, test_one_entry_lines_read_in_one_frame_join)
    chunks: list[tuple[bytes, Group]] = []
    tail = b""
    for text in texts:
        tail += text
        (g,) = parse_lines(text)
        if names_a_servo(g, s.by_channel):
            chunks.append((tail, g))
            tail = b""
    p = LineParser()
    data = b"".join(texts)
    if not chunks:                      # channels 3 and 4 only: nothing
        assert s.read(p, data) == (b"", len(data))
        assert not s.reading_stopped and s.pending is None
        assert _line(s, b"Q\r") == b"."
        assert s.frame() == dict(enumerate(start))
        return
    now = dict(enumerate(start))
    for j, (chunk, g) in enumerate(chunks):
        assert s.read(p, chunk) == (b"", len(chunk))
        assert s.pending == g
        # its move, from where the frame before left the servos; every move under way ends
        frames, targets = group_move(g, s.by_channel, now, {}, P20)
        n0s = dict(now)
        last = j == len(chunks) - 1
        for k in range(1, (frames if last else 1) + 1):
            for ch, n1 in targets.items():
                n0 = n0s[ch]
                now[ch] = n1 if n1 is None or n0 is None else frame_n(n0, n1, k, frames)
            assert s.frame() == now
            if last:
                if k == 1:              # the lines after it, that name no servo: nothing
                    assert s.read(p, tail) == (b"", len(tail))
                moving = any(n0s[ch] is not None and n1 is not None and n1 != n0s[ch] for ch, n1 in targets.items())
                assert _line(s, b"Q\r") == (b"+" if k < frames and moving else b".")
    # a servo that no line names stays where it started
    named = {ch for _, g in chunks for ch in group_move(g, s.by_channel, {}, {}, P20)[1]}
    assert all(s.now[ch] == start[ch] for ch in range(3) if ch not in named)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.none(), st.integers(0, 250)), min_size=3, max_size=3),
       st.tuples(st.integers(0, 2), st.integers(1, 3000), st.none() | st.integers(0, 500), st.none() | st.integers(0, 900)),
       st.lists(st.one_of(st.tuples(st.integers(0, 4), st.integers(0, 3000), st.none() | st.integers(0, 500),
                                    st.none() | st.integers(0, 900)),
                          st.sampled_from([b"\n", b"\r", b"  \r", b"#3\r"])), max_size=8))
def test_one_entry_lines_read_in_one_frame_join(start, first, more):
    """Lines of one entry each, back to back after a group line: every one is read in the frame,
    and those that name a servo join the group: their entries in order, the last T given. Empty
    lines and lines that name no servo in between do nothing."""
    servos = [Servo(0), Servo(1, reverse=True, trim=3), Servo(2, lo=20, hi=200, t_dav_us=Fraction(900))]
    s = Session(servos, P20, start=dict(enumerate(start)))

    def text(ch, w, v, t):
        return b"#%dP%d" % (ch, w) + (b"S%d" % v if v is not None else b"") + (b"T%d" % t if t is not None else b"") + b"\r"

    data, entries, time = text(*first), [Entry(first[0], first[1], first[2])], first[3]
    for line in more:
        if isinstance(line, bytes):
            data += line
            continue
        data += text(*line)
        ch, w, v, t = line
        if ch <= 2:                         # a servo's channel: it joins
            entries.append(Entry(ch, w, v))
            time = t if t is not None else time
    p = LineParser()
    assert s.read(p, data) == (b"", len(data))
    assert s.pending == Group(tuple(entries), time)
    frames, targets = group_move(s.pending, s.by_channel, dict(enumerate(start)), {}, P20)
    want = dict(enumerate(start))
    for ch, n1 in targets.items():
        n0 = start[ch]
        want[ch] = n1 if n1 is None or n0 is None else frame_n(n0, n1, 1, frames)
    assert s.frame() == want



@pytest.mark.parametrize("bad", [b"#1P15X\r", b"#2T100\r", b"#1P900 Q\r", b"#1P900 PO5 P3\r"])
def test_a_line_dropped_after_a_group_stops_the_reading_and_drops_nothing_of_it(bad):
    # the group stays; the bad line's end is read (it is dropped), and the reading stops there
    # until the group is committed: the line after it is read in the next frame
    s = _two()
    p = LineParser()
    data = b"#0P900\r" + bad + b"#1P1700\r"
    assert s.read(p, data) == (b"", 7 + len(bad))
    assert s.pending == Group((Entry(0, 900, None),), None) and s.dropped
    assert s.read(p, data[7 + len(bad):]) == (b"", 0)
    assert s.frame() == {0: 10, 1: 250}
    assert s.read(p, data[7 + len(bad):]) == (b"", 8)
    assert s.pending == Group((Entry(1, 1700, None),), None)


def test_where_the_state_is_in_xram_a_second_entry_waits_only_for_a_channel_of_the_group():
    # each entry keeps its line's generation: a line after a group writes its entries as each
    # ends, but not over one of the group's, which a line that then went bad could not give back
    waiting = frozenset({0, 7})
    for text, stalls in ((b"#1P900", False), (b"#0P900", True), (b"#7", False), (b"#7 S100", True),
                         (b"#1P900#7P100", True), (b"#1P900#2P100", False), (b"#0P15X", False), (b"", False),
                         (b"#9P900", False)):
        p = LineParser()
        for b in text:
            p.feed(b)
        assert p.stalls(ord("#"), waiting) == stalls, text
        assert p.stalls(ord("#")) == p.hashed, text         # in internal RAM: any '#' after a '#'
    # a session of two servos in XRAM: two-entry lines join the group but for a channel it names
    s = Session([Servo(0, t_dav_us=Fraction(2000)), Servo(1, t_dav_us=Fraction(2000)), Servo(2)], P20,
                start={0: 0, 1: 250, 2: 100}, xram=True)
    p = LineParser()
    data = b"#0P900\r#1P1700#2P1300\r#2P1400#0P1000\r"
    # the second line's entries are written as they end (channel 1's at the '#' of channel 2's),
    # and it joins; the third line's first entry is channel 2's, which the group gives a width: the
    # reading stops before the '#' that would write it over the group's (7 + 15 + 7 bytes)
    assert s.read(p, data) == (b"", 29)
    assert s.pending == Group((Entry(0, 900, None), Entry(1, 1700, None), Entry(2, 1300, None)), None)


def test_with_holds_entries_for_the_groups_servos_are_held_until_the_holds_are_taken():
    # K holds (layout.host_holds): an entry a '#' ends for a servo of the group waiting is held, so
    # the reading goes on; once K are taken, a '#' that ends an open entry (of any servo) waits
    servos = [Servo(c, t_dav_us=Fraction(2000)) for c in range(3)]
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100}, xram=True)
    p = LineParser(holds=2)
    data = b"#0P900#1P1000\r#0P1100#1P1200\r#0P1300#1P1400#2P1\r"
    # line 2 holds channel 0's entry (at its '#1'), its last is written at its end; line 3 holds
    # channel 0's again: both holds taken, it waits before '#2' (14 + 15 + 14 bytes)
    assert s.read(p, data) == (b"", 43)
    assert (p.held, p.joined) == (2, 1)
    assert s.pending.entries[2:] == (Entry(0, 1100, None), Entry(1, 1200, None))   # (joined: the later wins)
    s.frame()
    assert s.read(p, data[43:]) == (b"", len(data) - 43)       # the commit wrote them: none waits
    assert s.pending == Group((Entry(0, 1300, None), Entry(1, 1400, None), Entry(2, 1, None)), None)
    # a line that goes bad gives back the entries it held, those of lines that ended stay
    p = LineParser(holds=3)
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100}, xram=True)
    assert s.read(p, b"#0P900\r#0P1000#1P1\r#0P1100#1x\r") == (b"", 30)
    assert (p.held, p.joined, s.dropped) == (1, 1, True)
    assert s.pending.entries[1:] == (Entry(0, 1000, None), Entry(1, 1, None))
    # an entry with S alone writes nothing and holds nothing; one for a channel with no servo neither
    p = LineParser(holds=1)
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100}, xram=True)
    assert s.read(p, b"#0P900\r#0S100#9P1000#0P1000\r") == (b"", 28)
    assert p.held == 0


def test_where_the_firmware_reads_on_through_answer_lines_a_qs_answer_waits_for_the_commit():
    # LineParser(answers=True) (flow.reads_answers): Q, QP and VER lines after a group line are
    # read; QP's and VER's answers go out as their lines end, a Q's once the group is committed
    # (with the next reading's, first), the answers after it behind it; STOP and offset lines wait
    s = _two()
    p = LineParser(answers=True)
    data = b"#0P900\rQP1\rQ\rVER\r#1P1000\rSTOP\r"
    # QP 1 answers now (250: 2500 us); Q waits, VER goes behind it; the group line joins; the
    # reading stops before STOP's CR (7 + 4 + 2 + 4 + 8 + 4 bytes)
    assert s.read(p, data) == (bytes([250]), 29)
    assert s.frame() != {}
    assert s.read(p, data[29:]) == (b"+" + VERSION_REPLY, 1)     # a move is under way
    for text, stalls in ((b"Q", False), (b"QP 3", False), (b"VER", False), (b"qp", False), (b"STOP", True),
                         (b"PL0SQ1", True), (b"T100", True)):
        p, q = LineParser(answers=True), LineParser()
        for b in text:
            p.feed(b)
            q.feed(b)
        assert p.stalls(0x0D) == stalls and q.stalls(0x0D), text          # without: each waits


def test_in_internal_ram_with_holds_every_entry_is_held_and_a_lines_last_while_one_is():
    # no generations in internal RAM: while a group waits every entry a '#' ends is held, and,
    # while one is held, a line's last entry at its end (so that the holds keep the lines' order);
    # once the K are taken the reading waits before such a '#' or line end
    servos = [Servo(c, t_dav_us=Fraction(2000)) for c in range(3)]
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100})
    p = LineParser(holds=2, iram=True)
    data = b"#0P900#1P1000\r#2P1100#1P1200\r#0P1300#1P1400\r"
    # line 2 holds channel 2's entry at its '#1' and its last at its end; line 3's '#1' would end
    # an entry with both holds taken (14 + 15 + 7 bytes)
    assert s.read(p, data) == (b"", 36)
    assert (p.held, p.joined) == (2, 2)
    assert s.pending.entries[2:] == (Entry(2, 1100, None), Entry(1, 1200, None))
    s.frame()
    assert s.read(p, data[36:]) == (b"", len(data) - 36)       # the commit wrote them: none waits
    # a one-entry line with nothing held is written in place at its end (no hold); with a hold
    # taken, a line's end waits once both are
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100})
    p = LineParser(holds=2, iram=True)
    assert s.read(p, b"#0P900\r#1P1000\r#2P1\r") == (b"", 20) and p.held == 0
    s.frame()
    assert s.read(p, b"#0P900\r#1P1000#2P1100\r#0P1200\r") == (b"", 29)
    assert (p.held, p.joined) == (2, 2)
    # a line that goes bad gives back what it held; an entry for a channel with no servo holds nothing
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100})
    p = LineParser(holds=2, iram=True)
    assert s.read(p, b"#0P900\r#9P5#1P1000\r") == (b"", 19) and (p.held, p.joined) == (0, 0)
    s.frame()
    assert s.read(p, b"#0P900\r#1P1000#2x\r") == (b"", 18) and (p.held, s.dropped) == (0, True)
    # without holds a '#' after a '#' waits; a parser's holds must be for the session's RAM
    s = Session(servos, P20, start={0: 0, 1: 250, 2: 100})
    assert s.read(LineParser(), b"#0P900\r#1P1000#2P1\r") == (b"", 14)
    with pytest.raises(ValueError):
        Session(servos, P20, xram=True).read(LineParser(holds=2, iram=True), b"#0P900\r#1P1\r")


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(TOKENS), max_size=40))
def test_read_takes_every_line_and_stops_after_the_stopping_ones(tokens):
    data = b"".join(tokens)
    s = Session([Servo(0), Servo(1, t_dav_us=FAST)], P20, sequences=1, start={0: 125})
    seen: list[tuple[int, object]] = []
    line = s.line

    def record(cmd):
        seen.append((s.frames, cmd))
        return line(cmd)

    s.line = record
    p = LineParser()
    while data:
        _, n = s.read(p, data)
        assert n >= 1
        data = data[n:]
        s.frame()
    # every line read, in order
    assert [c for _, c in seen] == parse_lines(b"".join(tokens))
    # a line that stops the reading is the last of its frame, and the next line is read in the
    # next frame, but for a group line after a group line, which may join it in the same frame;
    # after any other line the reading goes on in the same frame
    for (f, c), (g, d) in zip(seen, seen[1:]):
        if s.stops_reading(c) and isinstance(c, Group) and isinstance(d, Group):
            assert g in (f, f + 1)
        else:
            assert g == f + (1 if s.stops_reading(c) else 0)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 250), st.integers(0, 250), st.booleans(), st.integers(-400, 400))
def test_the_firmware_form_of_output_n_is_output_n(a, b, reverse, trim):
    # the firmware clamps N to lo'..hi' and adds K to N xor m, in 8 bits (ssc32.output_params)
    lo, hi = min(a, b), max(a, b)
    params = output_params(lo, hi, reverse, trim)
    assert 0 <= params[0] <= params[1] <= 250 and params[3] in (0, 0xFF)
    assert [output_by(params, n) for n in range(251)] == [output_n(n, lo, hi, reverse, trim) for n in range(251)]


def test_the_bytes_the_reading_stops_before_while_a_group_waits():
    """The control bytes 0x08-0x0F and 0x18-0x1F (the firmware's one test, byte AND 0xE8 = 0x08:
    ESC, TAB) but CR and LF; CR and LF only at the end of a command or offset line; a '#' only
    once the line being read has had one, bad or not."""
    p = LineParser()
    controls = set(range(0x08, 0x10)) | set(range(0x18, 0x20))
    assert {b for b in range(256) if p.stalls(b)} == controls - {0x0A, 0x0D}
    # the end of a line that joins the group (entries with no PO), of a bad line (dropped alone),
    # of an empty line is read; of a command, a T alone or an offset line it waits
    for text, waits in ((b"", False), (b"  ", False), (b"#0P1500", False), (b"#0P1500S100T5", False),
                        (b"#3", False), (b"#0 S10", False), (b"#0P15X", False), (b"Q#", False),
                        (b"#0T100", False),
                        (b"Q", True), (b"QP 3", True), (b"VER", True), (b"STOP", True), (b"STOP 3", True),
                        (b"PL0SQ1", True), (b"T100", True), (b"#0PO5", True), (b"#0 PO", True), (b"#0PO-5", True),
                        (b"#0P1500 PO5", True)):       # PO open: bad only once it ends
        p = LineParser()
        for b in text:
            p.feed(b)
        assert p.stalls(0x0D) == p.stalls(0x0A) == waits, text
        assert p.stalls(0x1B) and p.stalls(0x09), text
    for text in (b"#", b"#0P15", b"#0P1500S100", b"#0P15X", b"#0P1500T5"):
        p = LineParser()
        for b in text:
            p.feed(b)
        assert p.stalls(ord("#")), text
    for text in (b"", b"Q", b"QP 3", b"X#", b"PL0SQ"):
        p = LineParser()
        for b in text:
            p.feed(b)
        assert not p.stalls(ord("#")), text

