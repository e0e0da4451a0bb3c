"""Input pins on a port that also has servos: the firmware never drives them, and verify models
what drives them from outside (the events, and every input inactive from the start)."""

from __future__ import annotations

import pytest

from conftest import build_text, simulate_events
from servoc import api, toolchain

pytestmark = pytest.mark.toolchain

PROGRAM = """\
servo arm = P1.0
input btn = P1.7{level}
pose a {{ arm: 100 }}
pose b {{ arm: 140 }}
main {{
  move a
  loop {{
    wait btn
    move b in 300ms
    move a in 300ms
  }}
}}
"""
SCENARIO = "500ms btn active\n700ms btn inactive\n1.5s btn active\n1.52s btn inactive\n"


def run(text: str, scenario: str, frames: int = 400, hex_text: str | None = None):
    plan, evs, trace = simulate_events(text, scenario, frames, hex_text)
    return plan, api.check_events(plan, trace, frames, evs)


@pytest.mark.parametrize("level", ["", " low", " high"])
def test_an_input_on_a_servo_port_verifies(level):
    _, report = run(PROGRAM.format(level=level), SCENARIO)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:4]])
    assert report.pulses > 300


@pytest.mark.parametrize("level", ["", " high"])
def test_with_no_events_the_input_stays_inactive(level):
    built = build_text(PROGRAM.format(level=level))
    report = api.verify(built.plan, built.firmware, 200)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:4]])
    widths = {m.expected_us for m in report.mismatches}
    assert not widths


def test_a_firmware_that_writes_an_input_latch_fails():
    # the same firmware, but its reset clears P1.7's latch too: the pin is held low, and verify says so
    built = build_text(PROGRAM.format(level=" high"))
    text = built.firmware.unit.text
    assert "ANL     P1, #0xFE" in text
    bad = toolchain.assemble(text.replace("ANL     P1, #0xFE", "ANL     P1, #0x7E"), name="bad").hex_text
    _, report = run(PROGRAM.format(level=" high"), SCENARIO, hex_text=bad)
    assert not report.ok
    assert any("the firmware wrote its latch" in m.what and m.pin == "P1.7" for m in report.mismatches)
