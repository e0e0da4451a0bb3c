"""Each port's rise among the falls of the port before it (costs.stagger_span): a port rises before
the port before it has finished its pulses, at a time at least STEP cycles from every fall that port
can have, or, at clocks whose DIV is less than 2 STEP cycles, BESIDE cycles after the fall of an N j
in one block with it and the fall of j + 1 (costs.beside); the program writes its items after its
sort, and the handler takes them after the port before's last edge. The ports' pulses overlap. Each
program here runs in ucsim at exactly the shortest period servoc reports for it, every pulse exact,
and that period less 1 us is refused.
"""

import dataclasses
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

from conftest import build_engine, build_text, front_end_text, parse_listing
from servoc import codegen, costs
from servoc.flow import port_reach
from test_costs import at_period, own_minimum
from test_serial import answering
from test_spans import between_two_poses, check_at_minimum, check_engine_at_minimum, engine_minimum

pytestmark = pytest.mark.toolchain

FAST = ["target at89c52 clock 22.1184MHz\n", "target stc89c52rc clock 11.0592MHz mode 6T\n"]
SLOW = ["", "target stc89c52rc clock 11.0592MHz\n", "target at89c52 clock 18.432MHz\n"]


def target_of(clock: str):
    return front_end_text(clock + "servo x = P1.0\npose a { x: 10 }\nmain { move a }\n")[0].plan.program.target


@pytest.mark.parametrize("clock", FAST + ["target at89c52 clock 24MHz\n", "target stc89c52rc clock 12MHz mode 6T\n"])
def test_a_rise_among_the_falls_is_at_least_a_step_from_every_fall(clock):
    """rise_slot: the first time from a given one on that is STEP or more from the fall of every N
    up to the port's top; below it, every time is nearer than STEP to some fall."""
    t = target_of(clock)
    assert costs.stagger_ok(t)
    widths = [t.width_cycles(n) for n in range(251)]
    for top in (0, 37, 120, 249, 250):
        for start in range(widths[0] - 20, widths[top] + 20, 5):
            d = costs.rise_slot(t, top, start)
            assert d >= start and all(abs(c - d) >= costs.STEP for c in widths[:top + 1])
            assert all(any(abs(c - x) < costs.STEP for c in widths[:top + 1]) for x in range(start, d))
        assert costs.rise_slot(t, top, widths[top]) == widths[top] + costs.STEP


@pytest.mark.parametrize("clock", SLOW)
def test_where_a_div_is_less_than_two_steps_a_rise_comes_beside_a_fall(clock):
    """At 12 MHz (8 cycles a DIV), 11.0592 MHz (7.37) and 18.432 MHz (12.29) no time between two
    falls one DIV apart is STEP from both, so rise_slot also takes BESIDE cycles after the fall of
    an N j from 1 up whose gaps to the N before and after it are the pair most N have
    (costs.beside, beside_gaps: the blocks' code is then the same for every j): the earlier of that
    and the first time STEP from every fall. Below it no time is either. A rise beside the fall of
    j is at least 3 cycles before the fall of j + 1 (the block's MOV A,@R0; INC R0; XRL after the
    rise), and 7 or more from every other."""
    t = target_of(clock)
    assert not costs.stagger_ok(t) and costs.beside(t)
    widths = [t.width_cycles(n) for n in range(251)]
    gaps = costs.beside_gaps(t)
    beside = {c + costs.BESIDE: j for j, c in enumerate(widths)
              if 1 <= j < 250 and (c - widths[j - 1], widths[j + 1] - c) == gaps}
    assert len(beside) > 60         # one N in four or more

    def clear(d: int, top: int) -> bool:
        return all(abs(c - d) >= costs.STEP for c in widths[:top + 1])
    for top in (0, 37, 120, 249, 250):
        for start in range(widths[0] - 20, widths[top] + 20, 7):
            d = costs.rise_slot(t, top, start)
            assert d >= start and (clear(d, top) or d in beside)
            assert not any(clear(x, top) or x in beside for x in range(start, d))
            if d in beside and not clear(d, top):
                j = beside[d]
                assert all(abs(c - d) >= costs.STEP for n, c in enumerate(widths) if n not in (j, j + 1))
                assert j == 250 or widths[j + 1] - d >= 3
    assert costs.rise_slot(t, 250, widths[0]) == min(beside)


def ports(*per_port: int, tops: tuple[int, ...] = (), crossing: bool = False) -> str:
    """Servos on P0, P1, ... (`per_port` each), moving every frame between two poses: each port's
    lines spread over 0..top (`tops`, default 250) one way and back, or (`crossing`) each line
    crossing the N of the others every frame."""
    servos = []
    for port, count in enumerate(per_port):
        top = tops[port] if tops else 250
        for bit in range(count):
            lo = top * bit // max(1, count - 1)
            servos.append((port, bit, lo, top - lo if crossing else (lo + 37 * port + 11) % (top + 1)))
    return between_two_poses(servos)


def ranged(per_port: int, lo: int, hi: int, ports_: int = 3) -> str:
    """Servos on P0, P1, ... (`per_port` each) whose lines stay within N lo..hi, moving every frame
    between two poses (an eased move and a linear one)."""
    return between_two_poses([(port, bit, lo + (13 * bit + 5 * port) * bit % (hi - lo + 1),
                               hi - (11 * bit + 7 * port) * bit % (hi - lo + 1))
                              for port in range(ports_) for bit in range(per_port)], eased=True)


def held(values: list[list[int]]) -> str:
    """Servos holding one pose, `values[port][bit]` each."""
    lines, a = [], []
    for port, ns in enumerate(values):
        for bit, n in enumerate(ns):
            lines.append(f"servo s{port}{bit} = P{port}.{bit}")
            a.append(f"s{port}{bit}: {n}")
    return "\n".join(lines) + f"\npose a {{ {', '.join(a)} }}\nmain {{ move a; hold {{1P}}us; loop {{ hold {{1P}}us }} }}\n"


CASES = {
    "all 24 lines at N 250": held([[250] * 8] * 3),
    "all 24 lines at N 0": held([[0] * 8] * 3),
    "24 lines one DIV apart across three ports": held([[226 + 8 * p + b for b in range(8)] for p in range(3)]),
    "N 0 and N 250 on every port": held([[0, 250, 36, 72, 108, 144, 180, 216]] * 3),
    "one servo on a port, eight on the next": ports(1, 8),
    "eight on a port, one on the next": ports(8, 1, 8),
    "lines crossing each other's N every frame": ports(8, 8, 8, crossing=True),
    "ports of different reach": ports(8, 8, 8, tops=(120, 250, 40)),
    "lines within 1 to 2 ms (N 62 to 187)": ranged(3, 62, 187),
}


