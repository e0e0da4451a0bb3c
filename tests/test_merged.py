"""The ports' pulses at once (codegen.can_merge; frame_merged.asm.j2, irq_merged.asm.j2): every port
rises in the same entry of the edge handler, 3 cycles apart, and the falls of every port are one
timeline of groups, each writing every port in the same order with the lines it drops there. So
each line falls C(N) after its own port's rise, to the cycle, wherever the N of different ports
come close. frame_io sorts each port as before, then, once the handler has put out the frame
before's last group, merges their lists into the items. Each program here runs in ucsim at exactly
the shortest period servoc reports for it, every pulse exact, and that period less 1 us is refused.
"""

import dataclasses

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import build_text, front_end_text, parse_listing, simulate_events
from servoc import api, codegen, costs, layout
from servoc.diagnostics import Reporter
from servoc.flow import port_motions
from test_costs import at_period, own_minimum
from test_spans import between_two_poses, check_at_minimum, check_engine_at_minimum
from test_stagger import CASES, held, ports

pytestmark = pytest.mark.toolchain

STC22 = "target stc89c52rc clock 22.1184MHz\n"
STC6T = "target stc89c52rc clock 11.0592MHz mode 6T\n"


def plan_of(text: str):
    fe, diags = front_end_text(at_period(text, 20000))
    assert fe.plan is not None, diags
    return fe.plan


@pytest.mark.parametrize("clock, case", [(STC22, c) for c in (
    "N 0 and N 250 on every port", "all 24 lines at N 250", "all 24 lines at N 0",
    "lines crossing each other's N every frame", "one servo on a port, eight on the next",
    "eight on a port, one on the next")] + [(STC6T, "N 0 and N 250 on every port"),
                                             (STC6T, "lines within 1 to 2 ms (N 62 to 187)")])
def test_the_ports_at_once_verify_at_the_minimum(clock, case):
    """At the shortest period reported, with the merging before the rise only up to the items the
    rise's entry reads (`costs.merged_late`) or, where the rest does not fit before the first fall,
    whole: every pulse exact, 1 us less refused."""
    built, period = check_at_minimum(clock + CASES[case], 12000)
    b = built.firmware.unit.budget
    assert b.merged and built.plan.ports_at_once and not built.plan.rises_among_falls
    # before the next rise only the items the rise's entry reads, where the rest of the merging fits
    # before the first fall (17 groups, 1677 cycles, do not: eight on a port, one on the next)
    late = costs.merged_late(built.plan.program.target, b)
    assert late == (b.merge if case == "eight on a port, one on the next" else b.head) and b.head < b.merge
    assert built.plan.rise_offsets == tuple(3 * k for k in range(len(built.plan.ports)))


def test_lines_of_different_ports_one_div_apart_keep_their_widths():
    """Consecutive N on different ports: groups one DIV (14 or 15 cycles at 22.1184 MHz) apart,
    each a step of the entry before (the shortest step: 3 cycles a port and the read and jump, 13).
    Eight servos on P0 and P2 at N 200 to 215, the ports' N interleaved: 16 groups in a row."""
    text = held([[200 + 2 * b for b in range(8)], [], [201 + 2 * b for b in range(8)]])
    built, period = check_engine_at_minimum(STC22 + text, 12000, merged=True)
    b, t = built.firmware.unit.budget, built.plan.program.target
    assert costs.merged_step(2) == 10 and b.falls == (costs.merged_split(2) - 1 + t.width_cycles(215) - t.width_cycles(200),)
    assert min(t.width_cycles(n + 1) - t.width_cycles(n) for n in range(250)) == 14


def test_the_groups_of_a_frame_are_counted_over_every_port():
    """costs.merged_load: each frame's groups are the distinct N of the lines of every port, and its
    falls the handler's cycles for them at the split of a group (`edges_load`): held poses, by hand."""
    t = plan_of(STC22 + CASES["N 0 and N 250 on every port"]).program.target
    widths = [t.width_cycles(n) for n in range(256)]
    split = costs.merged_split(3)
    same = frozenset({tuple((n, n) for n in [0, 250, 36, 72, 108, 144, 180, 216] * 3)})
    load = costs.merged_load(t, same, split)
    assert load.groups == 8
    assert load.falls == (split - 1) * 8        # 36 DIV apart: every group an entry of its own
    apart = frozenset({tuple((200 + k, 200 + k) for k in range(16))})
    load = costs.merged_load(t, apart, split)
    assert load.groups == 16
    assert load.falls == (split - 1) + widths[215] - widths[200]    # one entry, then a step each
    plan = plan_of(STC22 + CASES["lines crossing each other's N every frame"])
    joint = port_motions(plan, joint=True)[0]
    load = costs.merged_load(t, joint, split)
    frames = [list(f) for lines in joint for f in costs._frames(lines)]
    assert load.groups == max(len(set(f)) for f in frames)
    assert load.falls == max(costs.edges_load(widths, f, split) for f in frames)


