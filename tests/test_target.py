"""Targets: every chip of servoc.target builds and verifies in ucsim; code memory is the chip's own.

Each chip is tried at 12 MHz, and the STC89 chips also at 6 MHz in 6T mode
(ucsim runs its 12-clock core at twice the crystal: the same machine cycle);
other crystals are tried in tests/test_clocks.py.
"""

import pytest

from conftest import assert_exact, build_text, front_end_text, pose, servo_decls
from servoc import api, target
from servoc.diagnostics import Reporter
from servoc.source import SourceFile

pytestmark = pytest.mark.toolchain

SMALL = (servo_decls([(1, 0), (1, 1), (2, 3)]) + pose("a", {"s1_0": 0, "s1_1": 125, "s2_3": 250})
         + pose("b", {"s1_0": 61, "s1_1": 124, "s2_3": 3}) + "main { move a; move b in 800ms ease in-out; hold 30ms }\n")


def targets():
    for name, chip in target.CHIPS.items():
        yield f"target {name}"
        yield f"target {chip.display.rstrip('+')} clock 12MHz mode 12T"
        if chip.six_t:
            yield f"target {name} clock 6MHz mode 6T"


@pytest.mark.parametrize("line", list(targets()))
def test_every_chip_builds_and_verifies(line):
    built = build_text(line + "\n" + SMALL)
    t = built.plan.program.target
    assert t.cycle_us == 1 and t.sim_hz == 12_000_000
    assert built.firmware.unit.target == t
    assert_exact(built.verify(), line)


def big_program(chip: str) -> str:
    pins = [(p, b) for p in range(3) for b in range(8)]
    text = f"target {chip}\n" + servo_decls(pins, options="speed 0.001s/60deg")
    for k in range(330):
        text += pose(f"v{k}", {f"s{p}_{b}": (k * 7 + 3 * b + p) % 251 for p, b in pins})
    return text + "main {\n" + "".join(f"  move v{k} in 20ms\n" for k in range(330)) + "}\n"


def build(text: str):
    source = SourceFile("big.servo", text)
    reporter = Reporter(source)
    fe, fw = api.build(source, reporter)
    return fw, [d for d in reporter.diagnostics if d.is_error]


def test_a_program_too_big_for_8_kb_builds_for_the_at89c55wd():
    fw, errors = build(big_program("at89c52"))
    assert fw is None and [d.code for d in errors] == ["rom-overflow"]
    assert "the AT89C52 has 8192" in errors[0].message and "`target at89c55wd`" in errors[0].help
    fw, errors = build(big_program("at89c55wd"))
    assert not errors and 8192 < fw.rom_bytes <= 20 * 1024
    fe, _ = front_end_text(big_program("at89c55wd"))
    report = api.verify_hex(fe.plan, fw.hex_text, 40)
    assert report.ok and report.pulses == 40 * 24, report.summary()


def test_too_slow_a_clock_is_refused_before_any_code():
    fe, diags = front_end_text("target stc89c52rc clock 8MHz\n" + SMALL)
    (err,) = [d for d in diags if d.is_error]
    assert err.code == "bad-clock" and "the lowest clock that works is 10.5 MHz" in err.help


@pytest.mark.parametrize("chip", ["at89c55wd", "stc89c58rd"])
def test_frames_needed_tables_sit_at_the_top_of_a_bigger_chip(chip):
    """A move without duration entered from two places has its F looked up at run time, in
    tables on the last pages of the chip's own code memory."""
    text = (f"target {chip}\n" + servo_decls([(1, 0), (1, 1)]) + pose("a", {"s1_0": 0, "s1_1": 30})
            + pose("b", {"s1_0": 200, "s1_1": 90}) + pose("c", {"s1_0": 100, "s1_1": 250})
            + "sequence go { move c }\nmain { move a; play go; move b in 1s; play go }\n")
    built = build_text(text)
    top = target.CHIPS[chip].code_bytes
    assert built.firmware.unit.fneed_pages and max(built.firmware.unit.fneed_pages) * 256 < top
    assert top - 2 * 256 * len(built.plan.speed_tables) == min(built.firmware.unit.fneed_pages) * 256
    assert_exact(built.verify(), text)
