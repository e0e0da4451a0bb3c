"""Each port's span (costs.fit_spans): a port rises the longest pulse its lines can have after the
port before it (the highest N any of its lines reaches, flow.port_tops), and an entry of the edge
handler; longer where the next port's sort needs it. Each program here runs in ucsim at exactly
the shortest period servoc reports for it, every pulse exact, and that period less 1 us is refused.
"""

import dataclasses

import pytest

from conftest import build_engine, build_text, front_end_text
from servoc import costs
from servoc.flow import port_tops
from test_costs import at_period, own_minimum

pytestmark = pytest.mark.toolchain

CLOCKS = ["", "target stc89c52rc clock 11.0592MHz\n", "target at89c52 clock 22.1184MHz\n",
          "target stc89c52rc clock 11.0592MHz mode 6T\n"]


def between_two_poses(servos: list[tuple[int, int, int, int]], eased: bool = False) -> str:
    """Fast servos s<port><bit> on P<port>.<bit>, for each (port, bit, N in pose a, N in pose b),
    moving every frame from one pose to the other ({1P}: the period), the first move eased or not."""
    lines = [f"servo s{port}{bit} = P{port}.{bit} speed 0.0001s/60deg" for port, bit, _, _ in servos]
    a = ", ".join(f"s{port}{bit}: {n}" for port, bit, n, _ in servos)
    b = ", ".join(f"s{port}{bit}: {n}" for port, bit, _, n in servos)
    ease = " ease in-out" if eased else ""
    return ("\n".join(lines) + f"\npose a {{ {a} }}\npose b {{ {b} }}\n"
            + f"main {{ loop {{ move b in {{1P}}us{ease}; move a in {{1P}}us }} }}\n")