def test_the_items_are_sized_to_the_most_groups_a_frame_has():
    """RAM sized to the program: the items hold the rise's lines, then each group's link, N where it
    is an entry of its own, and a byte for each port; each port's list its distinct N and the end."""
    built = build_text(at_period(STC22 + CASES["N 0 and N 250 on every port"], 4000))
    unit = built.firmware.unit
    assert unit.budget.merged
    ram = dict((name, addr) for name, addr, _ in _ram_symbols(unit.text))
    groups = costs.merged_load(built.plan.program.target, port_motions(built.plan, joint=True)[0],
                               costs.merged_split(3)).groups
    assert groups == 8
    assert ram["DL1"] - ram["DL0"] == ram["DL2"] - ram["DL1"] == 2 * 8 + 1
    assert ram["ITEMS"] - ram["DL2"] == 2 * 8 + 1
    assert unit.text.count("\nmg") >= groups and f"mg{groups - 1}:" in unit.text and f"mg{groups}:" not in unit.text


def _ram_symbols(text: str):
    for line in text.splitlines():
        head = line.split(";")[0].split()
        if len(head) == 3 and head[1] == "=" and head[2].startswith("0x"):
            yield head[0], int(head[2], 16), line


def test_the_window_and_the_exits_are_where_the_items_say():
    """The offsets frame_io writes are the window's own: a group's code after the sled, the
    LJMP exit_far and the LJMP exit_end after it; and the longest exit, from a group's last edge to
    its RETI, is within the MEXIT its split counts (a group this far apart gets an entry of its own
    after the RETI before)."""
    built = build_text(at_period(STC22 + CASES["N 0 and N 250 on every port"], 4000))
    instrs, labels = parse_listing(built.firmware.image.listing)
    win = instrs[labels["win_m"]].address
    e = {"sled": costs.merged_split(3) - 1 - costs.merged_step(3)}
    at = {ins.address - win: ins for ins in instrs[labels["win_m"]:labels["exit_end"]]}
    assert all(at[k].op == "NOP" for k in range(e["sled"]))
    group = [(ins.op, ins.args[0]) for ins in instrs[labels["win_m"] + e["sled"]:][:15]]
    assert group[:9] == [("MOV", "A"), ("INC", "R0"), ("XRL", "P0"), ("MOV", "A"), ("INC", "R0"), ("XRL", "P1"),
                         ("MOV", "A"), ("INC", "R0"), ("XRL", "P2")]
    assert at[e["sled"] + 4 * 3 + 3].args == ("exit_far",) and at[e["sled"] + 4 * 3 + 6].args == ("exit_end",)
    from servoc import wcet
    code = wcet.Code(built.firmware.unit.text)
    assert 6 + code.longest_exit({"exit_far", "exit_end"}) == costs.MEXIT


def test_which_programs_can_have_the_ports_at_once():
    """Two ports or more, at a clock where a group of every port fits between the falls of two
    consecutive N (3 cycles a port and 4: 13 with three ports, 10 with two), built for speed,
    without `host` (a serial line alone is in its budget)."""
    two, three = ports(1, 8), CASES["N 0 and N 250 on every port"]
    assert codegen.can_merge(plan_of(STC22 + three))
    assert codegen.generate(plan_of(STC22 + three)).budget.merged
    assert not codegen.generate(plan_of(STC22 + three), merged=False).budget.merged
    assert codegen.can_merge(plan_of(STC6T + three))
    assert not codegen.can_merge(plan_of(three))                                          # 12 MHz: 8 a DIV
    assert codegen.can_merge(plan_of("target at89c52 clock 18.432MHz\n" + two))          # 12 or 13 a DIV
    assert not codegen.can_merge(plan_of("target at89c52 clock 18.432MHz\n" + three))
    assert codegen.can_merge(plan_of(STC22 + "serial 9600\n" + three))
    hosting = STC22 + "serial 9600\nhost ssc32\n" + three.replace("main {", "main {\n  host\n", 1)
    assert not codegen.can_merge(plan_of(hosting))
    assert not codegen.can_merge(plan_of(STC22 + held([[100]])))                        # one port


