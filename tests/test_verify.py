"""verify must fail on wrong firmware: patched HEX images and traces of other plans.

A verify that cannot fail is useless: each test here breaks the firmware (or
hands verify someone else's trace) and checks that the report names the
frame, the servo, the expected and the measured pulse.
"""

from __future__ import annotations

import dataclasses
import itertools
import io
import re

import pytest
from intelhex import IntelHex

from servoc import api, costs, verify

from servoc.plan import expand
from conftest import assert_exact, build_engine, build_text, parse_listing

pytestmark = pytest.mark.toolchain

PROGRAM = """\
frame 6ms
servo a = P1.0
servo b = P1.2
servo c = P1.5
servo d = P2.1
pose p { a: 10, b: 120, c: 250, d: 33 }
pose q { a: 11, b: 119, c: 250, d: 0 }
main {
  move p
  hold 30ms
  move q
  hold 30ms
}
"""

EXPECTED = {"a": 10, "b": 120, "c": 250, "d": 33}


@pytest.fixture(scope="module")
def good():
    built = build_engine(PROGRAM)       # the ports pulsed one after another: the code the patches below expect
    assert_exact(built.verify(), PROGRAM)
    return built


def patched(built, patches: dict[int, int]):
    """The firmware with some code bytes replaced."""
    ih = IntelHex()
    ih.loadhex(io.StringIO(built.firmware.hex_text))
    for addr, value in patches.items():
        ih[addr] = value
    buf = io.StringIO()
    ih.write_hex_file(buf, write_start_addr=False, byte_count=16)
    image = dataclasses.replace(built.firmware.image, hex_text=buf.getvalue().replace("\r\n", "\n"))
    return dataclasses.replace(built.firmware, image=image)


def instr(built, op: str, *args: str, label: str | None = None):
    instrs, labels = parse_listing(built.firmware.image.listing)
    if label is not None:
        return instrs[labels[label]], instrs, labels
    found = [i for i in instrs if i.op == op and i.args[:len(args)] == args]
    assert len(found) == 1, (op, args, found)
    return found[0], instrs, labels


def mismatch_text_ok(m: verify.Mismatch) -> None:
    text = str(m)
    assert f"frame {m.frame}" in text and m.servo in text and m.pin in text
    if m.expected_us is not None:
        assert f"expected {m.expected_us} cycles" in text
    if m.measured_us is not None:
        assert f"measured {m.measured_us} cycles" in text


def test_a_late_rise_is_caught(good):
    """P1's rise stub takes a 2-cycle INC DPTR for its 1-cycle NOP: the rise comes 1 cycle late,
    the falls do not move, so every P1 pulse is 1 cycle short; P2's are not."""
    instrs, labels = parse_listing(good.firmware.image.listing)
    rise = next(i for i, ins in enumerate(instrs) if ins.op == "MOV" and ins.args == ("A", "RISEM")
                and instrs[i + 2].args == ("P1", "A"))
    nop = instrs[rise + 1]
    assert nop.op == "NOP"
    report = api.verify(good.plan, patched(good, {nop.address: 0xA3}), 12)     # INC DPTR
    assert not report.ok
    widths = [m for m in report.mismatches if "width off by -1 cycles" in m.what]
    assert {m.servo for m in widths} == {"a", "b", "c"}
    assert {m.frame for m in widths} == set(range(1, 13))
    for m in widths:
        mismatch_text_ok(m)
        assert m.measured_us == m.expected_us - 1
    first = next(m for m in widths if m.frame == 1 and m.servo == "b")
    assert (first.expected_us, first.measured_us) == (500 + 8 * 120, 500 + 8 * 120 - 1)
    assert not any(m.servo == "d" and "width" in m.what for m in report.mismatches)


def test_a_wrong_interval_between_entries_is_caught(good):
    """exit_far adds one more to Timer0: each later entry of a port comes 1 cycle earlier than it
    should. P1's lines fall in three entries (N 10, 120, 250 are far apart): b 1 short, c 2 short."""
    instrs, labels = parse_listing(good.firmware.image.listing)
    start = labels["exit_far"]
    add = next(ins for ins in instrs[start:] if ins.op == "ADD" and ins.args == ("A", f"#{costs.STOP + 1}"))
    value = int(add.args[1].lstrip("#"), 0)
    report = api.verify(good.plan, patched(good, {add.address + 1: value + 1}), 5)
    assert not report.ok
    bad = {(m.frame, m.servo): m for m in report.mismatches if "width" in m.what}
    for frame in range(1, 6):
        for servo, off in (("b", -1), ("c", -2)):
            m = bad[(frame, servo)]
            mismatch_text_ok(m)
            assert m.measured_us == m.expected_us + off and f"off by {off} cycles" in m.what
        assert (frame, "a") not in bad and (frame, "d") not in bad


