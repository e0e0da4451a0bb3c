"""`host` on an STC89 with several ports of servos: its per-servo state and the DDA's error terms
are kept in the chip's XRAM (flow.host_xram, docs/host-protocol.md), read and written with
MOVX @DPTR in page 0. Each session runs in ucsim at the program's shortest period under the
heaviest lines (every servo with S in every line, Q, QP and PO lines between them) and is checked
by verify's model of the protocol; 1 µs less is refused.
"""
from __future__ import annotations

import re
from fractions import Fraction

import pytest

from conftest import build_text, front_end_text
from servoc import flow, layout
from test_verify_observes import problems, watch

pytestmark = pytest.mark.toolchain


def _program(chip: str, pins: list[tuple[int, int]], main: str = "main {\n  move q in 800ms\n  host\n}",
             clock: str = "11.0592MHz") -> str:
    servos = "".join(f"servo s{i} = P{p}.{b}{' reverse' if i % 3 == 1 else ''} trim {i % 5 - 2}\n"
                     for i, (p, b) in enumerate(pins))
    pose = ", ".join(f"s{i}: {40 + (13 * i) % 100}" for i in range(len(pins)))
    far = ", ".join(f"s{i}: {200 - (29 * i) % 90}" for i in range(len(pins)))
    # the home pose sets every servo at once; the moves after it start from where the servos are
    # (a compiled move's setup, linear and eased steps, all with the state in XRAM), and `PL 0 SQ 0`
    # plays the sequence from the host
    return (f"target {chip} clock {clock}\nserial 9600\nhost ssc32\n{servos}"
            f"pose p {{ {pose} }}\npose q {{ {far} }}\nhome p\n"
            f"sequence wave {{\n  move p in 1200ms ease in-out\n  move q in 1000ms\n}}\n{main}\n")


def _at_shortest(text: str):
    b = build_text(text)
    for _ in range(6):
        if b.plan.min_period_us == b.plan.period_us:
            break
        text = re.sub(r"host ssc32\n(frame \d+us\n)?", f"host ssc32\nframe {b.plan.min_period_us}us\n", text)
        b = build_text(text)
    assert b.plan.period_us == b.plan.min_period_us
    return b, text


@pytest.mark.parametrize("chip, pins, clock", [
    ("stc89c52rc", [(p, b) for b in range(8) for p in (1, 2)], "11.0592MHz"),            # 16 servos on two ports
    ("stc89c52rc", [(p, b) for b in range(8) for p in (0, 1, 2)], "11.0592MHz"),         # 24 on three, built for size
    ("stc89c58rd", [(p, b) for b in range(8) for p in (0, 1, 2)], "11.0592MHz"),         # 24 on three, built for speed
    ("stc89c58rd", [(p, b) for b in range(8) for p in (0, 1, 2)], "11.0592MHz mode 6T"),
    ("stc89c58rd", [(p, b) for b in range(6) for p in (1, 2)], "22.1184MHz"),
    ("at89c52", [(p, b) for b in range(3) for p in (1, 2)][:5], "11.0592MHz"),        # no XRAM: RAM allocated decides
])
def test_host_state_in_xram_holds_the_heaviest_lines_at_the_shortest_period(chip, pins, clock):
    text = _program(chip, pins, clock=clock)
    b, text = _at_shortest(text)
    xram = chip != "at89c52"
    assert flow.host_xram(b.plan) == xram and b.plan.compact == (chip == "stc89c52rc")     # 8 KB: built for size
    assert b.plan.program.target.six_t == ("6T" in clock)
    assert ("MOVX    @DPTR, A" in b.firmware.unit.text) == xram and ("HPW     = 0x00" in b.firmware.unit.text) == xram
    _heavy_session(b, text, len(pins))