def _held_off(hold: int):
    """The verify report of the build with the ports at once, with interrupts held off for `hold`
    cycles at several points of the background, at that build's own shortest period."""
    template = STC22 + CASES["N 0 and N 250 on every port"]
    period = 12000
    for _ in range(6):
        fe, diags = front_end_text(at_period(template, period))
        unit = codegen.generate(fe.plan, fe.source, hold_off=hold)
        if unit.min_period_us == period:
            break
        period = unit.min_period_us
    assert unit.budget.merged and unit.text.count("CLR     EA") >= 4
    firmware = api.assemble(unit, Reporter(fe.source))
    return api.verify(api.with_rises(fe.plan, unit), firmware, 200)


@pytest.mark.parametrize("hold", [4, 10])
def test_every_edge_stays_on_its_cycle_with_interrupts_held_off(hold):
    """Each group runs inside an entry of the edge handler, after its TL0 pad (test_irq.py): with
    interrupts held off for up to 10 cycles at several points of the background (frame_io's wait
    among them), every edge of the build with the ports at once stays on its cycle at that build's
    own shortest period."""
    report = _held_off(hold)
    assert report.ok and report.max_error_cycles == 0, (hold, report.summary(), [str(m) for m in report.mismatches[:5]])


def test_the_check_can_fail_when_the_pad_runs_out():
    """Held off for 40 cycles, an overflow waits longer than the pad covers: edges move, and
    verify says so (the test above can fail)."""
    assert not _held_off(40).ok


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_random_programs_verify_at_the_minimum_of_the_ports_at_once(data):
    """Random programs on two or three ports, each line between two random N, every frame a move
    (after a hold, or not):
    the build with the ports at once, at its own shortest period, every pulse exact in ucsim, and 1 us
    less refused by its budget (at 22.1184 MHz, 24 MHz, 11.0592 MHz and 12 MHz in 6T mode; two ports also
    at 18.432 MHz, 12 or 13 cycles a DIV)."""
    ports_ = data.draw(st.sampled_from([(0, 1), (0, 2), (0, 1, 2), (1, 2)]))
    clock = data.draw(st.sampled_from([STC22, STC6T, "target at89c52 clock 24MHz\n", "target stc89c52rc clock 12MHz mode 6T\n"]
                                      + (["target at89c52 clock 18.432MHz\n"] if len(ports_) == 2 else [])))
    servos = [(port, bit, data.draw(st.integers(0, 250)), data.draw(st.integers(0, 250)))
              for port in ports_ for bit in range(data.draw(st.integers(1, 8 if len(ports_) == 2 else 4)))]
    template = clock + between_two_poses(servos, eased=data.draw(st.booleans()))
    if data.draw(st.booleans()):        # frames before the first move: no line falls in them
        template = template.replace("main { loop {", "main { hold {3P}us; loop {")
    try:
        check_engine_at_minimum(template, 12000, merged=True)
    except layout.RamFull:      # the AT89C52 has no XRAM for the motion state: the build servoc
        # chooses is another one, which holds its own minimum
        assert "at89c52" in clock
        built, _ = check_at_minimum(template, 12000)
        assert not built.firmware.unit.budget.merged


def test_where_the_ports_at_once_do_not_fit_the_at89c52s_ram_another_build_is_chosen():
    """Three ports with eight lines at as many N (the motion state of three ports, 96 bytes, and the
    items of nine groups): the build with the ports at once does not fit the AT89C52's internal RAM,
    and that chip has no XRAM; the build with rises among falls is chosen, and holds its minimum."""
    servos = [(0, 0, 37, 0), (0, 1, 0, 12), (0, 2, 9, 0), (1, 0, 0, 8), (2, 0, 5, 0), (2, 1, 0, 4), (2, 2, 1, 0),
              (2, 3, 0, 0)]
    template = "target at89c52 clock 24MHz\n" + between_two_poses(servos)
    fe, _ = front_end_text(at_period(template, 12000))
    with pytest.raises(layout.RamFull):
        codegen.generate(fe.plan, merged=True)
    built, _ = check_at_minimum(template, 12000)
    assert built.firmware.unit.budget.stagger and not built.firmware.unit.budget.merged