def test_wrong_target_in_a_record_is_caught(good):
    """A move record with d's N changed from 33 to 34: one DIV long in the frames of that pose."""
    lines = good.firmware.image.listing.splitlines()
    rec = next(i for i, line in enumerate(lines) if re.search(r"\blist1:", line))
    db = next(line for line in lines[rec:] if ".db" in line)      # the list's first record
    address = int(db[6:12], 16)
    values = [int(v.strip(), 0) for v in db.split(".db", 1)[1].split(";")[0].split(",")]
    assert values[-4:] == [10, 120, 250, 33]
    report = api.verify(good.plan, patched(good, {address + len(values) - 1: 34}), 10)
    assert not report.ok
    assert {m.servo for m in report.mismatches} == {"d"}
    m = report.mismatches[0]
    assert (m.frame, m.expected_us, m.measured_us) == (1, 500 + 8 * 33, 500 + 8 * 34)
    assert "width off by 8 cycles" in m.what
    mismatch_text_ok(m)


def test_missing_reset_is_caught(good):
    """Without the reset's ANL P1 the P1 servo lines stay high until their first edge."""
    anl, _, _ = instr(good, "ANL", label="reset")
    assert anl.args[0] == "P1"
    report = api.verify(good.plan, patched(good, {anl.address: 0, anl.address + 1: 0, anl.address + 2: 0}), 4)
    assert not report.ok
    reset = [m for m in report.mismatches if "reset" in m.what]
    assert {m.servo for m in reset} == {"a", "b", "c"} and all(m.frame == 0 for m in reset)
    assert report.reset_low_cycles > verify.RESET_LOW_US


def test_non_servo_pin_change_is_caught(good):
    """The reset clears P1.7 too, which is not a servo."""
    anl, _, _ = instr(good, "ANL", label="reset")
    assert anl.args[0] == "P1"
    mask = int(anl.args[1].lstrip("#"), 0)
    report = api.verify(good.plan, patched(good, {anl.address + 2: mask & 0x7F}), 4)
    assert not report.ok
    assert [(m.pin, m.what) for m in report.mismatches] == [("P1.7", "a pin that is not a servo changed")]


def other(text_changes: dict[str, str]):
    text = PROGRAM
    for old, new in text_changes.items():
        assert old in text
        text = text.replace(old, new)
    return build_engine(text)       # the same handler as `good`


def test_trace_of_another_plan_is_caught(good):
    """verify(plan A, trace of firmware B): B moves b to 121 where A says 120."""
    wrong = other({"b: 120": "b: 121"})
    trace = api.simulate(wrong.firmware.hex_text, verify.cycles_needed(good.plan, 10))
    report = verify.verify(good.plan, trace, 10)
    assert not report.ok
    m = report.mismatches[0]
    assert (m.frame, m.servo, m.pin, m.expected_us, m.measured_us) == (1, "b", "P1.2", 1460, 1468)
    assert str(m).startswith("frame 1, b (P1.2): expected 1460 cycles, measured 1468 cycles")
    assert report.max_error_cycles == 8


def test_wrong_period_is_caught(good):
    """A firmware one microsecond per frame slow drifts out of its frame slots."""
    wrong = other({"frame 6ms": "frame 6001us"})
    report = api.verify(good.plan, wrong.firmware, 10)
    assert not report.ok
    assert any("from its frame slot" in m.what for m in report.mismatches)
    assert all(m.frame >= 3 for m in report.mismatches)


def test_early_pulse_and_missing_pulse_are_caught():
    """Plan: d gets its first target in the second move; firmware: d pulses from frame 1 and a never."""
    plan_text = PROGRAM.replace("d: 33", "d: 0").replace("pose p { a: 10, b: 120, c: 250, d: 0 }",
                                                         "pose p { a: 10, b: 120, c: 250 }")
    planned = build_text(plan_text)
    fw_text = PROGRAM.replace("pose p { a: 10,", "pose p {").replace("pose q { a: 11,", "pose q {") \
        .replace("servo a = P1.0\n", "servo a = P1.0\npose unused { a: 1 }\n")
    wrong = build_text(fw_text.replace("main {\n", "main {\n  hold 0ms\n"))
    report = api.verify(planned.plan, wrong.firmware, 8)
    assert not report.ok
    whats = {(m.servo, m.what) for m in report.mismatches}
    assert ("d", "pulse before any target") in whats
    assert ("a", "pulse missing") in whats


