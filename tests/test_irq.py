"""The edge interrupt against its latency: a test build holds interrupts off at several points of
the background (CLR EA, k NOPs, SETB EA: in frame_io's wait, in run_list, do_hold and every servo's
step), so Timer0's overflow often comes while they are off, and each edge must still land on its
exact cycle. On an 8051 the entry latency is 3 to 9 cycles (an instruction under way, up to a
4-cycle MUL, plus one more after a RETI or a write to IE; in ucsim 1 or 2); the handler's pad
absorbs a latency of up to costs.LATENCY = 12 cycles, so interrupts held off for up to 10 cycles
(a latency of about 12 when the overflow comes as they go off) still leave every edge in place.
Held off for 12 or more, the pad runs out: the check can fail. The same holds where each port's
rise comes among the falls of the port before it (22.1184 MHz): that rise lands from an entry with
the fall's 3 cycles to its edge, after the same pad.
"""

import pytest

from conftest import front_end_text
from servoc import api, codegen
from servoc.diagnostics import Reporter

pytestmark = pytest.mark.toolchain

PROGRAM = """\
frame {P}us
{servos}
pose a {{ {a} }}
pose b {{ {b} }}
pose c {{ {c} }}
sequence swing {{ move b in {P2}us; move a in {P3}us ease in-out }}
main {{
  move a
  loop {{ play swing; move c in {P1}us; hold {P2}us; repeat 2 {{ move b in {P1}us; move a in {P2}us }} }}
}}
"""

PINS = [(1, b) for b in range(8)] + [(2, 0), (2, 3), (2, 4)]


FAST = "target at89c52 clock 22.1184MHz\n"      # two ports: P2's rise among P1's falls


def source(period: int, clock: str = "") -> str:
    servos = "\n".join(f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg" for p, b in PINS)
    pose = lambda f: ", ".join(f"s{p}{b}: {f(i)}" for i, (p, b) in enumerate(PINS))   # noqa: E731
    return clock + PROGRAM.format(P=period, P1=period, P2=2 * period, P3=3 * period, servos=servos,
                          a=pose(lambda i: 7 * i), b=pose(lambda i: 250 - 3 * i), c=pose(lambda i: (40 * i) % 251))


def build(hold: int, clock: str = "", stagger: bool | None = None):
    """The test build at the shortest period its own code holds (`stagger`: that build)."""
    period = 20000
    for _ in range(6):
        fe, diags = front_end_text(source(period, clock))
        assert fe.plan is not None, diags
        unit = codegen.generate(fe.plan, fe.source, hold_off=hold, stagger=stagger)
        if unit.min_period_us == period:
            break
        period = unit.min_period_us
    fe, _ = front_end_text(source(period, clock))
    unit = codegen.generate(fe.plan, fe.source, hold_off=hold, stagger=stagger)
    assert unit.min_period_us <= period
    firmware = api.assemble(unit, Reporter(fe.source))
    assert firmware is not None
    return api.with_rises(fe.plan, unit), firmware


@pytest.mark.parametrize("hold", [0, 1, 2, 4, 7, 9, 10])
def test_every_edge_stays_on_its_cycle_with_interrupts_held_off(hold):
    plan, firmware = build(hold)
    assert firmware.unit.text.count("CLR     EA") == (5 if hold else 0)   # frame_io's waits, run_list, do_hold, step_pin
    report = api.verify(plan, firmware, 300)
    assert report.ok and report.max_error_cycles == 0, (hold, report.summary(), [str(m) for m in report.mismatches[:5]])


@pytest.mark.parametrize("hold", [12, 40])
def test_the_check_can_fail_when_the_pad_runs_out(hold):
    """Held off for 12 cycles or more, an overflow can wait longer than the pad covers: edges move,
    or the jump into the pad lands past it."""
    plan, firmware = build(hold)
    report = api.verify(plan, firmware, 300)
    assert not report.ok


@pytest.mark.parametrize("hold", [0, 4, 10])
def test_with_rises_among_falls_every_edge_stays_on_its_cycle(hold):
    plan, firmware = build(hold, FAST, stagger=True)
    assert firmware.unit.budget.stagger
    report = api.verify(plan, firmware, 300)
    assert report.ok and report.max_error_cycles == 0, (hold, report.summary(), [str(m) for m in report.mismatches[:5]])


def test_with_rises_among_falls_the_check_can_fail_when_the_pad_runs_out():
    plan, firmware = build(12, FAST, stagger=True)
    assert firmware.unit.budget.stagger
    assert not api.verify(plan, firmware, 300).ok