def test_with_a_meanwhile_body_and_an_input_the_ports_at_once_verify_at_the_minimum():
    """frame_io returns once the frame's items are written, before its rise: a select's looks
    (frame_w) come after it as in the other builds. 12 servos on three ports, a select on a button
    whose meanwhile body moves them every frame: every pulse exact at the reported minimum, 1 us
    less refused; pressed and released at random times, every reaction in its frame."""
    body = ports(4, 4, 4)
    decls, rest = body.split("main {", 1)
    template = (STC22 + "input button = P3.2\n" + decls + "main { loop { select { on press button { wait release "
                "button; move b in {2P}us } meanwhile { loop { move b in {1P}us; move a in {1P}us } } } } }\n")
    built, period = check_at_minimum(template, 12000)
    assert built.firmware.unit.budget.merged and "frame_w" in built.firmware.unit.text
    scenario = "".join(f"{t}ms button {'active' if k % 2 == 0 else 'inactive'}\n" for k, t in enumerate(range(7, 400, 37)))
    plan, evs, trace = simulate_events(at_period(template, period), scenario, 150)
    report = api.check_events(plan, trace, 150, evs)
    assert report.ok and report.max_error_cycles == 0 and len(report.reactions) >= 5, report.summary()


def test_compile_says_the_ports_pulse_at_once(tmp_path, capsys):
    """`servoc compile`'s summary names the build, as `plan` and the hover on `frame` do."""
    from servoc import cli
    path = tmp_path / "p.servo"
    path.write_text(at_period(STC22 + CASES["N 0 and N 250 on every port"], 4000))
    assert cli.main(["compile", str(path), "-o", str(tmp_path / "p.hex")]) == 0
    out = capsys.readouterr().out
    assert "the ports pulse overlapping, all at once" in out and "XRAM 240/256 bytes" in out


def test_frames_before_the_first_move_end_in_the_rise_s_entry():
    """Before its first move no line has a target: the rise's entry writes no line and ends the
    frame at once (exit_end), so frame_io cannot wait to see the handler past the rise's items; it
    sees MBUSY clear. Two ports held for some frames, then moving: every pulse exact at the
    minimum, 1 us less refused."""
    body = ports(4, 4)
    decls, rest = body.split("main {", 1)
    template = STC22 + decls + "main { hold {3P}us; hold {3P}us;" + rest
    built, period = check_at_minimum(template, 12000)
    assert built.firmware.unit.budget.merged and built.plan.ports_at_once


def every_kind_of_f(clock: str, period_us: int) -> str:
    """24 servos over three ports, the lines of a port each a different |delta|, up or down, moved
    in F of 1 (the first move: targets set at once), 3 and 7 frames (Q and REM from a DIV, carries
    on the first frame or not), 60, and 257 (over 255: Q = 0, REM = |delta|), at `period_us`."""
    lines = [f"servo s{i} = P{i // 8}.{i % 8} speed 0.0001s/60deg" for i in range(24)]
    a = ", ".join(f"s{i}: {(37 * (i % 8)) % 251}" for i in range(24))
    b = ", ".join(f"s{i}: {(250 - 53 * (i % 8)) % 251}" for i in range(24))
    moves = "; ".join(f"move {pose} in {frames * period_us // 1000}ms"
                      for pose, frames in (("a", 1), ("b", 3), ("a", 7), ("b", 60), ("a", 257)))
    return (clock + f"frame {period_us}us\n" + "\n".join(lines) + f"\npose a {{ {a} }}\npose b {{ {b} }}\n"
            f"main {{ {moves}; hold {2 * period_us // 1000}ms }}\n")


@pytest.mark.parametrize("clock, period_us, xram", [(STC22, 5000, True), ("", 8000, False),
                                                    ("target at89c52 clock 22.1184MHz\n", 7000, False)])