def test_eased_frames_are_compared_exactly():
    """The firmware's eased values are known exactly (its curve table): every frame where they
    differ is caught, the last frame of the move included."""
    base = """\
frame 6ms
servo a = P0.3 speed 0.001s/60deg
pose lo { a: 0 }
pose hi { a: TARGET }
main {
  move lo
  move hi in 60ms ease in-out
  hold 12ms
}
"""
    planned = build_text(base.replace("TARGET", "200"))
    near = build_text(base.replace("TARGET", "201"))
    report = api.verify(planned.plan, near.firmware, 14)
    assert not report.ok
    frames = sorted({m.frame for m in report.mismatches})
    lead = verify.first_pulse_frame(planned.plan)
    golden = list(itertools.islice(zip(expand(planned.plan), expand(near.plan)), lead, lead + 14))
    differ = [j for j, (a, b) in enumerate(golden, start=1) if a.n != b.n]
    assert frames == differ
    assert {11, 12, 13, 14} <= set(frames) and len(frames) < 14   # the move's last frame, the hold, the repeat
    assert all(m.measured_us - m.expected_us == 8 for m in report.mismatches)


def test_write_to_a_port_without_servos_is_caught(good):
    """The reset's ANL P1 retargeted to P0, which has no servo: P0's pins change, and that is caught
    as well as P1's servo lines staying high."""
    anl, _, _ = instr(good, "ANL", label="reset")
    assert anl.args[0] == "P1"
    report = api.verify(good.plan, patched(good, {anl.address + 1: 0x80}), 4)
    assert not report.ok
    changed = sorted(m.pin for m in report.mismatches if m.what == "a pin that is not a servo changed")
    mask = int(anl.args[1].lstrip("#"), 0)
    assert changed == [f"P0.{b}" for b in range(8) if not mask & (1 << b)]
    assert {m.servo for m in report.mismatches if "reset" in m.what} == {"a", "b", "c"}


FIRST_PULSE_CASES = {
    "waits for a byte": ('serial 4800\nservo a = P1.0\npose p { a: 10 }\n'
                         'main { loop { select { on "a" { move p } } } }\n', None),
    "a hold, then a move": "servo a = P1.0\npose p { a: 10 }\nmain { hold 2s; move p }\n",
    "an `after` cuts a wait in its meanwhile body": (
        "input b = P3.2\nservo a = P1.0\npose p { a: 10 }\nmain { select { on press b { move p } after 1s "
        "{ move p } meanwhile { select { on press b { move p } } } } }\n"),
    "an `after`": "input b = P3.2\nservo a = P1.0\npose p { a: 10 }\nmain { select { on press b { move p } after 300ms { move p } } }\n",
    "a wait, then a move": ("input b = P3.2\nservo a = P1.0\npose p { a: 10 }\nmain { wait press b; move p }\n", None),
}


@pytest.mark.parametrize("name", sorted(FIRST_PULSE_CASES))
def test_the_first_pulse_is_found_where_expand_puts_it_and_a_wait_forever_ends_the_search(name):
    """`first_pulse_frame` gives the first frame of `expand` with a pulse; where a select that waits
    forever (no choice, no `after` around it) comes before any pulse, there is none, and the search
    ends there rather than after SEARCH_FRAMES frames."""
    from conftest import front_end_text
    case = FIRST_PULSE_CASES[name]
    text, forever = case if isinstance(case, tuple) else (case, False)
    fe, diags = front_end_text(text)
    assert fe.plan is not None, [d.message for d in diags]
    plan = fe.plan
    frames = list(itertools.islice(expand(plan), 5000))
    want = next((i for i, fr in enumerate(frames) if any(n is not None for n in fr.n)), None)
    got = verify.first_pulse_frame(plan)
    assert got == want
    if forever is None:
        assert got is None
        with pytest.raises(verify._Still):
            next(iter(expand(plan, verify._UntilStill(()))))
    else:
        assert got is not None
