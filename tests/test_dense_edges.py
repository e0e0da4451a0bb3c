"""The frame engine's bad cases for its edges, each run in ucsim at exactly the shortest period
servoc reports for it, every pulse exact to the machine cycle, and that period less 1 µs refused.

The cases: all 24 lines at one N; every line one N from the next across three ports; half of each
port at N 0 and half at N 250, swapping; a port of one servo beside a port of eight; pairs of lines
whose order swaps every frame; and bytes back to back, at the highest rate the clock accepts, into a
select whose meanwhile body moves the lines one N apart. Four clocks: 12 MHz, 11.0592 MHz,
22.1184 MHz, and 11.0592 MHz in 6T mode.
"""

import pytest

from conftest import build_text, front_end_text, simulate_events
from servoc import api
from test_costs import all_at, at_period, own_minimum, servos

pytestmark = pytest.mark.toolchain

CLOCKS = {
    "12MHz": "",
    "11.0592MHz": "target stc89c52rc clock 11.0592MHz\n",
    "22.1184MHz": "target at89c52 clock 22.1184MHz\n",
    "11.0592MHz-6T": "target stc89c52rc clock 11.0592MHz mode 6T\n",
}

SWAP = "main { loop { move b in {1P}us; move a in {1P}us } }\n"

PAIRS = ((100, 101), (40, 200), (0, 250), (124, 126), (7, 9), (60, 61),
         (180, 90), (249, 250), (30, 31), (150, 152), (1, 2), (220, 210))