@pytest.mark.parametrize("first_step", [True, False])
def test_linear_moves_of_every_kind_of_f(clock, period_us, xram, first_step):
    """A linear move's set-up, DDA terms and first frame are one call (setup_step; with the motion
    state in XRAM, the record pointer kept in R2:R3 while DPTR reaches XRAM), or without
    `first_step` two (setup_pin, then dda_step): on the first frame the carry's path steps the pin
    in place, the other jumps to step_pin's. Every pulse of every frame exact in ucsim, with the
    motion state in XRAM (the ports at once) and in internal RAM (at 12 MHz and 22.1184 MHz on
    the AT89C52)."""
    built = build_text(every_kind_of_f(clock, period_us))
    plan, fw = built.plan, built.firmware
    if not first_step:
        plan = dataclasses.replace(plan, first_step=False)
        reporter = Reporter(built.source)
        fw = api.assemble(codegen.generate(plan, built.source), reporter)
        assert fw is not None, reporter.diagnostics
        plan = api.with_rises(plan, fw.unit)        # that build's ports' rises
    unit = fw.unit
    assert ("XSTATE" in unit.text) == xram and unit.budget.merged == xram and "dda_pin:" not in unit.text
    assert ("LCALL   setup_step" in unit.text) == first_step and ("LCALL   dda_step" in unit.text) != first_step
    assert [st.frames for st in plan.main if hasattr(st, "frames")][1:5] == [3, 7, 60, 257]
    report = api.verify(plan, fw, 1 + 3 + 7 + 60 + 257 + 2)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:5]])


@pytest.mark.parametrize("clock, linear", [(STC22, True), (STC22, False), (STC6T, True)])
def test_eased_and_linear_moves_each_set_up_and_stepped_in_one_call_with_the_motion_state_in_xram(clock, linear):
    """With the motion state in XRAM and both kinds of move of known F, setup_step takes both (it
    tests EASED: an eased move's N0 and |delta| written to XRAM, then step_eased's first frame; a
    linear one's DDA terms and first step); with eased moves only, those: eased (and linear) moves
    of F 1, 3, 7, 60 and 257 frames in turn, 24 servos over three ports, up and down: every pulse
    of every frame exact in ucsim."""
    lines = [f"servo s{i} = P{i // 8}.{i % 8} speed 0.0001s/60deg" for i in range(24)]
    a = ", ".join(f"s{i}: {(37 * (i % 8)) % 251}" for i in range(24))
    b = ", ".join(f"s{i}: {(250 - 53 * (i % 8)) % 251}" for i in range(24))
    moves = [("a", 5, " ease in-out"), ("b", 15, ""), ("a", 35, " ease in"), ("b", 300, ""), ("a", 1285, " ease out"),
             ("b", 5, ""), ("a", 15, " ease in-out"), ("b", 35, ""), ("a", 300, " ease in-out"), ("b", 1285, "")]
    moves = [(p, ms, e or ("" if linear else " ease in")) for p, ms, e in moves]
    text = (clock + "frame 5000us\n" + "\n".join(lines) + f"\npose a {{ {a} }}\npose b {{ {b} }}\n"
            "main { " + "; ".join(f"move {p} in {ms}ms{e}" for p, ms, e in moves) + "; hold 10ms }\n")
    built = build_text(text)
    unit = built.firmware.unit
    assert unit.budget.merged and "XSTATE" in unit.text and built.plan.first_step
    assert ("JNB     EASED, ss_l" in unit.text) == linear and "LJMP    se_a" in unit.text
    assert "LCALL   setup_pin" not in unit.text
    frames = [st.frames for st in built.plan.main if hasattr(st, "frames")]
    assert frames[:10] == [1, 3, 7, 60, 257] * 2
    report = built.verify(sum(frames) + 2)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:5]])


def test_the_shortest_period_reported_is_that_of_the_code_built_for_it_where_the_records_f_change():
    """At `frame 20ms` a 1.2 s linear move has F 60, in one byte, and its DDA terms take a DIV; at
    the shortest period its F is over 255 and the code built there takes none (wcet follows the
    record's F8). So the shortest period reported at 20 ms is the least P whose own code holds P
    (api._least_period), below what the code built for 20 ms holds: `frame P` builds, and 1 us less
    is refused; at that period every pulse of the whole loop is exact in ucsim."""
    lines = [f"servo s{i} = P{i // 8}.{i % 8}{' speed 0.3s/60deg' if i % 2 else ''}" for i in range(24)]
    low = (0, 250, 36, 72, 108, 144, 180, 216)
    a = ", ".join(f"s{i}: {low[i % 8]}" for i in range(24))
    b = ", ".join(f"s{i}: {250 - low[i % 8]}" for i in range(24))
    body = (f"\n".join(lines) + f"\npose a {{ {a} }}\npose b {{ {b} }}\n"
            "main {\n  loop {\n    move a in 1200ms ease in-out\n    move b in 1200ms\n  }\n}\n")
    fe, _ = front_end_text(STC22 + "frame 20ms\n" + body)
    reported = fe.plan.min_period_us
    own = codegen.generate(fe.plan).min_period_us        # the code built for 20 ms: with the DIV
    assert reported < own
    at, diags = front_end_text(STC22 + f"frame {reported}us\n" + body)
    assert at.plan.min_period_us == reported and not [d for d in diags if d.is_error]
    _, diags = front_end_text(STC22 + f"frame {reported - 1}us\n" + body)
    assert [d.code for d in diags if d.is_error] == ["period-too-short"]
    built = build_text(STC22 + f"frame {reported}us\n" + body)
    report = built.verify(sum(m.frames for m in built.plan.moves) + 2)      # both moves' first frames
    assert report.ok and report.max_error_cycles == 0, report.summary()