@pytest.mark.parametrize("clock", FAST)
@pytest.mark.parametrize("case", sorted(CASES))
def test_rises_among_falls_verify_at_the_minimum(clock, case):
    """The build with rises among falls (where the ports at once, test_merged.py, are shorter: that
    build itself) at its own shortest period."""
    built, period = check_engine_at_minimum(clock + CASES[case], 12000, stagger=True)
    unit = built.firmware.unit
    b, t = unit.budget, built.plan.program.target
    if case == "all 24 lines at N 0":      # no pulse reaches the next rise: bound by the work, where the items
        # of one N each are written in fewer cycles than the ports one after another take at their rises
        assert period <= codegen.generate(built.plan, stagger=False).min_period_us
        return
    assert b.stagger and built.plan.rises_among_falls
    m = len(b.spans)
    assert b.bottoms == port_reach(built.plan)[0]
    for k in range(m - 1):      # each rise among the falls before it where they reach past it
        assert all(abs(t.width_cycles(n) - b.spans[k]) >= costs.STEP for n in range(b.bottoms[k], b.tops[k] + 1))
        assert b.spans[k] >= t.width_cycles(b.tops[k]) - t.width_cycles(b.bottoms[k + 1]) + b.emits[k + 1]
    assert b.spans[-1] >= t.width_cycles(b.tops[-1]) + costs.STEP
    assert any(b.spans[k] < t.width_cycles(b.tops[k]) for k in range(m - 1))


@pytest.mark.parametrize("clock", FAST)
def test_every_period_from_the_minimum_on_holds_not_only_the_minimum(clock):
    """The last port's next rise (the first port's, a frame later) comes P - rise(last) after its
    own: at most periods 256 cycles or more after its last fall. Where that fall's N is near the
    top, the items must still take the rise for a cluster of its own, not for a step whose gap is
    found from the low bytes of the two times (right only below 256 cycles). Periods from the
    minimum on, 11 us apart (a step is a window of 93 cycles, 50 us) over more than 256 cycles:
    every pulse exact."""
    template = clock + CASES["N 0 and N 250 on every port"]
    least = engine_minimum(template, 12000, stagger=True)
    turn = int(256 * target_of(clock).cycle_us) + 1         # 256 machine cycles, in us
    for period in range(least, least + turn + 15, 11):
        built = build_engine(at_period(template, period), stagger=True)
        assert built.firmware.unit.budget.stagger
        report = built.verify(12)
        assert report.ok and report.max_error_cycles == 0, (period, report.summary())


@pytest.mark.parametrize("clock", FAST)
def test_a_port_whose_lines_never_fall_early_lets_the_port_before_it_end_sooner(clock):
    """The rising port's earliest fall is C(bottom), the lowest N its lines fall at (flow.port_reach),
    not C(0); and the rise need only be STEP from the falls the port before can have (N bottom to
    top). Lines within 1 to 2 ms: each span among falls is C(187) - C(62) and the handover, not
    C(187) - C(0), and the frame is shorter than with every bottom taken as N 0."""
    built = build_engine(clock + ranged(2, 62, 187).replace("{1P}", "20000"), stagger=True)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert b.stagger and b.bottoms == (62, 62, 62) and b.tops == (187, 187, 187)
    as_if_zero = costs.fit_spans(t, dataclasses.replace(b, bottoms=()), b.tops)
    for k in range(2):      # at least the shortest such span (longer where the next port's sort needs it)
        least = costs.stagger_span(t, 187, b.emits[k + 1], False, 62, 62)
        assert least < costs.stagger_span(t, 187, b.emits[k + 1], False) and b.spans[k] >= least
    assert sum(b.spans) < sum(as_if_zero)
    assert costs.frame_cycles(t, b) < costs.frame_cycles(t, dataclasses.replace(b, spans=as_if_zero, bottoms=()))
    assert codegen.generate(built.plan, stagger=True).min_period_us == t.us_at_least(costs.frame_cycles(t, b))


@pytest.mark.parametrize("clock", FAST)
def test_each_port_is_sorted_before_the_wait_and_its_items_written_after_it(clock):
    """With rises among falls the handler never reads the sort buffer: frame_io sorts a port as
    soon as the port before's items are written, and only its items (and its rise's mask) wait
    until the handler took the port before's. So the last port's sort is no longer between its
    wait and the work between frames (`costs._items_start`): the frame of 24 servos within N
    20..120, where the CPU's work bounds it, is shorter than with the whole sort after the wait,
    and the firmware holds it, every pulse exact (1 us less refused)."""
    built, period = check_at_minimum(clock + ranged(8, 20, 120), 12000)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert b.stagger and len(b.items) == 3 and all(0 < i < s for i, s in zip(b.items, b.sorts))
    instrs, labels = parse_listing(built.firmware.image.listing)
    for p in built.firmware.unit.ports:       # load, sort, distinct; the wait; RISEM, the items
        sorted_ = [ins.args[0] for ins in instrs[labels[f"fs{p}"]:labels[f"fi{p}"]] if ins.op == "LCALL"]
        assert sorted_ == ["sort8", "distinct8"], sorted_
        after = instrs[labels[f"ft{p}"]:labels[f"ft{p}"] + 3]
        assert ("MOV", "RISEM") in [(ins.op, ins.args[0]) for ins in after]
    after = dataclasses.replace(b, items=(), heads=())      # each sort whole after its wait, spans fitted to it
    whole = costs._frame_cycles(t, dataclasses.replace(after, spans=costs.fit_spans(t, after, b.tops)), 0)
    assert costs.frame_cycles(t, b) < whole


def test_the_rise_sled_puts_the_rise_exactly_its_gap_after_the_fall_before_it():
    """In each window: after a fall (its step's read and jump), the rise sled at offset rland + 7 - g
    for every gap g from STEP to SPLIT - 1, then the next port's rise; after the rise, the same read
    and jump into the fall sled. An entry that starts with the rise lands on it with the fall's
    3 cycles to the edge."""
    built = build_text(FAST[0] + ports(3, 3, 3).replace("{1P}", "20000"))
    unit = built.firmware.unit
    assert unit.budget.stagger
    instrs, labels = parse_listing(built.firmware.image.listing)
    by_addr = {ins.address: k for k, ins in enumerate(instrs)}
    ports_ = unit.ports
    rland = 2 * costs.SLED + 16
    for j, port in enumerate(ports_):
        nxt = ports_[(j + 1) % len(ports_)]
        base = instrs[labels[f"win_p{port}"]].address
        at = lambda off: instrs[by_addr[base + off]]                  # noqa: E731
        fall = [at(costs.SLED), at(costs.SLED + 1), at(costs.SLED + 2)]
        assert [(t.op, t.args) for t in fall] == [("MOV", ("A", "@R0")), ("INC", ("R0",)), ("XRL", (f"P{port}", "A"))]
        step = instrs[by_addr[fall[2].address] + 1:by_addr[fall[2].address] + 4]
        assert [t.op for t in step] == ["MOV", "INC", "JMP"]
        assert at(costs.SLED + 7).args == ("exit_far",) and at(costs.SLED + 10).args == (f"exit_rf{port}",)
        assert at(costs.SLED + 13).args == (f"emit_s{nxt}",)
        k = by_addr[base + costs.SLED + 16]
        assert all(ins.op == "NOP" for ins in instrs[k:k + costs.SLED])
        rise = instrs[k + costs.SLED:k + costs.SLED + 3]
        assert rise[0].address == base + rland and rise[2].op == "XRL" and rise[2].args == (f"P{nxt}", "A")
        assert sum(t.cycles for t in rise) == sum(t.cycles for t in fall)        # the same 3 cycles from an entry
        after = instrs[k + costs.SLED + 3:k + costs.SLED + 6]
        assert [(t.op, t.args) for t in after] == [(t.op, t.args) for t in step]
        for gap in range(costs.STEP, costs.SPLIT):
            off = (rland + 7 - gap)
            assert costs.SLED + 16 <= off <= rland
            assert sum(t.cycles for t in step) + (rland - off) + sum(t.cycles for t in rise) == gap
            assert (~gap + 2 * costs.SLED + 24) & 0xFF == off       # the offset the emit writes
    assert built.verify(40).ok