def crossed(i: int, first: bool) -> int:
    lo, hi = PAIRS[i // 2]
    return lo if (i % 2 == 0) == first else hi


ONE_AND_EIGHT = "servo s0 = P1.0 speed 0.0001s/60deg\n" + "".join(
    f"servo s{i} = P2.{i - 1} speed 0.0001s/60deg\n" for i in range(1, 9))

CASES = {
    "same-n": (24, servos(24) + all_at("a", 24, lambda i: 125) + all_at("b", 24, lambda i: 126) + SWAP),
    "one-apart": (24, servos(24) + all_at("a", 24, lambda i: i) + all_at("b", 24, lambda i: 250 - i) + SWAP),
    "ends": (24, servos(24) + all_at("a", 24, lambda i: 250 * (i % 2)) + all_at("b", 24, lambda i: 250 * (1 - i % 2))
             + SWAP),
    "one-and-eight": (9, ONE_AND_EIGHT + all_at("a", 9, lambda i: i) + all_at("b", 9, lambda i: 250 - i) + SWAP),
    "crossing": (24, servos(24) + all_at("a", 24, lambda i: crossed(i, True))
                 + all_at("b", 24, lambda i: crossed(i, False)) + SWAP),
}

def serial_program(lines: int) -> str:
    """`lines` servos one N apart, moving every frame, in a select's meanwhile body; each byte "x"
    moves them back and sends "k"."""
    return (servos(lines) + all_at("a", lines, lambda i: i) + all_at("b", lines, lambda i: 250 - i)
            + 'main { loop { select { on "x" { move a in {1P}us; send "k" } '
            + "meanwhile { loop { move b in {1P}us; move a in {1P}us } } } } }\n")


SERIAL = serial_program(24)

FRAMES = 120


def minimum(clock: str, template: str) -> int:
    return own_minimum(template, 9000) if CLOCKS[clock] else own_minimum(template)


def refused(template: str, period: int) -> bool:
    _, diags = front_end_text(at_period(template, period))
    return "period-too-short" in [d.code for d in diags if d.is_error]


@pytest.mark.parametrize("name,clock", [
    ("same-n", "12MHz"), ("same-n", "22.1184MHz"), ("same-n", "11.0592MHz-6T"),
    ("one-apart", "12MHz"), ("one-apart", "11.0592MHz"), ("one-apart", "11.0592MHz-6T"),
    ("ends", "11.0592MHz"), ("ends", "22.1184MHz"),
    ("one-and-eight", "12MHz"), ("one-and-eight", "11.0592MHz"), ("one-and-eight", "11.0592MHz-6T"),
    ("crossing", "11.0592MHz"), ("crossing", "22.1184MHz"), ("crossing", "11.0592MHz-6T"),
])
def test_dense_edges_verify_at_their_reported_minimum(name, clock):
    count, program = CASES[name]
    template = CLOCKS[clock] + program
    period = minimum(clock, template)
    built = build_text(at_period(template, period))
    assert built.plan.period_us == built.plan.min_period_us == period
    report = built.verify(FRAMES)
    assert report.ok and report.max_error_cycles == 0, (name, clock, period, report.summary(),
                                                        [str(m) for m in report.mismatches[:5]])
    assert report.pulses == FRAMES * count
    assert refused(template, period - 1)


def bytes_back_to_back(clock: str, baud: int, lines: int = 24):
    """`serial_program(lines)` at its shortest period with bytes back to back for the whole run:
    every pulse exact, every answer sent, 1 µs less refused. (template, period, plan)."""
    template = CLOCKS[clock] + f"serial {baud}\n" + serial_program(lines)
    period = minimum(clock, template)
    text = at_period(template, period)
    scenario = "50ms " + " ".join(['"x"'] * (FRAMES * period * baud // 10_000_000)) + "\n"
    plan, evs, trace = simulate_events(text, scenario, FRAMES)
    assert plan.period_us == plan.min_period_us == period
    report = api.check_events(plan, trace, FRAMES, evs)
    assert report.ok and report.max_error_cycles == 0, (clock, baud, period, report.summary(),
                                                        [str(m) for m in report.mismatches[:5]])
    assert report.pulses == FRAMES * lines
    assert report.bytes_sent >= FRAMES // 2
    assert refused(template, period - 1)
    return template, period, plan


@pytest.mark.parametrize("clock,baud,faster,refusal", [("12MHz", 4800, 9600, "bad-baud"),
                                                       ("22.1184MHz", 19200, 28800, "serial-too-fast")])
def test_bytes_back_to_back_at_the_highest_rate_during_dense_edges(clock, baud, faster, refusal):
    """Bytes come back to back for the whole run: the select takes one whenever it looks and the
    queue drops the rest; every pulse stays exact and every answer is sent in time."""
    template, period, _ = bytes_back_to_back(clock, baud)
    with pytest.raises(AssertionError, match=refusal):
        build_text(at_period(template.replace(f"serial {baud}", f"serial {faster}"), period))


def test_bytes_back_to_back_while_rises_come_as_steps():
    """At 11.0592 MHz and 4800 baud the firmware makes a rise less than SPLIT after the last fall a
    step of that fall's run (its handler runs are longer than an entry's rise): bytes back to back
    for the whole run, every pulse exact and every answer sent, at the shortest period, 1 µs less
    refused."""
    assert bytes_back_to_back("11.0592MHz", 4800)[2].rise_steps


def test_bytes_back_to_back_while_rises_come_among_falls_with_the_motion_state_in_xram():
    """In 6T mode at 9600 baud the 24 servos' select leaves internal RAM no room for the two item
    buffers beside the motion state: it moves to XRAM, and each port rises among the falls of the
    port before it. Bytes back to back for the whole run, every pulse exact and every answer sent,
    at the shortest period, 1 µs less refused."""
    template, period, plan = bytes_back_to_back("11.0592MHz-6T", 9600)
    assert plan.rises_among_falls and not plan.ports_at_once
    assert "XSTATE" in build_text(at_period(template, period)).firmware.unit.text


def test_bytes_back_to_back_while_the_ports_pulse_at_once():
    """In 6T mode at 9600 baud, 16 servos on two ports: the ports pulse at once, and the edge
    handler's longest stretch (everything it does in a frame) leaves the serial handler its time
    for each byte; bytes back to back for the whole run, every pulse exact and every answer sent,
    at the shortest period, 1 µs less refused. (Rises among falls with bursts of bytes at the
    highest rate: test_stagger.py, at 11.0592 MHz and 12 MHz, where the ports cannot pulse at once.)"""
    assert bytes_back_to_back("11.0592MHz-6T", 9600, 16)[2].ports_at_once
