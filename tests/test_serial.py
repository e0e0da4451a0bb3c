"""The serial line in the firmware, run in ucsim with bytes from a host.

Each scenario feeds ucsim's UART with bytes at chosen times (`servoc verify
--events`): the branch each select takes is found by replaying the
firmware's rule, every pulse must match the plan of that run exactly, each
`on` must start within 2 P of its byte's stop bit, and every byte the
firmware sends must be the plan's, in order, within 2 P of its frame.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction
import re
import sys
from pathlib import Path

import pytest

from conftest import assert_exact, build_text, front_end_text, simulate_events
from servoc import api, cli, codegen, costs, events, layout, verify
from servoc.flow import send_gap, send_run
from servoc.target import byte_cycles, timer1_baud, working_bauds

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import budget as bench  # noqa: E402  the benchmark's stress programs and its busy line

pytestmark = pytest.mark.toolchain

ROOT = Path(__file__).resolve().parent.parent

ARM = """\
serial 4800
servo arm = P1.0 speed 0.05s/60deg
servo leg = P1.1 speed 0.05s/60deg
servo tail = P2.3 speed 0.05s/60deg
pose home { arm: 20, leg: 20, tail: 20 }
pose a { arm: 230, leg: 40, tail: 120 }
pose b { arm: 100, leg: 200, tail: 60 }
main {
  move home
  send "R"
  loop {
    select {
      on "a" { move a in 300ms; send "A" }
      on "b" { move b in 300ms; hold 50ms; send "B" }
      after 1s { move home in 200ms; send "T" }
    }
  }
}
"""


def run(text: str, scenario: str, frames: int):
    plan, evs, trace = simulate_events(text, scenario, frames)
    return plan, trace, evs, api.check_events(plan, trace, frames, evs)


def sent(trace) -> str:
    return "".join(chr(b) for _, b in trace.sent)


P_US = 5300


def at_frames(k: float) -> str:
    return f"{round(k * P_US)}us"


SCENARIOS = {
    "nothing: the timeout, again and again": ("", "RTT"),
    "one byte mid-frame": (f'{at_frames(40.5)} "a"\n', "RAT"),
    "bytes at frame boundaries": (f'{at_frames(40)} "b"\n{at_frames(140)} "a"\n', "RBA"),
    "four back to back, one unknown": (f'{at_frames(40.3)} "a" "z" "b" "a"\n', "RABA"),
    "bytes while no select waits stay queued": (f'{at_frames(40.2)} "a"\n{at_frames(45.7)} "b"\n', "RAB"),
    "unknown bytes only": (f'{at_frames(40)} "x"\n{at_frames(60)} 0 255\n', "RTT"),
}


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_scenarios_verify_exactly(name):
    scenario, answers = SCENARIOS[name]
    plan, trace, evs, report = run(ARM, scenario, 700)
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert sent(trace).startswith(answers), sent(trace)
    assert report.bytes_sent == len(sent(trace)) or report.bytes_sent == len(sent(trace)) - 1


def test_each_branch_starts_within_two_frames_of_its_byte():
    plan, trace, evs, report = run(ARM, SCENARIOS["bytes at frame boundaries"][0], 700)
    delays = [d for _, _, d in verify.event_delays(plan, trace, evs)]
    assert len(delays) == 2 and all(0 < d <= 2 * plan.period_us for d in delays), delays


def test_a_run_checked_against_other_bytes_fails():
    plan, trace, _, report = run(ARM, f'{at_frames(40)} "a"\n', 400)
    assert report.ok
    other = events.parse(f'{at_frames(40)} "b"\n', (), True)
    assert not api.check_events(plan, trace, 400, other).ok


def test_the_queue_model_matters(monkeypatch):
    """Six bytes back to back while the robot moves: the queue keeps four, the rest are dropped.
    verify sees each drop, and allows it only because the queue held four: checked as if the queue
    held eight, the same run fails."""
    scenario = f'{at_frames(40.1)} "a"\n{at_frames(42)} "b" "a" "b" "a" "b" "a"\n'
    plan, trace, evs, report = run(ARM, scenario, 700)
    assert report.ok and sent(trace).startswith("RABABAT")     # a, then b a b a: the last b a dropped
    assert sum("the queue already held 4 bytes" in w for w in report.warnings) == 2, report.warnings
    monkeypatch.setattr(costs, "QUEUE", 8)
    wrong = api.check_events(plan, trace, 700, evs)
    assert sum("dropped with only 4 queued" in m.what for m in wrong.mismatches) == 2, wrong.mismatches


def test_a_wrong_byte_sent_is_caught():
    good = build_text(ARM)
    wrong = build_text(ARM.replace('send "A"', 'send "Z"'))
    evs = events.parse(f'{at_frames(40)} "a"\n', (), True)
    stim = api.stimulus(good.plan, evs)
    trace = api.simulate(wrong.firmware.hex_text, api.cycles_needed(good.plan, 300), good.plan.program.target, stim,
                         api.probes(wrong.firmware))
    report = api.check_events(good.plan, trace, 300, evs)
    assert not report.ok and any('sent "Z" where "A" was due' in m.what for m in report.mismatches)
    silent = build_text(ARM.replace('send "R"\n', ""))
    trace = api.simulate(silent.firmware.hex_text, api.cycles_needed(good.plan, 300), good.plan.program.target,
                         api.stimulus(good.plan))
    assert any("was not sent" in m.what or "where" in m.what for m in api.check_trace(good.plan, trace, 300).mismatches)


HEXAPOD = (ROOT / "examples/hexapod_serial.servo").read_text(encoding="utf-8")
HEXAPOD_P_US = 20000
HEXAPOD_SCENARIOS = {
    "at a frame boundary": (f'{100 * HEXAPOD_P_US}us "l"\n', "RL"),
    "mid-frame, unknown bytes around": ('2.3s "q"\n2.3053s "s" "?" "w"\n', "R?S?W"),
    # "l" comes while the stand after the cut runs (no select looks): queued, then taken
    "while it walks": ('2.2s "w"\n2.9s "s"\n3.1s "l"\n', "RWSL"),
    "a byte the walk does not hear": ('2.2s "w"\n2.5s "l"\n3.3s "s"\n', "RWS"),
}


@pytest.mark.parametrize("name", list(HEXAPOD_SCENARIOS))
def test_hexapod_scenarios(name):
    scenario, answers = HEXAPOD_SCENARIOS[name]
    plan, trace, _, report = run(HEXAPOD, scenario, 500)
    assert plan.period_us == HEXAPOD_P_US
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert sent(trace).startswith(answers), sent(trace)


def test_hexapod_example_verifies_over_serial():
    rc = cli.main(["verify", str(ROOT / "examples/hexapod_serial.servo"),
                   "--events", str(ROOT / "examples/events/hexapod_serial.events")])
    assert rc == 0


def answering(ms_hi: int = 150, ms_lo: int = 150, hi: str = "hi", lo: str = "lo") -> str:
    """A main that moves to `lo`, then forever: on "h" to `hi` in `ms_hi` ms, answering "H"; on "l"
    back to `lo` in `ms_lo` ms, answering "L"."""
    return (f'main {{\n  move {lo}\n  loop {{\n    select {{\n'
            f'      on "h" {{ move {hi} in {ms_hi}ms; send "H" }}\n      on "l" {{ move {lo} in {ms_lo}ms; send "L" }}\n'
            '    }\n  }\n}\n')


SPREAD = 16     # N apart: 118 cycles at 11.0592 MHz, so each line falls in an edge-handler entry of its own
FAST = """\
target stc89c52 clock 11.0592MHz
serial 14400
""" + "".join(f"servo s{p}{b} = P{p}.{b} speed 0.05s/60deg\n" for p in range(3) for b in range(6)) + """\
pose lo { """ + ", ".join(f"s{p}{b}: {SPREAD * b}" for p in range(3) for b in range(6)) + """ }
pose hi { """ + ", ".join(f"s{p}{b}: {250 - SPREAD * b}" for p in range(3) for b in range(6)) + " }\n" + answering(200, 200)


def test_the_fastest_rate_at_11_0592_mhz_with_bursts():
    """The fastest rate the check allows for 18 servos at 11.0592 MHz, at the program's own
    shortest period, its lines falling in entries of their own at the ends of each port's window
    (the edge handler's longest hold on the CPU): bursts of four bytes at 16 phases of the frame,
    each one sixteenth of a frame later than the one before. No byte may be lost."""
    built = build_text(FAST)
    unit, plan = built.firmware.unit, built.plan
    assert plan.period_us == unit.min_period_us
    late = costs.serial_latency(unit.target, unit.budget)
    assert late <= unit.budget.byte_cycles < late + 60        # at the check's limit
    lines = [f'{60_000 + 1_000_000 * k + k * plan.period_us // 16}us "h" "l" "h" "l"' for k in range(16)]
    plan, trace, evs, report = run(FAST, "\n".join(lines) + "\n", int(16_500_000 / plan.period_us))
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert sent(trace) == "HLHL" * 16


def test_rates_that_cannot_be_kept_are_refused(tmp_path, capsys):
    text = "target stc89c52 clock 11.0592MHz\nserial 19200\n" + "".join(
        f"servo s{b} = P1.{b}\n" for b in range(8)) + "pose p { " + ", ".join(f"s{b}: 100" for b in range(8)) + \
        " }\nmain { move p; wait \"a\"; send \"b\"; move p }\n"     # it answers: a run for TI may be under way
    path = tmp_path / "fast.servo"
    path.write_text(text)
    assert cli.main(["compile", str(path)]) == 1
    err = capsys.readouterr().err
    assert "[serial-too-fast]" in err and "use `serial 9600`" in err
    path.write_text(text.replace("serial 19200", "serial 9600"))
    assert cli.main(["compile", str(path), "-o", str(tmp_path / "f.hex")]) == 0


def test_sends_that_outrun_the_line_are_refused(tmp_path, capsys):
    base = "serial 1200\nservo arm = P1.0\npose p { arm: 100 }\npose q { arm: 120 }\n"
    path = tmp_path / "s.servo"
    path.write_text(base + 'main { move p; ' + 'send "a"; ' * 33 + '}\n')     # past the longest transmit queue
    assert cli.main(["compile", str(path)]) == 1
    assert "[send-overrun]" in capsys.readouterr().err
    path.write_text(base + 'main { loop { move p; send "a"; move q; send "b" } }\n')   # 1200 baud: 8.3 ms a byte
    assert cli.main(["compile", str(path)]) == 1
    assert "[send-overrun]" in capsys.readouterr().err
    path.write_text(base + 'main { loop { move p in 100ms; send "a"; move q in 100ms; send "b" } }\n')
    assert cli.main(["compile", str(path), "-o", str(tmp_path / "s.hex")]) == 0


def test_events_file_bytes():
    evs = events.parse('# the host\n1.5ms 0 255 "w"\n1s "#" 35 # two hashes\n', (), True)
    assert [(e.time_us, e.data) for e in evs] == [(1500, bytes([0, 255, 119])), (1_000_000, b"##")]
    for bad in ('1s 256\n', '1s ""\n', '1s "w" x\n', '1s "\u20ac"\n', '1s "\\q"\n', '1s "\\x1"\n', '1s "ab\n'):
        with pytest.raises(events.EventsError):
            events.parse(bad, (), True)


def test_events_file_strings_carry_whole_host_commands():
    """A host command is one line: a string's characters with the escapes \\r \\n \\t \\0 \\\\ \\" \\xHH;
    a `#` inside a string is no comment."""
    evs = events.parse('2s "#0P1500T500\\r"   # a move\n3s "\\x1bQ\\n" 0x1B\n4s "a\\"b\\\\"\n', (), True)
    assert [e.data for e in evs] == [b"#0P1500T500\r", b"\x1bQ\n\x1b", b'a"b\\']


def test_send_runs_and_gaps_are_counted():
    fe, _ = front_end_text('serial 4800\nservo arm = P1.0\npose p { arm: 100 }\n'
                           'main { send "a"; repeat 2 { send "b" }; move p; send "c"; hold 30ms; '
                           'loop { wait "x"; send "d"; send "e" } }\n')
    assert send_run(fe.plan) == 3               # a, b, b before the first frame
    assert send_gap(fe.plan, 100) == 1          # d e, one frame (the wait), d e again
    fe, _ = front_end_text('serial 4800\nservo arm = P1.0\npose p { arm: 100 }\n'
                           'main { move p; send "c"; hold 30ms; send "d"; select { on "x" { send "e" }; after 1s { } } }\n')
    assert send_run(fe.plan) == 2               # d, then e at once if "x" is already there
    assert send_gap(fe.plan, 100) == 6          # c, the hold's 6 frames, d
    assert send_gap(fe.plan, 3) == 3
    fe, _ = front_end_text('serial 4800\nservo arm = P1.0\npose p { arm: 100 }\n'
                           'main { move p; loop { wait "x"; send "d"; send "e" } }\n')
    assert send_run(fe.plan) == 2               # a pass that took no frame waits for one before the next
    assert send_gap(fe.plan, 100) == 1


def test_the_serial_handler_is_in_the_budget():
    """The serial handler's head and runs are read from the code, and the same code's shortest
    period with them is longer than without them by at least their load in one frame."""
    with_serial = build_text(ARM.replace("main {", "frame 20ms\nmain {"))
    budget = with_serial.firmware.unit.budget
    assert budget.serial_head == 2 + 2 + 2 + 1      # LCALL (the handler is at its vector), JNB RI, MOV RXB,SBUF, CLR RI
    assert budget.serial_run > budget.serial_head
    assert budget.byte_cycles == byte_cycles(*timer1_baud(with_serial.plan.program.target, 4800)[:2]) == 2080
    late = costs.serial_latency(with_serial.plan.program.target, budget)
    assert late < budget.byte_cycles
    assert 4800 in working_bauds(with_serial.plan.program.target)
    assert costs.max_nesting(True) == 5 and costs.max_nesting() == 15
    hexapod = build_text(HEXAPOD).firmware.unit
    target, budget = hexapod.target, hexapod.budget
    quiet = dataclasses.replace(budget, serial_run=0, serial_head=0, byte_cycles=0)
    slower, plain = costs.frame_cycles(target, budget), costs.frame_cycles(target, quiet)
    assert slower > plain       # the hexapod's work binds: the serial handler's runs make it longer
    # 24 servos with `serial` keep one sort buffer: the work after the last sort binds, in the window
    # from the second port's rise to the first port's next one, with every run that can come in it
    assert not budget.last_in_b
    window = slower - budget.spans[0]
    loaded = dataclasses.replace(quiet, work=quiet.work + costs.serial_load(target, budget, window))
    assert slower == costs.frame_cycles(target, loaded)


def test_sends_at_the_limit_verify():
    """Two bytes at 1200 baud (8.3 ms each) every 4 frames is the closest the send check allows
    for this program (3 frames is refused); run in ucsim, every byte is sent, in order, in time."""
    def text(ms: int) -> str:
        return ("serial 1200\nservo arm = P1.0 speed 0.05s/60deg\npose p { arm: 100 }\npose q { arm: 110 }\n"
                f'main {{ loop {{ move p in {ms}ms; send "a"; send "b"; move q in {ms}ms; send "c"; send "d" }} }}\n')
    fe, diags = front_end_text(text(16))
    assert fe.plan is not None and send_gap(fe.plan, 10) == 3
    with pytest.raises(AssertionError, match="send-overrun"):
        build_text(text(16))
    built = build_text(text(21))
    assert send_gap(built.plan, 10) == 4 and send_run(built.plan) == 2
    report = api.verify(built.plan, built.firmware, 300)
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert report.bytes_sent >= 140


@pytest.mark.parametrize("count, queue, head", [(7, 8, "serial 4800"), (20, 32, "serial 4800"),
                                               (12, 16, "target stc89c52rc clock 11.0592MHz mode 6T\nserial 9600"),
                                               (5, 8, "target at89c52 clock 22.1184MHz\nserial 19200")])
def test_a_long_run_of_sends_has_a_queue_of_its_size_and_every_byte_goes_out(count, queue, head):
    """`count` sends with no frame between them, in a loop with time enough for the line: the
    transmit queue is sized to the run (a power of two), every byte goes out in order in ucsim, and
    a run past the longest queue is refused."""
    def text(n: int) -> str:
        return (head + "\nservo arm = P1.0\npose p { arm: 100 }\npose q { arm: 120 }\n"
                "main {\n  loop {\n    move p in 100ms\n" + "".join(f'    send {65 + k % 26}\n' for k in range(n))
                + "    move q in 100ms\n  }\n}\n")
    from servoc.flow import TX_MOST, tx_queue
    built = build_text(text(count))
    assert send_run(built.plan) == count and tx_queue(built.plan) == queue
    assert re.search(rf"^TXQ\s+= 0x[0-9A-F]+\s+; the transmit queue$", built.firmware.unit.text, re.M)
    report = api.verify(built.plan, built.firmware, 200)
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert report.bytes_sent >= 2 * count
    _, diags = front_end_text(text(TX_MOST + 1))
    assert [d.code for d in diags if d.is_error] == ["send-overrun"]


def deep_serial_source(depth: int) -> str:
    """`depth` sequences, each playing the one below, with the serial line busy at the deepest one:
    the innermost move's F differs between passes (found at run time, a call deeper still), it
    sends a byte, and bytes come in. The servo is on P0.0, whose motion state lies just above the
    stack: an overflow would change its pulses."""
    text = ("serial 4800\nservo a = P0.0 speed 0.005s/60deg\nservo b = P1.7\nservo c = P2.7\n"
            "pose p { a: 10, b: 50, c: 50 }\npose q { a: 200 }\n"
            'sequence q0 {\n  move p\n  send "s"\n  move q\n}\n')
    for i in range(1, depth):
        text += f"sequence q{i} {{\n  play q{i - 1}\n}}\n"
    return text + f"main {{\n  loop {{ play q{depth - 1} }}\n}}\n"


def test_deepest_nesting_with_serial_runs_with_bytes_coming():
    """Nested exactly as deep as `serial` leaves stack for: one level more is `too-deep`; at the
    limit, with a byte coming every 7.3 frames at shifting phases, every pulse is exact and
    every byte is sent. (The handlers' share of the bound, the edge handler and the serial
    handler on top of the deepest call at once, is counted from the code, not forced here.)"""
    depth = costs.max_nesting(serial=True)
    _, diags = front_end_text(deep_serial_source(depth + 1))
    assert [d.code for d in diags if d.is_error] == ["too-deep"]
    text = deep_serial_source(depth)
    built = build_text(text)
    assert built.firmware.unit.stack_bytes <= costs.stack_room(serial=True) < costs.stack_bytes(depth + 1, True)
    assert any(inst.step.frames is None for inst in built.plan.moves), "the run-time F path is not used"
    frames = 300
    scenario = "\n".join(f'{round((20 + 7.3 * k) * built.plan.period_us)}us "z"' for k in range(38))
    plan, trace, evs, report = run(text, scenario, frames)
    assert report.ok, [str(m) for m in report.mismatches[:5]]
    assert report.bytes_sent >= 40 and set(sent(trace)) == {"s"}


def test_the_variables_named_directly_stay_below_0x80():
    """Direct addresses 0x80.. are the SFRs: with 24 servos, the serial line and a meanwhile body,
    the variables the code names directly end below 0x80 and only the buffers reached through
    @R0/@R1 (the handler's items, the queues) may go past it."""
    text = build_text(HEXAPOD).firmware.unit.text
    equ = {m[1]: int(m[2], 16) for m in re.finditer(r"^(\w+)\s+=\s+0x([0-9A-F]+)\s+;", text, re.M)}
    assert all(equ[name] < 0x80 for name in ("WID0", "WSP0", "LPTR", "RXW", "RXR", "RXB", "EMC", "SRT"))
    assert equ["RXQ"] + costs.QUEUE + 1 <= equ["STACK"]     # the receive ring (a slot more) below the stack
    ram = layout.RamAllocator(0x90)
    ram.next = 0x7E
    ram.alloc("A", 2, "fits")
    with pytest.raises(layout.RamFull):
        ram.alloc("B", 1, "named directly past 0x7F")
    ram = layout.RamAllocator(0x90)
    ram.next = 0x7E
    assert ram.alloc("C", 8, "a buffer", direct=False) == 0x7E and ram.next == 0x86


@pytest.mark.toolchain
def test_the_fastest_rate_at_11_0592_mhz_holds_its_period_under_bursts():
    """6 servos at 11.0592 MHz take 14400 baud; at the shortest period the budget gives them
    (the pulses alone, 7861 µs: the serial handler's runs charged once to each window), eight
    bursts of four bytes at eight phases are all answered and every pulse is exact. (The select
    finds the next byte already queued when a move ends: it waits no frame.)"""
    servos = [f"s{p}{b}" for p in range(3) for b in range(2)]
    text = "target stc89c52 clock 11.0592MHz\nserial 14400\n"
    text += "".join(f"servo {s} = P{s[1]}.{s[2]} speed 0.05s/60deg\n" for s in servos)
    text += "pose lo { " + ", ".join(f"{s}: {20 + 14 * int(s[2])}" for s in servos) + " }\n"
    text += "pose hi { " + ", ".join(f"{s}: {250 - 14 * int(s[2])}" for s in servos) + " }\n"
    text += answering()
    built = build_text(text)
    assert built.plan.period_us == built.plan.min_period_us
    lines = [f'{60 + 800 * k + 0.53 * k:.3f}ms "h" "l" "h" "l"' for k in range(8)]
    plan, trace, evs, report = run(text, "\n".join(lines) + "\n", int(7_000_000 / built.plan.period_us))
    assert report.ok, [str(m) for m in report.mismatches[:3]]
    assert sent(trace) == "HLHL" * 8


@pytest.mark.toolchain
@pytest.mark.parametrize("clock", ["", "target stc89c52 clock 11.0592MHz\n"])
def test_a_program_that_never_sends_is_charged_for_received_bytes_only(clock):
    """Without a `send` TI is never set, so the serial handler runs only for bytes received: 24
    servos at 4800 baud, eased moves (the work, with the runs that can come in its window, sets
    the answering program's period), bytes back to back in bursts. Without and with a `send`, each at the shortest
    period the budget gives it (shorter without), every pulse is exact and every byte taken."""
    def program(reply: str) -> str:
        servos = [f"s{p}{b}" for p in range(3) for b in range(8)]
        text = clock + "serial 4800\n"
        text += "".join(f"servo {s} = P{s[1]}.{s[2]} speed 0.05s/60deg\n" for s in servos)
        text += "pose lo { " + ", ".join(f"{s}: {20 + 14 * int(s[2])}" for s in servos) + " }\n"
        text += "pose hi { " + ", ".join(f"{s}: {250 - 14 * int(s[2])}" for s in servos) + " }\n"
        return text + ('main {\n  move lo\n  loop {\n    select {\n'
                       f'      on "h" {{ move hi in 150ms ease in-out{reply} }}\n      on "l" {{ move lo in 150ms ease in-out }}\n'
                       '    }\n  }\n}\n')
    quiet, answering = build_text(program("")), build_text(program('; send "H"'))
    assert not quiet.firmware.unit.budget.serial_sends and answering.firmware.unit.budget.serial_sends
    assert quiet.plan.min_period_us < answering.plan.min_period_us
    target = quiet.plan.program.target
    pulses = 3 * costs.port_span(target, 250, quiet.firmware.unit.budget.steps)     # machine cycles
    lines = [f"{60 + 700 * k + 1.07 * k:.3f}ms \"h\" \"l\" \"h\" \"l\"" for k in range(4)]
    assert target.cycles(answering.plan.min_period_us) > pulses        # the work and its serial runs set it
    for reply, built in (("", quiet), ('; send "H"', answering)):
        assert built.plan.period_us == built.plan.min_period_us and target.cycles(built.plan.min_period_us) >= pulses
        plan, trace, evs, report = run(program(reply), "\n".join(lines) + "\n", int(3_000_000 / built.plan.period_us))
        assert report.ok, (reply, [str(m) for m in report.mismatches[:3]])
        assert report.pulses > 0
        assert sent(trace) == ("H" * 8 if reply else "")


@pytest.mark.toolchain
@pytest.mark.parametrize("clock, build", [("", "last_in_b"), ("target stc89c52rc clock 11.0592MHz", "stagger")])
def test_24_servos_that_only_receive_hold_the_pulses_alone_under_bursts(clock, build):
    """A program that never sends has no transmit side (queue, counters, TI path): the RAM that
    leaves is enough for sort buffer B above the stack of the benchmark's stress program (every
    servo moving every frame, repeats four deep), so at 12 MHz its shortest period is the pulses
    alone, one port after another; at 11.0592 MHz the build with each port's rise among the falls
    of the port before is shorter still. There every pulse is exact while 4 bytes come back to
    back every 9 ms."""
    period = bench.budget_period(3, 8, target=clock, serial=True)
    built = build_text(bench.stress_source(3, 8, period, target=clock, serial=True))
    unit = built.firmware.unit
    assert getattr(unit.budget, build) and not unit.budget.serial_sends
    assert "TXQ" not in unit.text and "ui_send" not in unit.text and "send_byte" not in unit.text
    target = built.plan.program.target
    assert target.cycles(period) <= 3 * costs.port_span(target) + 1 and built.plan.period_us == period
    assert bench.serial_exact_at(3, period, clock, frames=120)
    pulses = sum(unit.budget.spans) if unit.budget.stagger else target.cycles(period)
    assert not bench.serial_exact_at(3, int(pulses * target.cycle_us) - 60, clock, frames=120)   # the ladder can fail


def test_a_run_counts_in_a_window_only_if_it_can_still_be_going_on():
    """The runs charged to a window of c cycles: ceil(c / gap) + 1, or fewer when each byte's run
    surely ends within `run_reach` of it (the edge handler's longest stretch, then the run, with
    the gap after each rise long enough for it); with a rise that leaves too short a gap, the
    plain count. The gap is `rx_gap`: a byte time of a host 2 % fast, less the start-bit jitter."""
    built = build_text("target stc89c52rc clock 11.0592MHz\nserial 4800\n"
                       + "".join(f"servo s{b} = P1.{b}\n" for b in range(8))
                       + "pose p { " + ", ".join(f"s{b}: {30 * b}" for b in range(8)) + " }\nmain { move p }\n")
    target, budget = built.plan.program.target, built.firmware.unit.budget
    run = budget.serial_run + costs.SERIAL_WAIT
    reach = costs.run_reach(target, budget)
    gap = costs.rx_gap(budget.byte_cycles)
    assert gap == 1869 and budget.byte_cycles == 1920      # 4800 baud at 11.0592 MHz: 1881 - 12
    assert reach == costs.busy_stretch(target, budget) + run < gap
    window = 2 * gap - reach                         # two bytes' runs at most, not three
    assert costs.serial_load(target, budget, window) == 2 * run
    assert costs.serial_load(target, budget, window + 1) == 3 * run
    slow_rise = dataclasses.replace(budget, rises=(target.width_cycles(0) - run + 1,))
    assert costs.run_reach(target, slow_rise) is None
    assert costs.serial_load(target, slow_rise, window) == 3 * run


FLAG_WRITERS = {"ADD", "ADDC", "SUBB", "CJNE", "RLC", "RRC", "DA", "MUL", "DIV"}


def _isr_paths(text: str) -> tuple[list[list[str]], list[str]]:
    """The serial handler's two runs, as their instructions in order: taking a byte (uart_isr to
    its first RETI) and sending one (ui_send to its RETI), from the generated assembly."""
    lines = [re.sub(r";.*$", "", raw).strip() for raw in text.splitlines()]
    start = next(i for i, s in enumerate(lines) if s.startswith("uart_isr:"))
    run, runs = [], []
    for s in lines[start:]:
        s = re.sub(r"^\w+:\s*", "", s)
        if not s:
            continue
        run.append(s)
        if s.split()[0] == "RETI":
            runs.append(run)
            run = []
            if len(runs) == 3:
                break
    return runs


@pytest.mark.parametrize("sends, host", [(False, False), (True, False), (True, True)])
def test_the_serial_handler_s_run_that_takes_a_byte_changes_no_flag(sends, host):
    """The handler saves PSW only in the run that sends: the run that takes a byte must change no
    flag (no arithmetic, no carry), since the background it interrupts may hold one; it is at its
    vector (0x0023: no jump to it) and saves ACC and bank 0's R0 around what it uses. With `host`
    that run includes marking the newest byte 0xFF when the queue is full (a CJNE there once set
    the carry of the move it interrupted)."""
    text = ("target stc89c52rc clock 11.0592MHz\nserial 9600\n" + ("host ssc32\n" if host else "")
            + "servo a = P1.0\npose p { a: 10 }\n"
            + ('main { move p; host }\n' if host else
               'main { move p; loop { wait "x"; send "y" } }\n' if sends else 'main { move p; loop { wait "x" } }\n'))
    unit = build_text(text).firmware.unit
    assert re.search(r"\.org\s+0x0023[^\n]*\n(;[^\n]*\n)*uart_isr:", unit.text)
    take = _isr_paths(unit.text)[0]
    ops = [s.split()[0] for s in take]
    assert not FLAG_WRITERS & set(ops), take
    assert not any(re.search(r"\b(C|PSW|CY)\b", s.split(None, 1)[1]) for s in take if " " in s), take
    assert ops[:5] == ["JNB", "MOV", "CLR", "PUSH", "PUSH"] and ops[-3:] == ["POP", "POP", "RETI"]
    if sends:       # the run that sends may use the carry: it saves PSW first
        send = next(r for r in _isr_paths(unit.text)[1:] if any("SBUF, @R0" in s for s in r))
        assert send[send.index(next(s for s in send if s.startswith("PUSH"))):][0] == "PUSH    PSW"


def test_send_overrun_names_the_shortest_period_at_which_the_sends_fit():
    """1 us below the shortest period lint reports, the runs of sends no longer fit: `send-overrun`
    refuses the program, and its help names that shortest period as a `frame` to use."""
    text = 'serial 4800\ninput b = P3.2\nservo a = P1.0\npose p { a: 100 }\nhome p\nmain { move p; loop { wait press b; send "x" } }\n'
    fe, _ = front_end_text(text)
    shortest = fe.plan.min_period_us
    _, diags = front_end_text(f"frame {shortest - 1}us\n" + text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "send-overrun" and f"`frame {shortest / 1000:g}ms` or longer" in d.help, d.help
    _, diags = front_end_text(f"frame {shortest}us\n" + text)
    assert not [d for d in diags if d.is_error]


def _docs_text() -> str:
    """docs/language.md, its whitespace one space."""
    return " ".join((Path(__file__).resolve().parent.parent / "docs" / "language.md").read_text(encoding="utf-8").split())


def test_the_shortest_period_is_found_where_the_code_built_below_it_cannot_hold_its_sends():
    """8 servos on two ports at once (11.0592 MHz 6T, 9600 baud), a select whose `on "b"` sends a
    byte each frame: the code built for 20 ms holds 2.18 ms, but the code built for that period has
    more work between frames, so its sends need longer (`send-overrun`, which names the period from
    which that code holds them). The search for the shortest period (api._least_period) goes there
    at once, not 1 us at a time until it gives up and reports P itself: lint at `frame 20ms` and by
    default reports it, `frame P` builds, 1 us less is refused naming P, and at P every pulse and
    byte sent is exact in ucsim with a byte asking for a send in every frame of a run."""
    names = [f"s{i}" for i in range(8)]
    body = ("target stc89c52rc clock 11.0592MHz mode 6T\nserial 9600\n"
            + "".join(f"servo s{i} = P{1 + i % 2}.{i // 2}\n" for i in range(8)) + "input btn = P3.2\n"
            + "pose q0 { " + ", ".join(f"{s}: 16" for s in names) + " }\n"
            + "pose q2 { " + ", ".join(f"{s}: {95 if i % 2 else 57}" for i, s in enumerate(names)) + " }\n"
            + 'main { move q0; loop { select { on press btn { move q2 in 1070ms ease in-out; move q2 in 1018ms } '
              'on "a" { move q0 in 1113ms } on "b" { send "z" } after 3s { move q2 in 998ms } } } }\n')
    fe, _ = front_end_text("frame 20ms\n" + body)
    reported = fe.plan.min_period_us
    assert fe.plan.ports_at_once and reported < 2500
    assert codegen.generate(fe.plan).min_period_us < reported       # the code built for 20 ms holds less
    assert front_end_text(body)[0].plan.min_period_us == reported
    at, diags = front_end_text(f"frame {reported}us\n" + body)
    assert at.plan.min_period_us == reported and not [d for d in diags if d.is_error]
    _, diags = front_end_text(f"frame {reported - 1}us\n" + body)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "send-overrun" and f"`frame {reported / 1000:g}ms` or longer" in d.help, d.help
    scenario = ("".join(f'{0.4 + 0.3 * k:.1f}s "b" "b" "b" "b"\n' for k in range(3)) + '1.1s "a"\n'
                + "".join(f'{1.3 + 0.3 * k:.1f}s "b" "b" "b" "b"\n' for k in range(3)) + "2.5s btn active\n2.6s btn inactive\n")
    frames = 1600
    plan, evs, trace = simulate_events(f"frame {reported}us\n" + body, scenario, frames)
    report = api.check_events(plan, trace, frames, evs)
    assert_exact(report)
    assert report.bytes_sent >= 12


def test_where_the_sends_bind_at_20ms_the_shortest_period_is_searched_from_what_the_rest_of_the_code_holds():
    """A 37 ms hold before four bytes at 1200 baud: at 20 ms the hold is two frames and the sends
    need 16.968 ms, at 5 ms it is seven and they fit easily. The shortest period reported at `frame
    20ms` is the default's, the least P whose own code holds it, not the fixed point near the code
    for 20 ms; `frame P` builds, 1 us less is refused, and at P the pulses and the bytes sent after
    each hold are exact in ucsim."""
    body = ("target stc89c52rc clock 11.0592MHz mode 6T\nserial 1200\nservo a = P1.1\nservo b = P1.4\n"
            "input btn = P3.2\npose q0 { a: 63, b: 58 }\npose q2 { a: 250, b: 250 }\n"
            'main { move q0; loop { select { on press btn { move q2; hold 9ms } '
            'on "a" { hold 37ms; send "z"; send "z"; send "z"; send "z" } on "b" { move q0 } } } }\n')
    fe, _ = front_end_text("frame 20ms\n" + body)
    reported = fe.plan.min_period_us
    twenty = codegen.generate(fe.plan).min_period_us
    assert twenty > 15000 > 3000 > reported     # the code for 20 ms: sends bind
    assert (f"P_min is {reported / 1000:.3f} ms, not the {twenty / 1000:.3f} ms the code for 20 ms needs"
            in _docs_text())        # docs/language.md's example is this program
    assert front_end_text(body)[0].plan.min_period_us == reported
    at, diags = front_end_text(f"frame {reported}us\n" + body)
    assert at.plan.min_period_us == reported and not [d for d in diags if d.is_error]
    _, diags = front_end_text(f"frame {reported - 1}us\n" + body)
    assert [d.code for d in diags if d.is_error] == ["period-too-short"]
    frames = 1500
    plan, evs, trace = simulate_events(f"frame {reported}us\n" + body, '0.3s "a"\n0.8s "b"\n1.5s "a"\n2.4s "a"\n', frames)
    report = api.check_events(plan, trace, frames, evs)
    assert_exact(report)
    assert report.bytes_sent == 12


def test_the_shortest_period_is_bisected_where_each_builds_code_holds_another_period():
    """13 servos on two ports at once at 22.1184 MHz, 19200 baud, five bytes a frame apart: the
    code built for 3908 us holds its sends only from 4018 us, the code built for 4018 us holds
    3908 us. The search does not go back and forth between the two (and give up at the higher):
    the shortest period reported is the least between whose own code holds it; 1 us less is
    refused; at it every pulse and byte is exact in ucsim with a run of sends asked for each frame."""
    names = ("s00 = P0.0", "s01 = P0.1", "s02 = P0.2", "s04 = P0.4", "s06 = P0.6", "s07 = P0.7", "s10 = P1.0",
             "s11 = P1.1", "s12 = P1.2", "s13 = P1.3", "s15 = P1.5", "s16 = P1.6", "s17 = P1.7")
    servos = [n.split(" = ")[0] for n in names]
    pose = lambda k, ns: f"pose q{k} {{ " + ", ".join(f"{s}: {n}" for s, n in zip(servos, ns)) + " }\n"     # noqa: E731
    body = ("target at89c52 clock 22.1184MHz\nserial 19200\n" + "".join(f"servo {n}\n" for n in names)
            + "input btn = P3.2\n"
            + pose(0, (102, 102, 102, 103, 102, 103, 102, 103, 102, 102, 103, 103, 102))
            + pose(2, (157, 203, 203, 233, 157, 203, 203, 157, 157, 157, 217, 233, 217))
            + 'main { move q0; loop { select { on press btn { move q0 in 1007ms ease in-out; hold 17ms } '
              'on "a" { move q2 in 419ms; send "y"; send "z" } on "b" { send "x"; send "z"; send "y" } } } }\n')
    fe, _ = front_end_text("frame 20ms\n" + body)
    reported = fe.plan.min_period_us
    assert fe.plan.ports_at_once and 3908 < reported < 4018
    at, diags = front_end_text(f"frame {reported}us\n" + body)
    assert at.plan.min_period_us == reported and not [d for d in diags if d.is_error]
    _, diags = front_end_text(f"frame {reported - 1}us\n" + body)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "send-overrun", d
    frames = 1000
    scenario = "".join(f'{0.3 + 0.4 * k:.1f}s "b" "b" "b" "b"\n' for k in range(4)) + '2s "a"\n'
    plan, evs, trace = simulate_events(f"frame {reported}us\n" + body, scenario, frames)
    report = api.check_events(plan, trace, frames, evs)
    assert_exact(report)
    assert report.bytes_sent >= 24


@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n",
                                   "target stc89c52rc clock 11.0592MHz mode 6T\n"])
def test_the_shortest_period_of_a_program_whose_sends_bound_it_follows_the_frames_between_them(clock):
    """Runs of three bytes at 2400 baud with two 30 ms moves between them: the frames between the
    runs follow P, so the code built for 20 ms holds a longer period than the code built for a
    shorter one. The shortest period reported, at `frame 20ms` and by default, is the least P whose
    own code holds P (api._least_period): `frame P` builds, 1 us less is refused, and at P every
    pulse and every byte sent is exact in ucsim (at 12 MHz, and where a cycle is no whole us)."""
    body = (clock + 'serial 2400\nservo a = P1.0\nservo b = P1.1\npose lo { a: 0, b: 0 }\npose hi { a: 1, b: 1 }\n'
            'home lo\nmain { loop { send "x"; send "y"; send "z"; move hi in 30ms; move lo in 30ms } }\n')
    fe, _ = front_end_text("frame 20ms\n" + body)
    reported = fe.plan.min_period_us
    assert fe.plan.program.target.cycle_us == (1 if not clock else Fraction(15625, 14400 * (2 if "6T" in clock else 1)))
    twenty = codegen.generate(fe.plan).min_period_us
    assert twenty > reported      # the code built for 20 ms: fewer frames
    if not clock:       # docs/language.md's example
        assert f"the code built for 20 ms holds {twenty / 1000:.3f} ms, its own P_min is {reported / 1000:.3f} ms" in _docs_text()
    assert front_end_text(body)[0].plan.min_period_us == reported
    at, diags = front_end_text(f"frame {reported}us\n" + body)
    assert at.plan.min_period_us == reported and not [d for d in diags if d.is_error]
    _, diags = front_end_text(f"frame {reported - 1}us\n" + body)
    assert [d.code for d in diags if d.is_error] in (["period-too-short"], ["send-overrun"])
    built = build_text(f"frame {reported}us\n" + body)
    report = api.verify(built.plan, built.firmware, 400)
    assert report.ok and report.max_error_cycles == 0, [str(m) for m in report.mismatches[:5]]
    assert report.bytes_sent >= 12