def test_plan_says_the_ports_pulses_overlap(tmp_path, capsys):
    from servoc import cli
    import json
    for clock, tops, among, once in ((FAST[0], (), False, True), ("serial 9600\n" + FAST[0], (), False, True),
                                     ("", (), True, False), ("", (40, 40), False, False)):
        path = tmp_path / "p.servo"        # (lines below N 40: the work bounds the period, not the pulses)
        path.write_text(clock + ports(4, 4, tops=tops).replace("{1P}", "20000"))
        assert cli.main(["plan", str(path)]) == 0
        out = capsys.readouterr().out
        assert ("the ports' pulses overlap" in out) == (among or once)
        assert ("every port rises at once" in out) == once
        assert cli.main(["plan", "--json", str(path)]) == 0
        data = json.loads(capsys.readouterr().out)
        assert (data["rises_among_falls"], data["ports_at_once"]) == (among, once)


def test_a_build_for_size_keeps_the_ports_one_after_another():
    """A build for size has no room for a second sled in each window: no rises among falls (and
    no ports at once: its unrolled merging)."""
    text = FAST[0] + ports(4, 4).replace("{1P}", "20000")
    built = build_text(text)
    assert built.firmware.unit.budget.merged
    assert codegen.generate(built.plan, merged=False).budget.stagger       # without the ports at once
    b = build_text(text, for_size=True).firmware.unit.budget
    assert not (b.stagger or b.merged)


def test_with_a_meanwhile_body_and_an_input_the_rises_come_among_falls_at_the_minimum():
    """The work between frames grows with a select's looks (frame_w): the spans and each sort in
    its turn still hold, every pulse exact at the reported minimum and 1 us less refused."""
    body = ports(4, 4, 4)
    decls, rest = body.split("main {", 1)
    template = (FAST[0] + "input button = P3.2\n" + decls + "main { loop { select { on press button { wait release "
                "button; move b in {2P}us } meanwhile { loop { move b in {1P}us; move a in {1P}us } } } } }\n")
    built, period = check_at_minimum(template, 12000)
    assert built.firmware.unit.budget.stagger and "frame_w" in built.firmware.unit.text


STC22 = "target stc89c52rc clock 22.1184MHz\n"


def test_on_a_chip_with_xram_the_motion_state_moves_there_to_leave_room_for_the_item_buffers():
    """24 servos, a select with an input, serial commands and a meanwhile body: in the STC89C52RC's
    256 bytes of internal RAM, the two item buffers of rises among falls do not fit beside the
    motion state and the stack. The motion state moves to its XRAM, as it does for the ports at
    once (there the merged items do not fit either), and the rises still come among falls: every
    pulse exact at the reported minimum, 1 us less refused. (With the motion state kept in internal
    RAM, the program's ports would pulse one after another, at a period 0.9 ms longer.)"""
    from servoc import layout
    body = ports(8, 8, 8)
    decls, rest = body.split("main {", 1)
    template = (STC22 + "serial 9600\ninput button = P3.2\n" + decls + "main { loop { select { on press button "
                "{ wait release button; move b in {3P}us } on \"x\" { send \"k\"; move a in {2P}us } meanwhile "
                "{ loop { move b in {1P}us; move a in {1P}us } } } } }\n")
    built, period = check_at_minimum(template, 12000)
    unit = built.firmware.unit
    assert unit.budget.stagger and "XSTATE" in unit.text and "frame_w" in unit.text
    assert not (unit.budget.merged or unit.budget.steps)
    with pytest.raises(layout.RamFull):
        codegen._generate(built.plan, None, 0, 1, False, True, codegen.at_start(built.plan), xstate=False)
    apart = codegen.generate(built.plan, stepping=True, stagger=False)
    assert "XSTATE" not in apart.text and apart.min_period_us > period + 800
    docs = " ".join((Path(__file__).resolve().parent.parent / "docs/language.md").read_text(encoding="utf-8").split())
    assert (f"serial line on the STC89C52RC at 22.1184 MHz: {period / 1000:.3f} ms, where the ports one after "
            f"another would take {apart.min_period_us / 1000:.3f}") in docs