def _heavy_session(b, text: str, count: int) -> None:
    """Group lines naming every servo with S and T back to back (the longest commit, at the rate
    the reading keeps up with: docs/host-protocol.md, Timing), then Q, QP and PO lines, an ESC and
    a bad line, then `PL 0 SQ 0`, each short line 3 frames after the end of the one before: verify's protocol
    model passes, no byte is lost, every answer comes, and 1 us less is refused."""
    body = "".join("".join(f"#{i}P{600 + (k * 370 + i * 190) % 1900}S{300 + 97 * k + i}" for i in range(count))
                   + f"T30\\r" for k in range(4))
    short = [line for k in range(4)
             for line in [f"Q\\r", f"QP{k % count}\\r"] + ([f"#{k % count}PO{40 - 19 * k}\\r"] if k % 2 == 0 else [])]
    short += ["#1P1500#2P1500\\x1b#3P900\\r", "#4P2000X\\r", "#5P1000\\r",     # an ESC and a bad line drop only
              "#6PO50#5PO10\\x1b#7PO-20\\r", "#6P1500#7P1500#5P1500\\r",         # their own; an offset line too
              "PL 0 SQ 0\\r", "Q\\r"]
    at, events = 1.3 + len(body.replace("\\r", "r")) * 10 / 9600, f'1.0s "{body}"\n'
    for line in short:
        events += f'{at:.4f}s "{line}"\n'
        at += len(line.replace("\\r", "r").replace("\\x1b", "e")) * 10 / 9600 + 3 * b.plan.period_us / 1e6
    trace, report = watch(b, events, int((at + 5.5) * 1e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert not [w for w in report.warnings if "lost" in w], report.warnings[:3]
    assert len(trace.sent) == 9                                         # every Q and QP answered
    shorter = re.sub(r"host ssc32\n(frame \d+us\n)?", f"host ssc32\nframe {b.plan.min_period_us - 1}us\n", text)
    _, diags = front_end_text(shorter)
    assert any(d.code == "period-too-short" for d in diags), [d.code for d in diags]


def test_without_xram_the_ram_allocated_decides_and_the_deepest_nesting_it_allows_runs():
    # an AT89C52 with two ports: `host`'s RAM comes first and the stack gets what is left, not a
    # fixed share; the deepest nesting lint accepts around `host` (7 repeats and `PL`'s play) runs
    # the heaviest lines at the shortest period, the stack at its deepest while the host commits;
    # one level more is too-deep at the repeat past it, from lint as from compile
    pins = [(p, b) for b in range(2) for p in (1, 2)]
    def program(levels: int) -> str:
        return _program("at89c52", pins, "main {\n" + "  repeat 2 {\n" * levels + "  move q in 800ms\n  host\n"
                        + "  }\n" * levels + "}")
    deepest = max(k for k in range(12) if not [d for d in front_end_text(program(k))[1] if d.is_error])
    assert deepest >= 4
    _, diags = front_end_text(program(deepest + 1))
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "too-deep" and f"level {deepest + 2}" in d.message
    b, text = _at_shortest(program(deepest))
    assert not flow.host_xram(b.plan)
    _heavy_session(b, text, len(pins))


def test_without_xram_the_same_program_is_refused_with_the_chip_that_holds_it():
    pins = [(p, b) for b in range(8) for p in (1, 2)]
    _, diags = front_end_text(_program("at89c52", pins))
    errors = [d for d in diags if d.is_error]
    assert [d.code for d in errors] == ["host-ram"]
    assert "stc89c58rd" in errors[0].help and "5 for each of the 16 servos" in errors[0].message


def test_the_state_in_xram_is_what_the_firmware_reads_and_lint_reports_its_room():
    # 24 servos: the motion state (96 bytes) and the host's arrays (120) are in XRAM page 0, the
    # internal RAM keeps none of them, and the stack reaches 0xFF
    pins = [(p, b) for b in range(8) for p in (0, 1, 2)]
    b = build_text(_program("stc89c58rd", pins))
    text = b.firmware.unit.text
    assert flow.host_xram(b.plan) and layout.host_holds(b.plan) == 2
    assert b.firmware.unit.xram_bytes == 24 * 6 + 2 * layout.HOLD_BYTES + 96
    assert re.search(r"^XSTATE\s+= 0xA0", text, re.M) and not re.search(r"^STATE\s+=", text, re.M)
    assert "MOVX    @R" not in text and "MOVX    A, @R" not in text      # never paged by P2
    # the same 24 servos with a select nested in the program: the allocation says too-deep or
    # host-ram, never an assembler error
    deep = _program("stc89c58rd", pins, "main {\n" + "  repeat 2 {\n" * 20 + "  host\n" + "  }\n" * 20 + "}")
    _, diags = front_end_text(deep)
    assert {d.code for d in diags if d.is_error} <= {"too-deep", "host-ram"} and any(d.is_error for d in diags)


def test_a_build_for_size_that_fits_only_without_the_holds_is_built_without_them():
    # 24 servos with `host` and a sequence on the STC89C52RC: built for size, the holds' code does
    # not fit its 8 KB, so it is built without (K = 0) and fits; without the sequence it keeps them;
    # on the STC89C58RD+ (32 KB) the same program keeps them, built for speed
    pins = [(p, b) for b in range(8) for p in (0, 1, 2)]
    text = _program("stc89c52rc", pins)
    b = build_text(text)
    assert b.plan.compact and not b.plan.holds and layout.host_holds(b.plan) == 0
    assert "HHO" not in b.firmware.unit.text and b.firmware.rom_bytes <= 8192
    plain = build_text(re.sub(r"sequence wave \{[^}]*\}\n", "", text))
    assert plain.plan.compact and layout.host_holds(plain.plan) == 2 and "host_flush:" in plain.firmware.unit.text
    big = build_text(text.replace("stc89c52rc", "stc89c58rd"))
    assert not big.plan.compact and layout.host_holds(big.plan) == 2


def test_a_program_whose_internal_ram_holds_no_holds_is_built_without_them():
    # `host` nested in repeats as deep as the stack allows with 24 servos: the deepest that fit
    # without the holds' 2 bytes of internal RAM are built without them (lint accepts, compile
    # builds, a session verifies), one deeper is too-deep, and shallower ones keep the holds
    pins = [(p, b) for b in range(8) for p in (0, 1, 2)]
    nest = lambda d: _program("stc89c58rd", pins, "main {\n" + "  repeat 2 {\n" * d + "  host\n" + "  }\n" * d + "}")  # noqa: E731
    plans = {}
    for d in range(8, 14):
        fe, diags = front_end_text(nest(d))
        plans[d] = (fe.plan, [x.code for x in diags if x.is_error])
    kept = [d for d, (p, errors) in plans.items() if not errors and layout.host_holds(p)]
    without = [d for d, (p, errors) in plans.items() if not errors and not p.holds]
    refused = [d for d, (p, errors) in plans.items() if errors]
    assert kept and without and refused and max(kept) < min(without) <= max(without) < min(refused), plans
    assert all(plans[d][1] == ["too-deep"] for d in refused)
    b = build_text(nest(max(without)))
    assert not b.plan.holds and "HHO" not in b.firmware.unit.text
    trace, report = watch(b, '0.5s "#0P1000#1P1200\\r#0P1100#1P900\\r"\n', int(1.5e6 / b.plan.period_us))
    assert report.ok, problems(report)


def test_a_program_past_the_stc89c52rcs_code_memory_is_told_the_chip_with_xram_and_more():
    # 24 servos with `host` and many sequences: rom-overflow names the STC89C58RD+, not the
    # AT89C55WD (more code memory, but no XRAM for the host's state)
    pins = [(p, b) for b in range(8) for p in (0, 1, 2)]
    seqs = "".join(f"sequence seq{k} {{\n  move p in {900 + 10 * k}ms ease in\n  move q in 1200ms ease out\n}}\n"
                   for k in range(12))
    text = _program("stc89c52rc", pins).replace("sequence wave", seqs + "sequence wave")
    _, diags = front_end_text(text)
    errors = [d for d in diags if d.is_error]
    assert [d.code for d in errors] == ["rom-overflow"], [d.code for d in errors]
    assert "`target stc89c58rd`" in errors[0].help and "at89c55wd" not in errors[0].help


def test_the_generations_of_dropped_lines_come_round_again_and_drop_nothing_else():
    # host_drop only counts HGEN up; host_gen, after each reading, starts it again from 0 once it
    # has reached its limit. Lines dropped by ESC, each after an entry for channel 0 (then 2), carry HGEN
    # there; then a group for channel 1 alone: channel 0 must stay where the home pose has it, and
    # verify's model of the protocol agrees frame by frame
    pins = [(p, b) for b in range(8) for p in (1, 2)]
    b = build_text(_program("stc89c52rc", pins, "main { host }"))
    # (host_run's own drop makes HGEN 1; limit - 1 drops more bring it to host_gen's limit, 255 less
    # a reading's bytes: the reading of the last of them, or the next, starts it again, and no line is
    # dropped between that and the group's commit)
    limit = 255 - flow.host_passes(b.plan)
    body = "#0P1000\\x1b" * (limit - 1) + "#1P2000\\r" + "#2P900\\x1b" * 140 + "#0P1100#1P700\\x1b#3P1300\\r"
    trace, report = watch(b, f'0.1s "{body}"\n', int(6.5e6 / b.plan.period_us))
    assert report.ok, problems(report)
    def widths(port: int, bit: int) -> list[int]:
        edges = trace.pin_edges(port, bit)
        return [fall - rise for (rise, up), (fall, _) in zip(edges, edges[1:]) if up == 1]
    # channel c is P1.c (model.host_channel)
    c0, c1, c3 = widths(1, 0), widths(1, 1), widths(1, 3)
    assert len(set(c0)) == 1                      # channel 0 never moved
    assert c1[-1] > c1[0] and c3[-1] != c3[0]     # channels 1 and 3 did


def test_held_entries_keep_their_order_when_the_generations_come_round_again():
    # each group line's end counts HGEN up; 80 runs of three lines back to back (a group line for
    # channels 1 and 2, a line that holds channel 1's entry, a line that holds channel 2's and
    # whose last entry, written at its end, is channel 1's again) count it past host_gen's limit in
    # a frame whose reading held entries: host_gen renumbers the holds' generations with the
    # entries', in order, so that the commit still writes the latest width of each (verify's model
    # checks every pulse; with the holds' generations left as they were, verify fails)
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    b = build_text(_program("stc89c58rd", pins, "main { host }"))
    assert layout.host_holds(b.plan) and 3 * 80 > 255 - flow.host_passes(b.plan)
    body = "".join(f"#1P{1000 + 7 * n}#2P{1100 + n}\\r#1P{1500 + 5 * n}#2P{900 + n}\\r#2P{1300 + n}#1P{2000 - 3 * n}\\r"
                   for n in range(80))
    trace, report = watch(b, f'0.2s "{body}"\n', int(5.0e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert all(r.queued for r in trace.observation.received)
    from servoc import ssc32
    from servoc.model import host_channel
    servo = next(c.servo for c in b.plan.channels if host_channel(c.servo) == 1)
    n = ssc32.output_n((2000 - 3 * 79 - 500 + 4) // 8, 0, 250, servo.reverse, servo.trim)
    edges = trace.pin_edges(1, 1)
    last = [fall - rise for (rise, up), (fall, _) in zip(edges, edges[1:]) if up == 1][-1]
    assert (servo.port, servo.bit) == (1, 1) and last == b.plan.program.target.width_cycles(n), last


def test_lines_that_set_all_24_servos_back_to_back_lose_no_byte():
    # a group line stops the frame's reading, so each frame reads enough more than a frame brings
    # to catch up within the next line (flow.host_passes): 24-servo lines of the shortest kind
    # host_passes keeps up with (`#c P1500` each, 183 bytes), back to back for 8 s: every byte read.
    # With one byte more than a frame brings (the rule before), the queue overflowed within 4 s.
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    b = build_text(_program("stc89c58rd", pins, "main { host }"))
    p = flow.host_passes(b.plan)
    frame = b.plan.program.target.cycles(b.plan.period_us)
    from servoc import costs, target as target_mod
    per = Fraction(frame, costs.rx_gap(target_mod.byte_cycles(b.plan.program.serial.th1, b.plan.program.serial.smod)))
    line = flow.full_line(b.plan)
    assert line == 183 and p * (line / per - 1) >= line > p                # catches up within a line
    body = "".join("".join(f"#{c}P{1000 + (n * 37 + c * 11) % 900}" for c in range(24)) + "\\r"
                   for n in range(45))
    trace, report = watch(b, f'0.2s "{body}"\n', int(9.0e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert all(r.queued for r in trace.observation.received) and len(trace.observation.received) == 45 * 183



def test_one_channel_lines_to_24_servos_back_to_back_lose_no_byte():
    """What host libraries send: one line a servo (`#c P w` and CR, 8 or 9 bytes), back to back
    for 3 s, with 24 servos, where a frame brings about 28 bytes: three lines end in a frame's
    reading, and they join into one group. Every byte read, none lost, verify passes, and the
    last servo named lands on its width."""
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    b = build_text(_program("stc89c58rd", pins, "main { host }"))
    lines = [f"#{c}P{1000 + (n * 37 + c * 11) % 900}\\r" for n in range(14) for c in range(24)]
    body = "".join(lines)
    sent = len(body.replace("\\r", "\r"))
    trace, report = watch(b, f'0.2s "{body}"\n', int((1.0 + sent * 10 / 9600) * 1e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert all(r.queued for r in trace.observation.received) and len(trace.observation.received) == sent
    joined = [got for h in trace.observation.hosts for _, _, got in h.frames if bytes(got).count(b"\r") >= 2]
    assert len(joined) > 20


@pytest.mark.parametrize("size", [2, 3, 5])
def test_lines_of_a_few_servos_to_24_servos_back_to_back_lose_no_byte(size):
    """Lines that set 2, 3 or 5 servos (15 to 42 bytes), back to back for 3 s, with 24 servos, where
    a frame brings about 28 bytes. With the host's state in XRAM each entry keeps its line's
    generation, so a line after a group line writes its entries as they end and joins the group;
    the reading waits only before an entry for a servo the group gives a width, which here never
    comes in one frame. Every byte read, none lost, verify passes. (Stopping before every second
    entry after a group line, the reading fell behind with these lines and lost bytes.)"""
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    _lines_back_to_back(build_text(_program("stc89c58rd", pins, "main { host }")), size, lambda n: n * size)


def _lines_back_to_back(b, size: int, first, baud: int = 9600) -> list:
    """Lines that set `size` servos each, channels `first(n)` on for line n, back to back for 3 s at
    `baud`: verify passes and every byte is read, none lost. The readings."""
    lines = ["".join(f"#{c % 24}P{1000 + (n * 37 + c * 11) % 900}" for c in range(first(n), first(n) + size)) + "\\r"
             for n in range(3 * baud // 10 // (8 * size))]
    body = "".join(lines)
    sent = len(body.replace("\\r", "\r"))
    trace, report = watch(b, f'0.2s "{body}"\n', int((1.0 + sent * 10 / baud) * 1e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert all(r.queued for r in trace.observation.received) and len(trace.observation.received) == sent
    return [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames]


@pytest.mark.parametrize("chip, size, clock, baud", [
    ("stc89c58rd", 2, "11.0592MHz", 9600), ("stc89c58rd", 3, "11.0592MHz", 9600), ("stc89c52rc", 2, "11.0592MHz", 9600),
    ("stc89c58rd", 2, "11.0592MHz mode 6T", 19200), ("stc89c58rd", 3, "22.1184MHz", 19200)])
def test_lines_that_set_the_same_servos_back_to_back_lose_no_byte(chip, size, clock, baud):
    """The same 2 or 3 servos set by every line, back to back for 3 s, with 24 servos: each line
    after the first in a frame names servos the group waiting gives a width. Its entries that a
    '#' ends are held (layout.host_holds) rather than written over the group's, so the reading
    goes on into the next line. Every byte read, none lost, verify passes (with the reading
    stopped before each such entry until the commit, 873 of 3840 bytes of 2-servo lines were
    lost). Built for speed (STC89C58RD+) and for size (STC89C52RC, without the sequence that
    leaves no room for the holds' code there); and in 6T mode and at 22.1184 MHz at 19200 baud,
    each at the program's shortest period."""
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    text = _program(chip, pins, "main { host }", clock).replace("serial 9600", f"serial {baud}")
    b = build_text(re.sub(r"sequence wave \{[^}]*\}\n", "", text))
    assert layout.host_holds(b.plan) >= size - 1 and b.plan.period_us == b.plan.min_period_us
    readings = _lines_back_to_back(b, size, lambda n: 0, baud)
    assert sum(1 for got in readings if got.count(b"\r") >= 2) > 20    # lines naming the group's servos
                                                                        # were read in one frame


@pytest.mark.parametrize("ram, lines, want", [
    # channel 0's entry held in the second line; the third line's, written at its end, is later
    ("xram", "#0P1000\\r#0P2000#1P1300\\r#0P1500\\r", {0: 1500, 1: 1300}),
    # two entries for channel 0 held in one line: the later wins
    ("xram", "#0P1000\\r#0P1300#0P1800#1P900\\r", {0: 1800, 1: 900}),
    # channel 0's entry held, then its line goes bad: it is given back (the reading stops there)
    ("xram", "#0P1000\\r#0P2000#1x\\r", {0: 1000}),
    # in internal RAM every entry a '#' ends is held, and a line's last while one is: the first
    # held is written first, so the later wins
    ("iram", "#0P1000\\r#0P1300#0P1800\\r", {0: 1800}),
    ("iram", "#0P1000\\r#0P2000#1x\\r", {0: 1000}),
    # a one-entry line with nothing held is written in place at its end; the holds after it win
    ("iram", "#0P1000\\r#1P1200\\r#0P1500#1P900\\r", {0: 1500, 1: 900}),
])
def test_held_entries_keep_the_order_of_their_lines(ram, lines, want):
    """Lines queued before `host` runs, so that one frame's reading has them: after a group line
    for channel 0, a line naming it again holds that entry (layout.host_holds). A later line's
    entry for the same channel written at its line's end wins over the held one (host_flush
    leaves it); a held entry of a line that goes bad is given back. The servos settle where the
    lines say (widths from the pins, not from the model), and verify agrees frame by frame. With
    the state in XRAM (24 servos on an STC89C58RD+), and in internal RAM (2 servos at `frame
    20ms`, where a frame brings more bytes than a two-entry line)."""
    from servoc import ssc32
    from servoc.model import host_channel
    main = "main {\n  hold 300ms\n  host\n}"
    if ram == "xram":
        b = build_text(_program("stc89c58rd", [(p, b) for p in (1, 2, 0) for b in range(8)], main))
    else:
        b = build_text(_program("stc89c52rc", [(1, 0), (1, 1)], main).replace("host ssc32\n", "host ssc32\nframe 20ms\n"))
    assert layout.host_holds(b.plan) and flow.host_xram(b.plan) == (ram == "xram")
    trace, report = watch(b, f'0.02s "{lines}"\n', int(1.4e6 / b.plan.period_us))
    assert report.ok, problems(report)
    first = next(bytes(got) for h in trace.observation.hosts for _, _, got in h.frames if got)
    assert first == lines.replace("\\r", "\r").encode(), first         # one reading has them all
    target = b.plan.program.target
    for ch, width in want.items():
        servo = next(c.servo for c in b.plan.channels if host_channel(c.servo) == ch)
        n = ssc32.output_n((width - 500 + 4) // 8, 0, 250, servo.reverse, servo.trim)
        edges = trace.pin_edges(servo.port, servo.bit)
        last = [fall - rise for (rise, up), (fall, _) in zip(edges, edges[1:]) if up == 1][-1]
        assert last == target.width_cycles(n), (ch, last, target.width_cycles(n))


def test_a_receive_queue_past_internal_ram_is_host_ram_with_the_frame_to_shorten():
    # with the host's state in XRAM, a long frame at a fast rate makes a receive queue internal RAM
    # cannot hold: host-ram counts it and points at the frame, where it used to be a ram-overflow
    # about "the stack at 0x100"
    text = ("target stc89c58rd clock 11.0592MHz\nserial 9600\nframe 60ms\nhost ssc32\n"
            + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p in (1, 2, 0) for b in range(2)) + "main { host }\n")
    _, diags = front_end_text(text)
    errors = [d for d in diags if d.is_error]
    assert [d.code for d in errors] == ["host-ram"], [(d.code, d.message) for d in errors]
    assert "a receive queue of" in errors[0].message and "XRAM" in errors[0].message
    assert "shorter frame" in errors[0].help
    assert flow.host_xram(build_text(text.replace("frame 60ms\n", "")).plan)     # at its own period it builds


def test_ver_answers_back_to_back_follow_each_other_within_a_frame():
    """Group lines each followed by a `VER` line, back to back, with 24 servos (a frame is about 28
    byte times): the answers wait in HAQ, and each goes out as the transmit queue has room; the
    next VER's answer starts in the frame after the last byte of the one before goes in, never
    two frames later. verify allows a byte 2 P from the end of the byte before it: when the end
    of an answer was found a frame after its last byte went in, and the next VER's was taken a
    frame after that, its first byte came more than 2 P late."""
    from servoc import ssc32
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    b = build_text(re.sub(r"sequence wave \{[^}]*\}\n", "", _program("stc89c58rd", pins, "main { host }")))
    assert flow.host_xram(b.plan)
    body = "".join(f"#{n % 24}P{1000 + n * 37 % 900}\\rVER\\r" for n in range(40))
    trace, report = watch(b, f'0.2s "{body}"\n', int(3.0e6 / b.plan.period_us))
    assert report.ok, problems(report)
    sent = bytes(b for _, b in trace.sent)
    assert sent.count(ssc32.VERSION_REPLY) >= 5 and sent.replace(ssc32.VERSION_REPLY, b"") == b""


@pytest.mark.parametrize("answer", ["Q", "QP"])
def test_answer_lines_after_group_lines_are_read_on(answer):
    """24 servos (a frame brings about 28 bytes): group lines each followed by a `Q` or `QP` line,
    back to back. The reading goes on through the answer lines after a group line
    (flow.reads_answers): `QP`'s answer as its line ends, a `Q`'s once the group is committed (at
    the start of the next reading, HAQ's 0xFE), the answers after it behind it. verify passes,
    every answer line read is answered, in order; with `QP` no byte is lost (with the reading
    stopped before each answer line's end, a quarter of them were). With `Q`, the queue of answers
    (3) fills once a frame's Q lines wait behind the last frame's answers, which stops the reading
    as documented (verify checks that rule both ways)."""
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    b = build_text(re.sub(r"sequence wave \{[^}]*\}\n", "", _program("stc89c58rd", pins, "main { host }")))
    assert flow.reads_answers(b.plan) and b.plan.period_us == b.plan.min_period_us       # at its shortest
    pairs = [f"#{n % 24}P{1000 + n * 37 % 900}T200\\r" + (f"QP{n % 24}" if answer == "QP" else "Q") + "\\r"
             for n in range(120)]
    body = "".join(pairs)
    sent = len(body.replace("\\r", "\r"))
    trace, report = watch(b, f'0.2s "{body}"\n', int((1.0 + sent * 10 / 9600) * 1e6 / b.plan.period_us))
    assert report.ok, problems(report)
    readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames]
    read = b"".join(readings)
    assert sum(1 for got in readings if re.search(rb"\r(Q|QP\d+)\r#", got)) > 10     # read on in one frame
    lines = [ln for ln in read.split(b"\r")[:-1] if 0xFF not in ln]
    asked = [ln for ln in lines if ln.startswith(b"Q")]
    replies = bytes(x for _, x in trace.sent)
    assert len(replies) == len(asked), (len(replies), len(asked))
    if answer == "Q":
        assert set(replies) <= set(b"+.") and b"+" in replies
    else:
        lost = sent - sum(1 for r in trace.observation.received if r.queued)
        assert lost == 0 and 0 not in replies