def ports_of(tops: dict[int, int], per_port: int = 8) -> str:
    """Servos on each port, moving every frame between N 0 and their port's top, in steps so that
    lines fall apart: the port's highest N is its top, reached in some frames."""
    return between_two_poses([(port, bit, top * bit // max(1, per_port - 1), top - top * bit // max(1, per_port - 1))
                              for port, top in tops.items() for bit in range(per_port)])


def check_at_minimum(template: str, start: int) -> tuple:
    period = own_minimum(template, start)
    built = build_text(at_period(template, period))
    assert built.plan.period_us == built.plan.min_period_us == period
    report = built.verify(100)
    assert report.ok and report.max_error_cycles == 0, (period, report.summary(), [str(m) for m in report.mismatches[:5]])
    _, diags = front_end_text(at_period(template, period - 1))
    assert "period-too-short" in [d.code for d in diags if d.is_error]
    return built, period


def engine_minimum(template: str, start: int, stepping: bool = False, stagger: bool = False,
                   merged: bool = False) -> int:
    """`own_minimum` for one edge handler (codegen.generate's `stepping`, `stagger`, `merged`)."""
    from servoc import codegen

    period = start
    for _ in range(6):
        fe, diags = front_end_text(at_period(template, period))
        assert fe.plan is not None, diags
        least = codegen.generate(fe.plan, stepping=stepping, stagger=stagger, merged=merged or None).min_period_us
        if least == period:
            break
        period = least
    return period


def check_engine_at_minimum(template: str, start: int, stepping: bool = False, stagger: bool = False,
                            merged: bool = False) -> tuple:
    """`check_at_minimum` for one edge handler (conftest.build_engine), not the one whose period is
    shortest: at that handler's own shortest period every pulse exact, and 1 us less refused by its
    budget."""
    from servoc import codegen

    period = engine_minimum(template, start, stepping, stagger, merged)
    built = build_engine(at_period(template, period), stepping, stagger, merged)
    assert built.plan.period_us == period
    report = built.verify(100)
    assert report.ok and report.max_error_cycles == 0, (period, report.summary(), [str(m) for m in report.mismatches[:5]])
    fe, _ = front_end_text(at_period(template, period - 1))
    assert not codegen.generate(fe.plan, stepping=stepping, stagger=stagger, merged=merged or None).period_holds
    return built, period


@pytest.mark.parametrize("clock", CLOCKS)
def test_three_ports_of_different_reach_verify_at_their_minimum(clock):
    template = clock + ports_of({0: 120, 1: 250, 2: 180})
    built, period = check_at_minimum(template, 9000 if clock else 20000)
    target, unit = built.plan.program.target, built.firmware.unit
    assert port_tops(built.plan) == (120, 250, 180)
    b = unit.budget
    assert b.stagger == costs.stagger_ok(target)     # 22.1184 MHz and 6T: each rise among the falls before it
    for k, top in enumerate((120, 250, 180)):       # its longest pulse, or what the next port's sort needs
        sort_need = b.sorts[k + 1] + b.rises[k] + b.falls[k] if k + 1 < (2 if b.last_in_b else 3) else 0
        if b.stagger:       # the rise a step from every fall, the next port's items written before its falls
            c0 = target.width_cycles(0)
            least = (target.width_cycles(top) + costs.STEP if k == 2
                     else costs.rise_slot(target, top, max(target.width_cycles(top) - c0 + b.emits[k + 1], c0)))
            assert b.spans[k] >= least and (b.spans[k] == least or k + 1 < (2 if b.last_in_b else 3))
        else:
            assert b.spans[k] == max(costs.port_span(target, top, b.steps), sort_need)
    assert unit.rise_offsets == (0, unit.budget.spans[0], sum(unit.budget.spans[:2]))
    full = costs.frame_cycles(target, dataclasses.replace(b, spans=()))    # every port's span for N 250
    assert costs.frame_cycles(target, b) <= full and (clock or costs.frame_cycles(target, b) < full)


def test_a_span_is_longer_where_the_next_ports_sort_needs_it():
    # P0's lines stay within N 0..10 (a 691-cycle span at 12 MHz), but the sort of P1's eight lines
    # and P0's own edges need more time between the two rises: P0's span grows to hold them
    template = ports_of({0: 10, 1: 250})
    built, period = check_at_minimum(template, 20000)
    target, budget = built.plan.program.target, built.firmware.unit.budget
    assert budget.spans[0] > costs.port_span(target, 10, budget.steps)
    load = budget.rises[0] + budget.falls[0]
    assert budget.spans[0] == budget.sorts[1] + load and budget.spans[1] == costs.port_span(target, 250, budget.steps)


def test_host_lines_reach_what_the_limits_allow():
    # `host` can put each line anywhere its limit allows: P1's span holds 120deg (N 162), P2's the
    # whole range
    text = ("serial 4800\nhost ssc32\ninput stop = P3.2\nservo a = P1.0 limit 30deg..120deg\n"
            "servo b = P2.0\npose mid { a: 90deg, b: 90deg }\nhome mid\nmain { host until press stop }\n")
    fe, diags = front_end_text(text)
    assert fe.plan is not None and not [d for d in diags if d.is_error], diags
    assert port_tops(fe.plan) == (162, 250)


def test_plan_says_where_each_port_rises(tmp_path, capsys):
    import json
    from servoc import cli
    prog = tmp_path / "two.servo"
    prog.write_text(ports_of({1: 100, 2: 250}).replace("{1P}", "20000"))
    assert cli.main(["plan", str(prog)]) == 0
    out = capsys.readouterr().out
    # P1's lines reach N 100: its span is C(100) + RISE_STEP = 1300 + 13 cycles (12 MHz: us), if its sort fits
    fe, _ = front_end_text(prog.read_text())
    span = fe.plan.rise_offsets[1]
    assert span >= costs.port_span(fe.plan.program.target, 100, True) == 1300 + costs.RISE_STEP
    steps = fe.plan.rise_steps
    assert (f"ports: P1 rises at 0 ms (its lines reach N 100), P2 rises at {span / 1000:g} ms (its lines reach N 250)"
            + (f"; a rise less than {costs.SPLIT} cycles after the last fall before it is a step" if steps else "\n")) in out
    assert cli.main(["plan", "--json", str(prog)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["ports"] == [{"port": 1, "rise_us": 0.0, "top": 100}, {"port": 2, "rise_us": float(span), "top": 250}]
    assert data["rise_steps"] == steps


def serial_ports(per_port: int, sends: bool) -> str:
    pins = [(p, b) for p in (1, 2, 0) for b in range(per_port)]
    text = "target stc89c52rc clock 11.0592MHz\nserial 9600\n" + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p, b in pins)
    text += "pose a { " + ", ".join(f"s{p}{b}: {20 * b}" for p, b in pins) + " }\n"
    text += "pose z { " + ", ".join(f"s{p}{b}: {250 - 20 * b}" for p, b in pins) + " }\n"
    return text + 'main { loop { select { on "a" { move a' + ('; send "A"' if sends else "") + ' } on "z" { move z } } } }\n'


@pytest.mark.parametrize("per_port,sends", [(8, False), (8, True)])
def test_spans_leave_the_serial_handler_room_for_every_byte(per_port, sends):
    # 9600 baud at 11.0592 MHz: a byte every 934 cycles from a host 2 % fast. A port's lines can keep
    # the serial handler waiting 8 x 111 cycles, and the next port's rise 413 more: each span leaves
    # a gap after its longest pulse in which the handler takes a byte, so the two never come together.
    # 24 servos, whether they only receive or also answer, take every byte sent back to back.
    from test_verify_observes import problems, watch
    template = serial_ports(per_port, sends)
    fe, diags = front_end_text(template)
    assert fe.plan is not None and not [d for d in diags if d.is_error], [d.message for d in diags if d.is_error]
    budget = build_text(template).firmware.unit.budget
    gap = costs.serial_gap(budget)
    assert all(costs.span_slack(fe.plan.program.target, budget, k) + 1 >= gap for k in range(3))
    assert costs.serial_latency(fe.plan.program.target, budget) <= costs.rx_gap(budget.byte_cycles)
    period = fe.plan.min_period_us
    built = build_text(f"frame {period}us\n" + template)
    trace, report = watch(built, "0.1s " + " ".join(['"a"', '"z"'] * 300) + "\n", int(0.8e6 / period))
    assert report.ok and report.max_error_cycles == 0, problems(report)
    assert len(trace.observation.received) == 600          # every byte taken from the UART in time
    _, below = front_end_text(f"frame {period - 1}us\n" + template)
    assert "period-too-short" in [d.code for d in below if d.is_error]
    # twice the rate: refused (8 x 111 cycles of falls alone are more than a byte time)
    _, faster = front_end_text(template.replace("serial 9600", "serial 19200"))
    assert "serial-too-fast" in [d.code for d in faster if d.is_error]


@pytest.mark.parametrize("clock", CLOCKS)
def test_a_rise_less_than_split_after_the_last_fall_is_a_step_at_every_gap(clock):
    """The next port's rise comes RISE_STEP cycles after its port's longest pulse; where the port's
    last fall is less than SPLIT before it, the rise is a step of that fall's entry (emit_s), else an
    entry of its own. Each port's highest line walks down from its top one N a frame, through every
    gap from RISE_STEP to past SPLIT, and back: every pulse exact at the reported minimum (and 1 us
    less refused), at each clock."""
    t = front_end_text(clock + "servo x = P1.0\npose a { x: 10 }\nmain { move a }\n")[0].plan.program.target
    far = next(n for n in range(251) if t.width_cycles(250) - t.width_cycles(250 - n) + costs.RISE_STEP >= costs.SPLIT)
    lines, walk = [], []
    for port in (0, 1, 2):
        for bit in range(3):
            lines.append(f"servo s{port}{bit} = P{port}.{bit} speed 0.0001s/60deg")
    poses = []
    for k in range(far + 3):
        poses.append(f"pose w{k} {{ " + ", ".join(f"s{p}{b}: {250 - k if b == 2 else 40 * b + 7 * p}"
                                                for p in range(3) for b in range(3)) + " }")
        walk.append(f"move w{k} in {{1P}}us")
    template = clock + "\n".join(lines + poses) + "\nmain { loop { " + "; ".join(walk + walk[::-1]) + " } }\n"
    if costs.stagger_ok(t):     # 22.1184 MHz, 6T: the rises come among the falls before them instead
        check_engine_at_minimum(template, 9000 if clock else 12000, stagger=True)
        return
    built, period = check_engine_at_minimum(template, 9000 if clock else 12000, stepping=True)
    assert built.firmware.unit.budget.steps
    assert built.firmware.unit.budget.spans[0] == costs.port_span(t, 250, True)     # the shortest span
    assert far > 1 and "emit_s0" in built.firmware.unit.text