@pytest.mark.parametrize("clock_hz, six_t", [(12_000_000, False), (22_118_400, False), (11_059_200, True),
                                             (18_432_000, False), (4_497_664, False), (9_999_616, False)])
def test_a_group_taken_as_far_without_its_gap_is_far_at_every_n(clock_hz, six_t):
    """costs.near_dn, from which frame_io (and the handler of the other builds) takes a group as an
    entry of its own without looking up its gap: the least dN at which every C(N + dN) - C(N) is
    the split or more, at 1 us cycles, at others, and at clocks where dN x the DIV's cycles, floored,
    would say one more."""
    from servoc import target as target_mod
    t = target_mod.Target(target_mod.CHIPS["stc89c52rc"], clock_hz, six_t)
    widths = [t.width_cycles(n) for n in range(251)]
    for split in (costs.SPLIT, costs.merged_split(2), costs.merged_split(3)):
        d = costs.near_dn(t, split)
        assert all(widths[n + d] - widths[n] >= split for n in range(251 - d))
        assert any(widths[n + d - 1] - widths[n] < split for n in range(252 - d))


def test_lines_near_dn_apart_verify_where_the_floored_div_would_say_one_more():
    """At 12.681472 MHz dN x the DIV's cycles, floored, reaches SPLIT only at 12, while every pair of
    N 11 apart is already SPLIT cycles apart (costs.near_dn): lines 11 apart, and 10 apart, on a
    port, at the shortest period reported: every pulse exact, 1 us less refused."""
    from test_stagger import held
    from servoc import target as target_mod
    t = target_mod.Target(target_mod.CHIPS["at89c52"], 12_681_472, False)
    d = costs.near_dn(t, costs.SPLIT)
    assert d == 11 and next(k for k in range(1, 250) if int(k * t.div_cycles) >= costs.SPLIT) == 12
    check_at_minimum("target at89c52 clock 12.681472MHz\n"
                     + held([[20 + d * k for k in range(4)] + [150 + (d - 1) * k for k in range(4)]]), 9000)


def serial_goal(clock: str, baud: int, period_us: int) -> str:
    """24 servos on three ports (every port N 0 and 250 in the same frame, the others 36 apart)
    moved by bytes from a host: "a" and "b", each answered once its move is done."""
    low = (0, 250, 36, 72, 108, 144, 180, 216)
    text = clock + f"serial {baud}\nframe {period_us}us\n"
    text += "".join(f"servo s{i} = P{i // 8}.{i % 8} speed 0.0001s/60deg\n" for i in range(24))
    text += "pose a { " + ", ".join(f"s{i}: {low[i % 8]}" for i in range(24)) + " }\n"
    text += "pose b { " + ", ".join(f"s{i}: {250 - low[i % 8]}" for i in range(24)) + " }\n"
    return text + ('main {\n  move a\n  send "R"\n  loop {\n    select {\n'
                   '      on "a" { move a in 60ms ease in-out; send "A" }\n'
                   '      on "b" { move b in 60ms; send "B" }\n    }\n  }\n}\n')


