"""Crystals other than 12 MHz: every line falls round_half_up((500 + 8 N) µs / t_c) machine cycles
after its port's rise, measured on ucsim's own trace (not only through `verify`).

The programs put lines on one port one DIV apart (7 cycles at the lowest clock), many lines on one N
(merged edges), N = 0 and 250 together (the longest gaps), and all three ports in use.
"""

from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import assert_exact, build_engine, build_text, front_end_text
from servoc import api, costs, target, toolchain

pytestmark = pytest.mark.toolchain

CLOCKS = [
    ("stc89c52rc", "11.0592MHz", ""), ("at89c52", "22.1184MHz", ""), ("at89c52", "24MHz", ""),
    ("at89s52", "33MHz", ""), ("stc89c52rc", "11.0592MHz", "6T"), ("stc89c58rd", "22.1184MHz", "6T"),
    ("stc89c58rd", "40MHz", "6T"), ("at89c55wd", "10.5MHz", ""), ("stc89c52rc", "10.6MHz", ""),
    ("stc89c52rc", "5.25MHz", "6T"),     # the lowest clocks that work: 10.5 MHz, 5.25 MHz in 6T mode
]


def expected_cycles(clock_mhz: Fraction, six_t: bool, n: int) -> int:
    """The spec's formula, written out here on its own: round_half_up((500 + 8 N) us / t_c)."""
    t_c = Fraction(6 if six_t else 12) / clock_mhz
    return int((500 + 8 * n) / t_c + Fraction(1, 2))


def program(line: str, values: list[list[int]]) -> str:
    pins = [(p, b) for p in range(3) for b in range(8)][:len(values[0])]
    text = line + "\n" + "".join(f"servo s{i} = P{p}.{b} speed 0.001s/60deg\n" for i, (p, b) in enumerate(pins))
    for k, row in enumerate(values):
        text += f"pose q{k} {{ " + ", ".join(f"s{i}: {v}" for i, v in enumerate(row)) + " }\n"
    return text + "main { loop { " + "; ".join(f"move q{k} in 10ms; hold 20ms" for k in range(len(values))) + " } }\n"


ROWS = [
    [0, 1, 2, 3, 4, 5, 6, 7] + [250] * 8 + [125, 126, 125, 127, 0, 250, 249, 248],
    [7, 6, 5, 4, 3, 2, 1, 0] + [0, 250, 0, 250, 1, 249, 2, 248] + [100] * 8,
    [250, 249, 248, 247, 246, 245, 244, 243] + [61, 62, 64, 67, 71, 76, 82, 89] + [3, 3, 4, 4, 5, 5, 6, 6],
]


def measured_widths(built, frames: int = 12):
    plan = built.plan
    t = plan.program.target
    trace = api.simulate(built.firmware.hex_text, (frames + 3) * t.cycles(plan.period_us) + t.cycles(5000), t)
    return {c.index: trace.pulses(c.port, c.bit) for c in plan.channels}


