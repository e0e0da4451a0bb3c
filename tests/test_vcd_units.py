"""The VCD at other crystals: its times are in the unit its timescale names, and it carries the
inputs, RXD and TXD next to the pulses."""

from __future__ import annotations

import pytest

from servoc.cli import main
from test_vcd import high_pulses, read_vcd

pytestmark = pytest.mark.toolchain

PROGRAM = """\
target stc89c52rc {clock}
serial {baud}
input button = P3.2
servo pan = P1.0
pose mid {{ pan: 90deg }}
pose side {{ pan: 100deg }}
main {{
  move mid
  loop {{
    select {{
      on button {{ move side in 100ms; move mid in 100ms }}
      on "a" {{ send "b" }}
    }}
  }}
}}
"""
EVENTS = '300ms button active\n320ms button inactive\n700ms "a"\n'


def uart_bytes(wave: list[tuple[int, int]], bit_ns: float) -> list[int]:
    """The bytes on a serial line's waveform: each start bit, then 8 data bits sampled mid-bit."""
    def level_at(t: float) -> int:
        lv = 1
        for at, v in wave:
            if at > t:
                break
            lv = v
        return lv
    out, t = [], 0
    for at, v in wave[1:]:
        if v == 0 and at >= t:
            out.append(sum(level_at(at + (k + 1.5) * bit_ns) << k for k in range(8)))
            t = at + 10 * bit_ns - bit_ns / 2
    return out


@pytest.mark.parametrize("clock,baud,cycle_ns", [("clock 11.0592MHz", 9600, 1e6 / 921.6),
                                                  ("clock 11.0592MHz mode 6T", 9600, 1e6 / 1843.2)])
def test_vcd_times_are_nanoseconds_and_it_shows_the_button_and_the_bytes(tmp_path, capsys, clock, baud, cycle_ns):
    prog = tmp_path / "pan.servo"
    prog.write_text(PROGRAM.format(clock=clock, baud=baud))
    events = tmp_path / "pan.events"
    events.write_text(EVENTS)
    vcd = tmp_path / "pan.vcd"
    assert main(["verify", str(prog), "--events", str(events), "--vcd", str(vcd)]) == 0, capsys.readouterr()
    dump = read_vcd(vcd.read_text(encoding="ascii"))
    assert dump.timescale in ("1 ns", "1ns")
    widths = {w for _, w in high_pulses(dump.waves("servoc.P1.pan"))}
    assert any(abs(w - 1_476_000) <= cycle_ns / 2 + 1 for w in widths), sorted(widths)[:5]    # 90deg = 1476 µs
    assert all(abs(w - 1_476_000) <= cycle_ns / 2 + 1 or abs(w - 1_636_000) <= 200_000 for w in widths)
    button = dump.waves("servoc.P3.button")
    assert [v for _, v in button] == [1, 0, 1]                  # active low: pressed at 300 ms, released at 320
    assert abs(button[1][0] - 300_000_000) <= 10 * cycle_ns and abs(button[2][0] - 320_000_000) <= 10 * cycle_ns
    bit_ns = 1e9 / baud
    rxd, txd = dump.waves("servoc.serial.RXD"), dump.waves("servoc.serial.TXD")
    assert abs(rxd[1][0] - 700_000_000) <= 2 * cycle_ns         # the start bit at the event's time
    assert uart_bytes(rxd, bit_ns * 0.9995) == [ord("a")]
    assert uart_bytes(txd, bit_ns * 0.9995) == [ord("b")]
    assert rxd[1][0] < txd[1][0] < rxd[1][0] + 30_000_000       # the answer within a few frames
