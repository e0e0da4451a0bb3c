"""`host` on an STC89 with several ports of servos: its per-servo state and the DDA's error terms
are kept in the chip's XRAM (flow.host_xram, docs/host-protocol.md), read and written with
MOVX @DPTR in page 0. Each session runs in ucsim at the program's shortest period under the
heaviest lines (every servo with S in every line, Q, QP and PO lines between them) and is checked
by verify's model of the protocol; 1 µs less is refused.
"""
from __future__ import annotations

import re

import pytest

from conftest import build_text, front_end_text
from servoc import flow
from test_verify_observes import problems, watch

pytestmark = pytest.mark.toolchain


def _program(chip: str, pins: list[tuple[int, int]], main: str = "main { host }") -> str:
    servos = "".join(f"servo s{i} = P{p}.{b}{' reverse' if i % 3 == 1 else ''} trim {i % 5 - 2}\n"
                     for i, (p, b) in enumerate(pins))
    pose = ", ".join(f"s{i}: {40 + (13 * i) % 100}" for i in range(len(pins)))
    return (f"target {chip} clock 11.0592MHz\nserial 9600\nhost ssc32\n{servos}"
            f"pose p {{ {pose} }}\nhome p\n{main}\n")


def _at_shortest(text: str):
    b = build_text(text)
    for _ in range(6):
        if b.plan.min_period_us == b.plan.period_us:
            break
        text = re.sub(r"host ssc32\n(frame \d+us\n)?", f"host ssc32\nframe {b.plan.min_period_us}us\n", text)
        b = build_text(text)
    assert b.plan.period_us == b.plan.min_period_us
    return b, text


@pytest.mark.parametrize("chip, pins", [
    ("stc89c52rc", [(p, b) for b in range(8) for p in (1, 2)]),            # 16 servos on two ports
    ("stc89c58rd", [(p, b) for b in range(7) for p in (0, 1, 2)]),         # 21 on three
])
def test_host_state_in_xram_holds_the_heaviest_lines_at_the_shortest_period(chip, pins):
    text = _program(chip, pins)
    b, text = _at_shortest(text)
    assert flow.host_xram(b.plan)
    assert "MOVX    @DPTR, A" in b.firmware.unit.text and "HPW     = 0x00" in b.firmware.unit.text
    count = len(pins)
    body = ""
    for k in range(4):
        body += "".join(f"#{i}P{600 + (k * 370 + i * 190) % 1900}S{300 + 97 * k + i}" for i in range(count))
        body += f"T30\\rQ\\rQP{k % count}\\r" + (f"#{k % count}PO{40 - 19 * k}\\r" if k % 2 == 0 else "")
    body += "#1P1500#2P1500\\x1b#3P900\\r#4P2000X\\r"      # an ESC and a bad line drop only their own
    trace, report = watch(b, f'0.1s "{body}"\n', int(2.0e6 / b.plan.period_us))
    assert report.ok, problems(report)
    assert len(trace.sent) == 8                                         # every Q and QP answered
    shorter = re.sub(r"host ssc32\n(frame \d+us\n)?", f"host ssc32\nframe {b.plan.min_period_us - 1}us\n", text)
    _, diags = front_end_text(shorter)
    assert any(d.code == "period-too-short" for d in diags), [d.code for d in diags]


def test_without_xram_the_same_program_is_refused_with_the_chip_that_holds_it():
    pins = [(p, b) for b in range(8) for p in (1, 2)]
    _, diags = front_end_text(_program("at89c52", pins))
    errors = [d for d in diags if d.is_error]
    assert [d.code for d in errors] == ["host-ram"]
    assert "stc89c58rd" in errors[0].help and "5 for each of the 16 servos" in errors[0].message


def test_twenty_four_servos_with_host_are_refused_by_what_the_firmware_allocates():
    pins = [(p, b) for b in range(8) for p in (0, 1, 2)]
    _, diags = front_end_text(_program("stc89c58rd", pins))
    errors = [d for d in diags if d.is_error]
    assert [d.code for d in errors] == ["host-ram"], [d.code for d in errors]
    assert "XRAM" in errors[0].message and "bytes short" in errors[0].message