@pytest.mark.parametrize("chip,clock,mode", CLOCKS)
def test_widths_follow_the_formula_in_machine_cycles(chip, clock, mode):
    line = f"target {chip} clock {clock}" + (f" mode {mode}" if mode else "")
    built = build_text(program(line, ROWS))
    mhz = Fraction(clock[:-3])
    formula = {expected_cycles(mhz, mode == "6T", n) for n in range(251)}
    t = built.plan.program.target
    frames = 3 * (t.cycles(30_000) // t.cycles(built.plan.period_us) + 2)
    period = t.cycles(built.plan.period_us)
    for ch, pulses in measured_widths(built, frames).items():
        widths = {w for _, w in pulses}
        assert all(b - a == period for (a, _), (b, _) in zip(pulses, pulses[1:]))
        assert widths <= formula, (ch, sorted(widths - formula))
        # each pose is held for 20 ms: its own width is there, to the cycle
        assert {expected_cycles(mhz, mode == "6T", row[ch]) for row in ROWS} <= widths, ch
    assert_exact(built.verify(60), line)


def test_the_edge_table_is_the_formula():
    """The firmware's C(N) table (`ctab`: low bytes, then high bytes a page later) is the formula."""
    built = build_text(program("target stc89c52rc clock 11.0592MHz", ROWS[:1]))
    image = built.firmware.image
    ih = toolchain._load_hex(image.hex_text)
    at = image.symbols["ctab"]
    table = [ih[at + n] + 256 * ih[at + 256 + n] for n in range(251)]
    assert table == [expected_cycles(Fraction("11.0592"), False, n) for n in range(251)]
    assert table[0] == 461 and table[250] == 2304
    t = built.plan.program.target
    assert float(t.width_error_us()) == pytest.approx(0.5417, abs=1e-4)
    assert target.DEFAULT.width_error_us() == 0


def test_compile_reports_the_clock_and_the_width_error(tmp_path, capsys):
    from servoc.cli import main
    src = tmp_path / "b.servo"
    src.write_text(program("target stc89c52rc clock 11.0592MHz", ROWS[:1]), encoding="utf-8")
    assert main(["compile", str(src), "-o", str(tmp_path / "b.hex")]) == 0
    out = capsys.readouterr().out
    assert "STC89C52RC at 11.0592 MHz, machine cycle 1.0851 µs, widths within 0.5417 µs of 500 + 8 N µs" in out
    assert (tmp_path / "b.hex").read_text().startswith(":")


def test_a_frame_the_timer_cannot_count_is_refused():
    """At 40 MHz in 6T mode a machine cycle is 0.15 µs: Timer0's 65535 cycles are 9.83 ms."""
    text = program("target stc89c58rd clock 40MHz mode 6T", ROWS[:1]).replace("main", "frame 10ms\nmain", 1)
    _, diags = front_end_text(text)
    (err,) = [d for d in diags if d.is_error]
    assert err.code == "period-too-long" and "9.83" in err.message


@pytest.mark.parametrize("line", ["target stc89c58rd clock 40MHz mode 6T", "target at89c52"])
def test_the_longest_period_compile_accepts_verifies(line):
    """The limit itself: a frame of exactly max_period_us builds and runs exact in ucsim; 1 µs more is refused."""
    t = front_end_text(program(line, ROWS[:1]))[0].plan.program.target
    most = t.max_period_us()
    assert t.cycles(most) <= target.TIMER_CYCLES < t.cycles(most + 1)
    text = program(line, [ROWS[0][:8], ROWS[1][:8]]).replace("main", f"frame {most}us\nmain", 1)
    built = build_text(text)
    assert built.plan.period_us == most
    assert_exact(built.verify(8), line)
    _, diags = front_end_text(text.replace(f"frame {most}us", f"frame {most + 1}us"))
    assert "period-too-long" in [d.code for d in diags if d.is_error]


def test_ports_follow_each_other_as_the_budget_counts():
    """Measured in ucsim at 11.0592 MHz: P1 rises C(250) + SPLIT cycles after P0 (2304 + 93), or
    C(250) + RISE_STEP (2304 + 21) in firmware whose rises can be steps (the ports pulsed one after
    another: test_stagger.py has them overlapping)."""
    built = build_engine(program("target stc89c52rc clock 11.0592MHz", [r[:16] for r in ROWS]), stepping=True)
    steps = built.firmware.unit.budget.steps
    span = costs.port_span(built.plan.program.target, 250, steps)
    assert span == 2304 + (costs.RISE_STEP if steps else costs.SPLIT)
    widths = measured_widths(built, 4)
    p0 = [rise for rise, _ in widths[0]]
    p1 = [rise for rise, _ in widths[8]]
    assert {b - a for a, b in zip(p0, p1)} == {span}
    assert built.firmware.unit.rise_offsets == (0, span)


@settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.lists(st.lists(st.integers(0, 250), min_size=9, max_size=9), min_size=2, max_size=3),
       st.sampled_from([("stc89c52rc", "11.0592MHz", ""), ("at89c52", "10.5MHz", ""), ("at89s52", "22.1184MHz", "")]))
def test_random_positions_verify_exactly(rows, clock):
    chip, hz, mode = clock
    line = f"target {chip} clock {hz}" + (f" mode {mode}" if mode else "")
    assert_exact(build_text(program(line, rows)).verify(30), line)