@pytest.mark.parametrize("clock", [STC22, STC6T])
def test_the_ports_at_once_with_a_serial_line_at_its_fastest_rate_under_bursts(clock):
    """With a serial line the ports still pulse at once: the serial handler's runs are charged to
    each window (the work's, the merging's before the rise) and the edge handler's longest stretch
    is everything it does in a frame (the rise, every group, the last one's exit), which 14400 baud
    leaves time for and 19200 does not (that rate gets the ports overlapping). At 14400 baud, at the
    shortest period reported, bursts of four bytes back to back at four phases of the frame (each
    byte a move of 60 ms between N 0 and 250 on every port): every pulse exact, every byte answered
    in order; 1 us less refused."""
    from servoc import events
    from test_serial import run, sent
    fast = build_text(serial_goal(clock, 19200, 20000))
    assert not fast.firmware.unit.budget.merged
    first = build_text(serial_goal(clock, 14400, 20000))
    period = first.plan.min_period_us
    built = build_text(serial_goal(clock, 14400, period))
    b = built.firmware.unit.budget
    assert b.merged and b.byte_cycles and b.serial_sends and built.plan.ports_at_once
    assert built.plan.min_period_us == period < fast.plan.min_period_us
    target = built.plan.program.target      # the serial handler's runs are in the budget
    assert costs.frame_cycles(target, dataclasses.replace(b, byte_cycles=0)) < costs.frame_cycles(target, b)
    lines = [f'{40 + 300 * k + 0.27 * k * period / 1000:.3f}ms "a" "b" "a" "b"' for k in range(4)]
    frames = int(1_400_000 / period)
    plan, trace, evs, report = run(serial_goal(clock, 14400, period), "\n".join(lines) + "\n", frames)
    assert report.ok and report.max_error_cycles == 0, [str(m) for m in report.mismatches[:3]]
    assert sent(trace) == "R" + "ABAB" * 4
    fe, diags = front_end_text(serial_goal(clock, 14400, period - 1))
    assert "period-too-short" in str(diags)


@settings(max_examples=5, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_random_serial_programs_with_the_ports_at_once_verify_at_the_minimum(data):
    """Random programs on two or three ports with a serial line (2400 to 9600 baud), a select of
    up to eight branches, each a byte answered once its moves (in a `repeat`, between random poses,
    linear and eased) are done: the ports at once, at the shortest period reported, two bursts of
    four bytes at random phases, every pulse exact and every byte answered in order; 1 us less
    refused."""
    from test_serial import run, sent
    ports_ = data.draw(st.sampled_from([(0, 1), (0, 2), (0, 1, 2), (1, 2)]))
    clock = data.draw(st.sampled_from([STC22, STC6T]))
    baud = data.draw(st.sampled_from([2400, 4800, 9600]))
    pins = [(p, b) for p in ports_ for b in range(data.draw(st.integers(1, 4)))]
    branches = data.draw(st.integers(2, 8))
    text = clock + f"serial {baud}\n"
    text += "".join(f"servo s{p}{b} = P{p}.{b} speed 0.0001s/60deg\n" for p, b in pins)
    for k in range(branches + 1):
        text += f"pose q{k} {{ " + ", ".join(f"s{p}{b}: {data.draw(st.integers(0, 250))}" for p, b in pins) + " }\n"
    letters = "abcdefgh"[:branches]
    text += 'main {\n  move q0\n  send "R"\n  loop {\n    select {\n'
    for k, c in enumerate(letters):
        text += (f'      on "{c}" {{ repeat {data.draw(st.integers(1, 2))} {{ move q{k + 1} in 30ms; '
                 f'move q{(k + 1) % branches + 1} in 30ms ease in-out }}; send "{c.upper()}" }}\n')
    text += "    }\n  }\n}\n"
    period = own_minimum(text)      # (the moves' F, and so the frames between sends, follow P)
    built = build_text(at_period(text, period))
    assert built.firmware.unit.budget.merged and built.plan.min_period_us == period
    sent_bytes = [data.draw(st.sampled_from(letters)) for _ in range(8)]
    phase = data.draw(st.integers(0, 999)) / 1000
    bursts = [f'{40 + 700 * k + phase * period / 1000:.3f}ms ' + " ".join(f'"{c}"' for c in sent_bytes[4 * k:4 * k + 4])
              for k in range(2)]
    plan, trace, evs, report = run(at_period(text, period), "\n".join(bursts) + "\n", int(1_400_000 / period))
    assert report.ok and report.max_error_cycles == 0, (text, [str(m) for m in report.mismatches[:3]])
    assert sent(trace) == "R" + "".join(sent_bytes).upper(), text
    _, diags = front_end_text(at_period(text, period - 1))
    assert "period-too-short" in str(diags)