def nested(depth: int) -> str:
    """24 servos at 22.1184 MHz, moving every frame inside `depth` nested repeats (each level 2
    bytes of stack)."""
    pins = [(p, b) for p in range(3) for b in range(8)]
    lines = [FAST[0].strip(), "frame 20ms"] + [f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg" for p, b in pins]
    lines += ["pose lo { " + ", ".join(f"s{p}{b}: {(7 * (8 * p + b)) % 40}" for p, b in pins) + " }",
              "pose hi { " + ", ".join(f"s{p}{b}: {250 - (11 * (8 * p + b)) % 40}" for p, b in pins) + " }"]
    body = "move hi in 20ms; move lo in 20ms"
    for _ in range(depth):
        body = f"repeat 1 {{ {body} }}"
    return "\n".join(lines) + f"\nmain {{ loop {{ {body} }} }}\n"


def test_where_the_ram_cannot_hold_two_item_buffers_the_ports_pulse_one_after_another():
    """Rises among falls take two item buffers (the handler's and the one the program writes): a
    program whose stack leaves no room for them is built without, and still compiles and verifies."""
    from servoc import layout
    results = []
    for depth in range(10):
        built = build_text(nested(depth))
        try:
            codegen.generate(built.plan, stagger=True)
            fits = True
        except layout.RamFull:
            fits = False
        results.append((depth, fits, built))
        if not fits:
            break
    depth, fits, built = results[-1]
    assert not fits and depth > 0 and results[-2][1]
    assert results[-2][2].firmware.unit.budget.stagger and not built.firmware.unit.budget.stagger
    assert built.verify(20).ok


@pytest.mark.parametrize("clock", ["target at89c52 clock 24MHz\n", "target stc89c52rc clock 12MHz mode 6T\n"])
def test_at_the_other_clocks_whose_div_leaves_room_rises_come_among_falls_too(clock):
    """24 MHz (16 cycles a DIV) and 12 MHz in 6T mode (16): N 0 and N 250 on every port, exact at
    the reported minimum, 1 us less refused."""
    check_engine_at_minimum(clock + CASES["N 0 and N 250 on every port"], 12000, stagger=True)


def test_the_handovers_cycles_quoted_in_the_docs_are_the_codes():
    """docs/language.md quotes the handover's run (Budget.emits) as read from the generated code."""
    from pathlib import Path
    built = build_engine(FAST[0] + ports(8, 8).replace("{1P}", "20000"), stagger=True)
    emits = set(built.firmware.unit.budget.emits)
    assert len(emits) == 1
    text = (Path(__file__).resolve().parent.parent / "docs" / "language.md").read_text(encoding="utf-8")
    assert f"the entry's {costs.ENTRY} cycles included: {emits.pop()})" in text


def beside_check(built) -> None:
    """Each port's rise but the last's is STEP or more from every fall its port can have, or BESIDE
    after the fall of some N j (costs.beside), at least 3 before the fall of j + 1."""
    b, t = built.firmware.unit.budget, built.plan.program.target
    for k in range(len(b.spans) - 1):
        near = [n for n in range(b.bottoms[k], b.tops[k] + 1) if abs(t.width_cycles(n) - b.spans[k]) < costs.STEP]
        if near:
            j = near[0] if t.width_cycles(near[0]) < b.spans[k] else near[0] - 1
            assert costs.beside(t) and b.spans[k] - t.width_cycles(j) == costs.BESIDE and set(near) <= {j, j + 1}
        assert b.spans[k] >= t.width_cycles(b.tops[k]) - t.width_cycles(b.bottoms[k + 1]) + b.emits[k + 1]


BESIDE_CASES = ["24 lines one DIV apart across three ports", "N 0 and N 250 on every port", "all 24 lines at N 250",
                "lines within 1 to 2 ms (N 62 to 187)"]


@pytest.mark.parametrize("clock,case", [("", c) for c in BESIDE_CASES] + [(SLOW[1], BESIDE_CASES[1]), (SLOW[2], BESIDE_CASES[0])])
def test_rises_beside_falls_verify_at_the_minimum(clock, case):
    """Where a DIV is less than 2 STEP cycles the rises come among the falls too (a rise beside a
    fall where no time is STEP from both): each program runs in ucsim at the shortest period
    servoc reports, every pulse exact, 1 us less refused, shorter than the ports pulsed one after
    another."""
    built, period = check_at_minimum(clock + CASES[case], 12000)
    assert built.firmware.unit.budget.stagger and built.plan.rises_among_falls
    beside_check(built)
    assert codegen.generate(built.plan, stepping=True).min_period_us > period


def test_the_held_pose_figures_quoted_in_the_docs_are_the_codes():
    """docs/language.md and the README quote the shortest period of 24 servos held at N 250 at
    12 MHz, rises among falls (verified at exactly that period by
    `test_rises_beside_falls_verify_at_the_minimum`), beside the ports one after another."""
    template = CASES["all 24 lines at N 250"]
    period = own_minimum(template, 12000)
    fe, _ = front_end_text(at_period(template, period))
    apart = codegen.generate(fe.plan, stepping=True, stagger=False).min_period_us
    assert fe.plan.rises_among_falls and apart > period
    root = Path(__file__).resolve().parent.parent
    for doc in ("docs/language.md", "README.md"):
        text = " ".join((root / doc).read_text(encoding="utf-8").split())
        assert f"{period / 1000:.3f} ms instead of {apart / 1000:.3f}" in text, doc


def block_program(clock: str, shape: tuple) -> tuple[str, int]:
    """Held lines on P0, P1 and P2 such that P0's rise among its falls comes beside the fall of an
    N j, with P0's lines at j + each offset in `shape`, its others at N 0 (or, where `shape` starts
    with 'first', none below) and 250: found by building until the rise stays where the lines put
    it (P1's lowest line, which P0's span depends on, tried at a few N where it does not settle)."""
    offsets = [o for o in shape if o != "first"]
    for low in (100, 97, 94, 103, 91):
        values = [[10, 20, 30, 0, 250, 40, 50, 60], [low, 250, 120, 130, 140, 150, 160, 170],
                  [100, 250, 180, 190, 200, 210, 220, 230]]
        for _ in range(6):
            template = clock + held(values)
            fe, diags = front_end_text(at_period(template, 12000))
            assert fe.plan is not None, diags
            t, span = fe.plan.program.target, codegen.generate(fe.plan).budget.spans[0]
            j = max(n for n in range(251) if t.width_cycles(n) < span)
            lines = [j + o for o in offsets]
            want = lines + ([250] * (8 - len(lines)) if "first" in shape else values[0][len(lines):])
            if want == values[0] and span - t.width_cycles(j) == costs.BESIDE:
                return template, j
            values[0] = want
    raise AssertionError(f"the rise did not settle beside the lines: {values[0]}")


@pytest.mark.parametrize("clock", SLOW[:2])
@pytest.mark.parametrize("shape", [(-1, 0, 5), (-4, 1, 2), (-3, 0, 1), ("first", 0, 3, 4), ("first", 0, 1, 9)],
                         ids=["FR after the fall at j-1", "RF after no line at j-1", "FRF after no line at j-1", "FR first",
                              "FRF first"])
def test_each_block_of_a_rise_beside_a_fall_puts_every_edge_exactly(clock, shape):
    """The blocks of a rise beside the fall of j: the fall of j and the rise (FR), and the fall of
    j + 1 (FRF), or the rise and the fall of j + 1 (RF); each after the fall at j - 1, or one with
    no line written there for it, or as the port's first edge after the header N j - 1 with no line.
    Every pulse exact at the minimum, 1 us less refused."""
    template, j = block_program(clock, shape)
    built, period = check_at_minimum(template, 12000)
    beside_check(built)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert b.spans[0] - t.width_cycles(j) == costs.BESIDE


@pytest.mark.parametrize("hold", [4, 10])
def test_a_rise_beside_a_fall_keeps_every_edge_with_interrupts_held_off(hold):
    """The blocks of a rise beside a fall run inside one entry of the edge handler, after its pad:
    with interrupts held off for up to 10 cycles at several points of the background (test_irq.py),
    every edge of a build whose rise comes beside the fall of j, with lines at j and j + 1, stays on
    its cycle at that build's own shortest period."""
    from servoc import api
    from servoc.diagnostics import Reporter
    template, j = block_program("", (-3, 0, 1))
    period = 12000
    for _ in range(6):
        fe, diags = front_end_text(at_period(template, period))
        unit = codegen.generate(fe.plan, fe.source, hold_off=hold, stagger=True)
        if unit.min_period_us == period:
            break
        period = unit.min_period_us
    t = fe.plan.program.target
    assert unit.text.count("CLR     EA") >= 4 and unit.budget.spans[0] - t.width_cycles(j) == costs.BESIDE
    firmware = api.assemble(unit, Reporter(fe.source))
    plan = api.with_rises(fe.plan, unit)
    report = api.verify(plan, firmware, 200)
    assert report.ok and report.max_error_cycles == 0, (hold, report.summary(), [str(m) for m in report.mismatches[:5]])


@pytest.mark.parametrize("clock", ["target stc89c52rc clock 11.0592MHz\nserial 9600\n", "serial 4800\n"])
def test_with_a_serial_line_the_rises_come_beside_falls_at_the_minimum(clock):
    """A serial line's handler runs between the edge handler's entries: each span among falls
    leaves it its time (costs._stagger_stretch, the line-less edge included). Lines within 1 to 2 ms
    with a serial line at 11.0592 MHz and at 12 MHz: the build with rises beside falls, every pulse
    exact at the minimum, 1 us less refused."""
    built, period = check_at_minimum(clock + CASES["lines within 1 to 2 ms (N 62 to 187)"], 12000)
    assert built.firmware.unit.budget.stagger and costs.beside(built.plan.program.target)
    beside_check(built)


def twelve_answering(clock: str, baud: int) -> str:
    """Twelve servos, four on each port at N 20, 70, 120, 170 (each fall an entry of its own, the
    edge handler's longest hold on the CPU), moved there and back by bytes that get an answer."""
    servos = [f"s{p}{b}" for p in range(3) for b in range(4)]
    text = clock + f"serial {baud}\n"
    text += "".join(f"servo {s} = P{s[1]}.{s[2]} speed 0.05s/60deg\n" for s in servos)
    text += "pose lo { " + ", ".join(f"{s}: {20 + 50 * int(s[2])}" for s in servos) + " }\n"
    text += "pose hi { " + ", ".join(f"{s}: {230 - 50 * int(s[2])}" for s in servos) + " }\n"
    return text + answering()


@pytest.mark.parametrize("clock, baud, faster", [("target stc89c52rc clock 11.0592MHz\n", 14400, 19200),
                                                 ("", 4800, None)])
def test_serial_bytes_at_the_highest_rate_the_overlap_takes_during_the_densest_edges(clock, baud, faster):
    """The issue's bad case for rises among falls: bytes at the highest rate with which the program
    still takes the build with rises beside falls (at 11.0592 MHz 14400 baud: at 19200 that build's
    handler would keep a byte waiting too long; at 12 MHz 4800, the fastest rate the chip makes),
    at the program's own shortest period, every line's fall an entry of its own: bursts of four
    bytes at eight phases of the frame, each an eighth of a frame later than the one before. Every
    byte is answered, in order, and every pulse is exact."""
    from test_serial import run, sent
    from servoc import layout
    from servoc.target import working_bauds

    template = twelve_answering(clock, baud)
    period = own_minimum(template, 12000)
    built = build_text(at_period(template, period))
    unit, plan = built.firmware.unit, built.plan
    assert unit.budget.stagger and plan.period_us == unit.min_period_us == period
    assert costs.serial_latency(unit.target, unit.budget) <= costs.rx_gap(unit.budget.byte_cycles)
    rates = working_bauds(plan.program.target)
    if faster is None:
        assert baud == max(rates)
    else:
        assert faster == min(r for r in rates if r > baud)
        fe, _ = front_end_text(at_period(twelve_answering(clock, faster), period))
        with pytest.raises(layout.SerialTooFast):
            codegen.generate(fe.plan, fe.source, stagger=True)
    bursts = [f'{60_000 + 700_000 * k + k * period // 8}us "h" "l" "h" "l"' for k in range(8)]
    plan, trace, evs, report = run(at_period(template, period), "\n".join(bursts) + "\n",
                                   int(5_800_000 / period))
    assert report.ok and report.pulses > 0, [str(m) for m in report.mismatches[:5]]
    assert sent(trace) == "HLHL" * 8


TWO_PORTS = """\
servo a0 = P0.0 speed 0.0001s/60deg
servo a3 = P0.3 speed 0.0001s/60deg
servo a4 = P0.4 speed 0.0001s/60deg
servo a5 = P0.5 speed 0.0001s/60deg
""" + "".join(f"servo c{b} = P2.{b} speed 0.0001s/60deg\n" for b in range(8)) + """\
pose p0 { a0: 115, a3: 115, a4: 115, a5: 115, """ + ", ".join(f"c{b}: 115" for b in range(8)) + """ }
pose p1 { a0: 96, a3: 96, a4: 96, a5: 96, """ + ", ".join(f"c{b}: 96" for b in range(8)) + """ }
main {
  move p0
  loop {
    move p1 in 134ms ease in-out
    hold 27ms
    move p0 in 87ms ease out
  }
}
"""


@pytest.mark.parametrize("clock", SLOW[:2])
def test_with_two_ports_the_reported_minimum_is_the_shortest_period_the_code_holds(clock):
    """With two ports and rises among falls, the last port's items wait for its handover in the
    frame before, which comes earlier as the period grows (costs._items_start): the need shrinks
    with the period. The shortest period reported is the first that holds (costs._least), not the
    need evaluated at P = 0, which is longer: every period from it on holds, none below it, every
    pulse is exact there and 1 us less is refused."""
    built, period = check_at_minimum(clock + TWO_PORTS, 6000)
    unit, t = built.firmware.unit, built.plan.program.target
    b = unit.budget
    assert b.stagger and len(b.lines) == 2
    least = t.cycles(period)
    assert costs._frame_cycles(t, b, 0) > least         # the need at P = 0 asks for more
    for p in range(least - 40, least + 40):
        assert costs.holds(t, b, p) == (p >= costs.frame_cycles(t, b)), p


SERIAL_TWO_PORTS = """\
target stc89c52rc clock 11.0592MHz
serial 9600
""" + "".join(f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg\n" for p, b in
              ((0, 0), (0, 1), (0, 2), (0, 3), (0, 6), (0, 7), (2, 0), (2, 1), (2, 2), (2, 3), (2, 4), (2, 5), (2, 6))) + """\
pose p0 { s00: 173, s01: 199, s02: 41, s03: 100, s06: 94, s07: 29, s20: 246, s21: 161, s22: 196, s23: 74, s24: 213, s25: 140, s26: 164 }
pose p1 { s00: 52, s01: 162, s02: 63, s03: 180, s06: 151, s07: 247, s20: 196, s21: 50, s22: 94, s23: 196, s24: 217, s25: 77, s26: 166 }
""" + answering(46, 40, hi="p1", lo="p0")


def test_with_a_serial_line_the_minimum_is_the_first_period_from_which_every_one_holds():
    """With a serial line the need is a step function of the period (the serial handler's runs
    in each window), and with two ports and rises among falls it also shrinks as the period grows:
    a search up from below steps past the first period that holds. The minimum is the first period
    from which every longer one holds (costs.frame_cycles goes down from the one it found while
    each holds), no period below it is accepted (codegen: `period_holds`), and there, with bytes
    in bursts at four phases of the frame, every pulse is exact and every byte answered."""
    from test_serial import run, sent

    period = own_minimum(SERIAL_TWO_PORTS, 12000)
    built = build_text(at_period(SERIAL_TWO_PORTS, period))
    unit, t = built.firmware.unit, built.plan.program.target
    b = unit.budget
    assert b.stagger and len(b.lines) == 2 and b.byte_cycles and unit.min_period_us == period
    least = costs.frame_cycles(t, b)
    assert costs._holding_from(t, b, costs._least(t, b)) > least          # the search up steps past it
    assert all(costs.holds(t, b, p) for p in range(least, least + 3000))
    for p in (period - 1, period - 3, period - 9, period - 40):
        fe, diags = front_end_text(at_period(SERIAL_TWO_PORTS, p))
        assert "period-too-short" in [d.code for d in diags if d.is_error], p
    bursts = [f'{60_000 + 300_000 * k + k * period // 4}us "h" "l"' for k in range(4)]
    plan, trace, evs, report = run(at_period(SERIAL_TWO_PORTS, period), "\n".join(bursts) + "\n",
                                   int(1_500_000 / period))
    assert report.ok and report.pulses > 0, [str(m) for m in report.mismatches[:5]]
    assert sent(trace) == "HL" * 4


@st.composite
def two_or_three_ports(draw) -> str:
    """A program on two or three ports at a clock with rises among falls (beside them or not), with
    or without a serial line and a select that answers bytes: random lines and poses."""
    clock = draw(st.sampled_from(SLOW + FAST))
    ports = draw(st.sampled_from([(0, 1), (0, 2), (1, 2), (0, 1, 2)]))
    pins = [(p, b) for p in ports for b in range(draw(st.integers(1, 6)))]
    n = st.integers(0, 250)
    poses = [[draw(n) for _ in pins] for _ in range(2)]
    baud = draw(st.sampled_from([None, 2400, 4800]))
    text = clock + (f"serial {baud}\n" if baud else "")
    text += "".join(f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg\n" for p, b in pins)
    for name, values in zip(("lo", "hi"), poses):
        text += f"pose {name} {{ " + ", ".join(f"s{p}{b}: {v}" for (p, b), v in zip(pins, values)) + " }\n"
    if baud:
        return text + answering(draw(st.integers(30, 90)), draw(st.integers(30, 90)))
    return text + f"main {{\n  move lo\n  loop {{\n    move hi in {draw(st.integers(30, 90))}ms\n    move lo in 50ms\n  }}\n}}\n"


@given(two_or_three_ports())
@example(TWO_PORTS)
@example(SERIAL_TWO_PORTS)
@settings(max_examples=15, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
def test_the_minimum_is_the_first_period_from_which_every_longer_one_holds(text):
    """For random programs on two or three ports, with and without a serial line: the period 1 cycle
    below the reported minimum does not hold in the budget of the build chosen, and every period
    from the minimum on does (checked every 7 cycles over 600); the two programs above among them,
    whose minimum was once found past a period that holds. (The other tests here check the pulses
    in ucsim at such minimums.)"""
    fe, diags = front_end_text(at_period(text, 20000))
    assert fe.plan is not None, diags
    unit = codegen.generate(fe.plan, fe.source)
    t, b = unit.target, unit.budget
    least = costs.frame_cycles(t, b)
    assert not costs.holds(t, b, least - 1)
    assert all(costs.holds(t, b, p) for p in range(least, least + 600, 7))


def read_while_written(template: str, period: int, marks, after_frame: int = 0) -> tuple[int, bool]:
    """`template` built at `period`, below its own minimum (refused as period-too-short, built all
    the same) and run in ucsim with probes at `marks(ports)`: where a port's items start being
    written, where that ends, and the read (a label, or a label and an offset from it). How often
    the read comes while the items are being written (after the first `after_frame` reads), and
    whether every pulse is exact."""
    from servoc import api, sim
    from servoc.diagnostics import Reporter
    from servoc.observe import listing_lines
    from servoc.source import SourceFile

    source = SourceFile("below.servo", at_period(template, period))
    reporter = Reporter(source)
    plan = api.front_end(source, reporter).plan
    assert [d.code for d in reporter.diagnostics if d.is_error] == ["period-too-short"]
    fw = api.assemble(api.codegen.generate(plan, source), reporter)
    assert fw.unit.budget.stagger
    labels = {line.split(":")[0].strip(): addr for addr, line, _ in listing_lines(fw.image.listing)
              if addr is not None and ":" in line.split(";")[0]}
    at = [labels[m] if isinstance(m, str) else labels[m[0]] + m[1] for m in marks(fw.unit.ports)]
    frames = sum(m.frames for m in plan.moves) + 10
    trace = sim.run(fw.hex_text, api.cycles_needed(plan, frames), probes=[(a, tag, ()) for tag, a in enumerate(at)],
                    xtal_hz=plan.program.target.clock_hz)
    reads = [p for p in trace.probes if p.tag == 2]
    assert len(reads) >= frames - 2
    late, writing, since = 0, False, reads[after_frame - 1].cycle if after_frame else -1
    for p in trace.probes:
        late += p.tag == 2 and writing and p.cycle > since
        writing = p.tag == 0 or (writing and p.tag == 2)
    return late, api.verify_hex(plan, fw.hex_text, frames).ok


def rotated_goal(clock: str = "") -> str:
    """24 servos moving between two poses over the full range (N 0 and 250 on every port), eased
    and linear, two speed classes, as the benchmark's goal program, but each port's N in another
    order: a port's items left from another port would move its edges (a template for
    `at_period`)."""
    low = (0, 250, 36, 72, 108, 144, 180, 216)
    n = lambda i: low[(i % 8 + 3 * (i // 8)) % 8]     # noqa: E731
    text = clock + "".join(f"servo s{i} = P{i // 8}.{i % 8}{' speed 0.3s/60deg' if i % 2 else ''}\n"
                                           for i in range(24))
    text += "pose a { " + ", ".join(f"s{i}: {n(i)}" for i in range(24)) + " }\n"
    text += "pose b { " + ", ".join(f"s{i}: {250 - n(i)}" for i in range(24)) + " }\n"
    return text + "main {\n  loop {\n    move a in 1000ms ease in-out\n    move b in 1000ms\n  }\n}\n"


@pytest.mark.toolchain
def test_the_first_ports_items_may_end_after_its_handover_for_it_reads_only_their_header():
    """With rises among falls the first port's handover reads only its items' header; the handler
    reads the rest from that port's first edge on. So the chain to those items ends twice: the
    header before the port's rise, the whole before its earliest edge, the rise's run between
    (`costs.first_read`): the goal program at 12 MHz is bound by them, less than where the whole
    must be written before the rise. Built below that (the budget bypassed), some frame's
    items are still being written when the handler takes them, and every pulse is exact in ucsim:
    each port's N in its own order, so items left from another port would move edges."""
    at_min = build_text(at_period(rotated_goal(), 20000))
    b, t = at_min.firmware.unit.budget, at_min.plan.program.target
    assert b.stagger and len(b.lines) == 3 and 0 < b.head < b.items[0] and costs.first_read(t, b) > b.rises[0]
    assert costs.frame_cycles(t, b) < costs.frame_cycles(t, dataclasses.replace(b, head=0))  # all by the rise
    late, ok = read_while_written(rotated_goal(), at_min.plan.min_period_us - 150,
                                  lambda ports: (f"ft{ports[0]}", f"fs{ports[1]}", f"emit_s{ports[0]}"))
    assert late > 0 and ok


@pytest.mark.toolchain
@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n"])
def test_where_the_first_ports_items_end_by_its_first_edge_every_pulse_is_exact_at_the_minimum(clock):
    """The goal program with each port's N in its own order, at 12 MHz and 11.0592 MHz: its
    shortest period is set by the chain to the first port's items ending ENTRY before that port's
    first edge (a later first edge would shorten it; it is shorter than all of them by the rise).
    At exactly that period, over both moves whole (each start among them), every pulse is exact
    in ucsim; 1 us less is refused."""
    from servoc import api

    period = own_minimum(rotated_goal(clock))
    built = build_text(at_period(rotated_goal(clock), period))
    plan, b, t = built.plan, built.firmware.unit.budget, built.plan.program.target
    assert b.stagger and plan.min_period_us == period and t.us_at_least(costs.frame_cycles(t, b)) == period
    later = dataclasses.replace(b, bottoms=(b.bottoms[0] + 30,) + b.bottoms[1:])
    assert costs.frame_cycles(t, later) < costs.frame_cycles(t, b) < costs.frame_cycles(t, dataclasses.replace(b, head=0))
    assert costs.frame_cycles(t, b) > sum(b.spans)        # not the pulses
    report = api.verify_hex(plan, built.firmware.hex_text, sum(m.frames for m in plan.moves) + 3)
    assert report.ok and report.max_error_cycles == 0, report.summary()
    _, diags = front_end_text(at_period(rotated_goal(clock), period - 1))
    assert "period-too-short" in [d.code for d in diags if d.is_error]


def later_port(clock: str = "", a: tuple[int, int] = (150, 185)) -> str:
    """One servo on P0 within N `a` (150..185) and eight on P1 within N 120..185, moved there and
    back (eased and linear): P1's sort and items take longer than P0's pulses, so where they had to
    be written whole by P1's rise, P0's span would be that long (a template for `at_period`)."""
    low = (120, 185, 130, 175, 140, 165, 150, 160)
    text = clock + "servo a = P0.0 speed 0.0001s/60deg\n"
    text += "".join(f"servo b{i} = P1.{i} speed 0.0001s/60deg\n" for i in range(8))
    text += f"pose lo {{ a: {a[0]}, " + ", ".join(f"b{i}: {n}" for i, n in enumerate(low)) + " }\n"
    text += f"pose hi {{ a: {a[1]}, " + ", ".join(f"b{i}: {305 - n}" for i, n in enumerate(low)) + " }\n"
    return text + "main {\n  move lo\n  loop {\n    move hi in 200ms ease in-out\n    move lo in 200ms\n  }\n}\n"


@pytest.mark.toolchain
@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n"])
def test_a_later_ports_span_need_only_leave_its_rise_mask_by_its_rise(clock):
    """With rises among falls a later port's rise reads only RISEM, which its items write first;
    its handover reads their header, and the handler the rest from its first edge on
    (`costs._stagger_need`). So the span of the port before it can end before that port's sort and
    items would: P0's span here is far shorter than where they must be written whole by P1's
    rise, and so is the period. At that minimum, over both moves whole, every pulse is exact in
    ucsim; 1 us less is refused."""
    from servoc import api

    built, period = check_at_minimum(later_port(clock), 20000)
    plan, b, t = built.plan, built.firmware.unit.budget, built.plan.program.target
    assert b.stagger and len(b.lines) == 2 and b.heads and b.heads[1] < b.items[1]
    whole = dataclasses.replace(b, heads=())       # each later port's sort and items by its rise
    spans = costs.fit_spans(t, whole, b.tops)
    assert b.spans[0] + 300 < spans[0] and b.spans[0] < b.sorts[1]
    assert costs.frame_cycles(t, b) < costs.frame_cycles(t, dataclasses.replace(whole, spans=spans))
    report = api.verify_hex(plan, built.firmware.hex_text, sum(m.frames for m in plan.moves) + 3)
    assert report.ok and report.max_error_cycles == 0, report.summary()


@pytest.mark.toolchain
@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n"])
def test_a_later_ports_header_is_written_before_the_earliest_handover(clock):
    """P1's handover comes after P1's rise and after P0's last fall. With P0's servo going down to
    N 0 that fall can come at C(0), before P1's header would be written by a span that leaves only
    RISEM its time: the span then holds the header too (ENTRY before P1's rise), and is longer than
    where P0's lowest N puts its last fall after that header (N 40). Both exact in ucsim at their
    minimum, 1 us less refused."""
    spans = {}
    for a in ((0, 120), (40, 100)):
        built, _ = check_at_minimum(later_port(clock, a), 20000)
        b, t = built.firmware.unit.budget, built.plan.program.target
        assert b.stagger and len(b.lines) == 2 and b.bottoms[0] == a[0]
        late = costs.handovers(t, b.tops, b.spans)[0]
        header = (late + costs.handler_load(b.rises[0], b.falls[0]) + b.sorts[1] - b.items[1] + b.heads[1]
                  + costs.ENTRY)    # P1's header written, and the entry before the handover that reads it
        if a[0] == 0:       # P0's last fall can come before the header: the span holds it
            assert t.width_cycles(b.bottoms[0]) < header <= b.spans[0]
        else:               # P0's last fall, and the handover, come after it: the span need not
            assert b.spans[0] < header <= t.width_cycles(b.bottoms[0])
        spans[a] = b.spans[0]
    assert spans[(0, 120)] > spans[(40, 100)]


@pytest.mark.toolchain
def test_a_later_ports_items_may_be_written_after_its_rise():
    """`later_port` built 100 us below its minimum (the budget bypassed): in frames after the first,
    P1's rise comes while its items are still being written (after RISEM, which it reads), and
    every pulse is exact in ucsim."""
    at_min = build_text(at_period(later_port(), 20000))
    late, ok = read_while_written(later_port(), at_min.plan.min_period_us - 100,
                                  lambda ports: (f"ft{ports[1]}", "fi_done", (f"win_p{ports[0]}", 2 * costs.SLED + 16)),
                                  after_frame=1)     # P1's rise: in P0's window, its sled's end
    assert late > 0 and ok


def two_tripods(clock: str = "", low: int = 120) -> str:
    """Eight servos on each of P0, P1 and P2 within N `low`..`low` + 112: P1's lines spread 16 N apart
    (each fall an entry of its own) where P2's are together, then the other way round, each by an
    eased move and a linear one (a template for `at_period`). Each port's worst frame is the other's
    best."""
    text = clock + "".join(f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg\n" for p in range(3) for b in range(8))

    def pose(name: str, first: bool) -> str:
        values = [f"s0{b}: {low + 30 + 10 * b if first else low + 20 + 5 * b}" for b in range(8)]
        values += [f"s{p}{b}: {low + 16 * b if first == (p == 1) else low + 56}" for p in (1, 2) for b in range(8)]
        return f"pose {name} {{ {', '.join(values)} }}\n"

    return (text + pose("a", True) + pose("b", False)
            + "main {\n  loop {\n    move a in {3P}us ease in-out\n    hold {1P}us\n    move b in {2P}us\n    hold {1P}us\n  }\n}\n")


def test_ports_falls_are_charged_for_their_worst_frame_together():
    """`costs.falls_together`: the most of some ports' falls in one frame, from every frame the moves
    can put out, is what adding each port's falls frame by frame over those frames gives (brute force
    over the joint frames), and where each port's worst frame is another's best, less than the sum of
    the ports' worst."""
    from servoc.flow import port_motions

    fe, _ = front_end_text(at_period(two_tripods(), 6000))
    plan, t = fe.plan, fe.plan.program.target
    widths = [t.width_cycles(n) for n in range(256)]
    ports_of = tuple(c.port for c in plan.channels)
    joint = port_motions(plan, joint=True)[0]
    per = port_motions(plan)
    got = {}
    for which in ((1, 2), (0, 1, 2)):
        brute = 0
        for lines in joint:
            falling = [ab is not None for ab in lines]
            for cur in costs._frames(lines):
                brute = max(brute, sum(costs.edges_load(widths, [v for v, f, q in zip(cur, falling, ports_of) if f and q == p])
                                       for p in which))
        apart = sum(costs.port_load(t, per[p]).falls for p in which)
        assert costs.falls_together(t, joint, ports_of, (which,), (apart,)) == (brute,) and brute < apart
        got[which] = brute
    b = codegen.generate(plan).budget
    assert (b.pair_falls, b.frame_falls) == (got[(1, 2)], got[(0, 1, 2)])


@pytest.mark.parametrize("clock", ["", SLOW[1]])
def test_falls_of_one_frame_charged_together_verify_at_the_minimum(clock):
    """The chain from the middle port's handover to the first port's items charges the falls of the
    last two ports, and the work from one frame's first items to the next the falls of every port:
    each from one frame, charged for their worst frame together (`Budget.pair_falls`,
    `Budget.frame_falls`). Each lowers this program's minimum below what each port's worst frame
    apart would give; every pulse is exact in ucsim at that minimum and 1 us less is refused."""
    built, period = check_engine_at_minimum(clock + two_tripods(), 9000, stagger=True)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert b.stagger and b.pair_falls < b.falls[1] + b.falls[2] and b.frame_falls < sum(b.falls)
    least = costs.frame_cycles(t, b)
    assert least < costs.frame_cycles(t, dataclasses.replace(b, pair_falls=0))
    assert least < costs.frame_cycles(t, dataclasses.replace(b, frame_falls=0))


@pytest.mark.parametrize("clock", ["", SLOW[1]])
def test_with_the_ports_one_after_another_one_frames_falls_are_charged_together_too(clock):
    """`two_tripods` within N 0..112: servoc pulses the ports one after another, and everything the
    frame does binds the minimum; its falls, of one frame, charged for that frame together, lower
    it. Every pulse exact in ucsim there, 1 us less refused."""
    built, period = check_at_minimum(two_tripods(clock, 0), 9000)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert not b.stagger and b.frame_falls < sum(b.falls)
    least = costs.frame_cycles(t, b)
    assert least == sum(b.sorts) + b.work + costs.frame_load(b) < costs.frame_cycles(t, dataclasses.replace(b, frame_falls=0))


def test_the_hexapods_chains_are_below_everything_its_frame_does():
    """examples/hexapod.servo at 12 MHz: the chain to the first port's items starts at the middle
    port's handover where the last port's sort is done by then, else the background is busy from
    the first port's handover, each run of the handler counted once. Neither binds: its minimum is
    everything the frame does (W, the sorts, the handler's rises and falls), and every pulse is
    exact in ucsim there over every move, with 1 us less refused."""
    from servoc import api

    source = (Path(__file__).resolve().parent.parent / "examples" / "hexapod.servo").read_text(encoding="utf-8")
    template = "".join(line + "\n" for line in source.splitlines() if not line.startswith("frame "))
    built, period = check_at_minimum(template, 20000)
    plan, b, t = built.plan, built.firmware.unit.budget, built.plan.program.target
    frame = sum(b.sorts) + b.work + costs.frame_load(b)
    assert b.stagger and t.cycles(period) == costs.frame_cycles(t, b) == frame > sum(b.spans)
    report = api.verify_hex(plan, built.firmware.hex_text, sum(m.frames for m in plan.moves) + 3)
    assert report.ok and report.max_error_cycles == 0, report.summary()


def shared_n(clock: str) -> str:
    """24 servos whose lines fall at 4 distinct N per port in every frame (pins b and b + 4 of a
    port together), moving between two poses, an eased move and a linear one."""
    lines = [f"servo s{p}{b} = P{p}.{b}" for p in range(3) for b in range(8)]
    a = ", ".join(f"s{p}{b}: {20 + 30 * (b % 4) + 5 * p}" for p in range(3) for b in range(8))
    z = ", ".join(f"s{p}{b}: {200 - 25 * (b % 4) - 7 * p}" for p in range(3) for b in range(8))
    return clock + "\n".join(lines) + f"\npose a {{ {a} }}\npose z {{ {z} }}\n" \
        "main { loop { move z in 900ms ease in-out; move a in 700ms } }\n"


@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n"])
def test_each_list_is_charged_for_the_most_distinct_n_of_one_frame(clock, monkeypatch):
    """Writing a port's list (stagger_emit.asm.j2) takes a pass for each pair after the first; passes
    past the last N read only the end mark, so each list is charged for its port's most distinct N
    in one frame (4 here, not 8): the minimum is lower, and every pulse exact in ucsim there over
    every move, with 1 us less refused."""
    from servoc import api

    template = shared_n(clock)
    built, period = check_at_minimum(template, 20000)
    plan, b = built.plan, built.firmware.unit.budget
    motions = codegen.port_motions(plan)
    assert b.stagger and [costs.port_load(plan.program.target, motions[p]).distinct for p in plan.ports] == [4] * 3
    report = api.verify_hex(plan, built.firmware.hex_text, sum(m.frames for m in plan.moves) + 3)
    assert report.ok and report.max_error_cycles == 0, report.summary()
    monkeypatch.setattr(codegen, "_unread", lambda *args: 0)       # every pass charged as one writing a fall
    monkeypatch.setattr(codegen, "_budgets", type(codegen._budgets)())
    assert own_minimum(template, 20000) > period
