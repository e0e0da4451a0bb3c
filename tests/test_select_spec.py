"""The spec's select rules, frame by frame in ucsim.

A select looks at its events as soon as it is reached: an event already
there starts its branch in the very next frame (the select takes no frame of
its own); a loop pass that took no frame waits for the next frame before it
repeats. Each test states the branches taken (`plan.Choice`) from the timing
of its events and checks every pulse and byte sent against `plan.expand` of
exactly that run, so a select that spent a frame it should not fails it.
"""

from __future__ import annotations

import pytest

from conftest import build_text, simulate_events
from servoc import api, events, plan as plan_mod, verify
from servoc.plan import Choice
from servoc.target import byte_cycles

pytestmark = pytest.mark.toolchain

HEAD = """\
serial 4800
frame 6ms
servo arm = P1.0
pose lo { arm: 20 }
pose hi { arm: 22 }
pose mid { arm: 30 }
"""


def simulate(text: str, scenario: str, frames: int):
    plan, _, trace = simulate_events(text, scenario, frames)
    return plan, trace


def exact(plan, trace, frames: int, choices: tuple) -> verify.VerifyReport:
    report = verify.verify(plan, trace, frames, choices)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:5]])
    return report


def test_an_event_already_there_starts_its_branch_in_the_next_frame():
    # "x" arrives during the hold; the select after it takes it at once: the move to `hi` is the
    # frame right after the hold's last. One frame spent by the select would put a frame of `lo`
    # between them, and the pulses would not match.
    text = HEAD + 'main {\n  move lo\n  hold 120ms\n  wait "x"\n  move hi\n  move lo\n}\n'
    plan, trace = simulate(text, '30ms "x"\n', 60)
    exact(plan, trace, 60, (Choice(0, 0),))
    with pytest.raises(AssertionError):
        exact(plan, trace, 60, (Choice(0, 1),))


def test_select_waits_a_frame_at_a_time_when_nothing_is_there():
    # Nothing queued when the select is reached: it waits frames (targets repeating) until "x".
    text = HEAD + 'main {\n  move lo\n  wait "x"\n  move hi\n}\n'
    plan, trace = simulate(text, '300ms "x"\n', 90)
    t1 = verify.first_rise_us(plan, trace)
    arrival = events.byte_arrivals(events.parse('300ms "x"\n', (), True),
                                   byte_cycles(plan.program.serial.th1, plan.program.serial.smod),
                                   plan.program.target)[0][0]
    lead = verify.first_pulse_frame(plan) or 0
    # move lo takes 1 frame; the select is reached right after it; the byte is seen at the first
    # look after it arrives: `waited` frames after the select was reached
    reached_us = t1 + (1 - lead) * plan.period_us
    waited = [w for w in range(0, 80) if verify.verify(plan, trace, 90, (Choice(0, w),)).ok]
    assert len(waited) == 1, waited
    first_rise = reached_us + waited[0] * plan.period_us        # the branch's first frame's rise
    assert 0 < first_rise - arrival <= 2 * plan.period_us


def test_a_loop_of_select_and_one_frame_moves_keeps_up_with_a_byte_a_frame():
    # The host sends one byte every frame for 100 frames; each pass takes one byte and makes one
    # frame: nothing is lost, nothing queues up.
    text = HEAD + ('main {\n  move lo\n  loop {\n    select {\n'
                   '      on "a" { move hi in 6ms; send "A" }\n'
                   '      on "b" { move lo in 6ms; send "B" }\n    }\n  }\n}\n')
    seq = "ab" * 50
    scenario = "".join(f'{100 + 6 * k}ms "{c}"\n' for k, c in enumerate(seq))
    plan, trace = simulate(text, scenario, 140)
    got = "".join(chr(b) for _, b in trace.sent)
    assert got == seq.upper(), got
    # every pass is one frame: the widths alternate hi, lo, hi, ... for 100 frames in a row
    hi, lo = (plan.program.target.width_cycles(n) for n in (22, 20))
    widths = [w for _, w in trace.pulses(1, 0)]
    start = widths.index(hi)
    assert widths[start:start + 100] == [hi, lo] * 50, widths[start:start + 100]


def test_a_loop_pass_that_takes_no_frame_waits_for_the_next():
    # Four bytes queued while the first move runs: `loop { wait "a"; send "b" }` answers them
    # one a frame, never two in one frame.
    text = HEAD + 'main {\n  move lo in 120ms\n  loop {\n    wait "a"\n    send "b"\n  }\n}\n'
    plan, trace = simulate(text, '10ms "a" "a" "a" "a"\n', 40)
    starts = [t for t, b in trace.sent if b == ord("b")]
    assert len(starts) == 4
    period = plan.program.target.cycles(plan.period_us)
    gaps = [b - a for a, b in zip(starts, starts[1:])]
    assert all(abs(g - period) <= byte_cycles(plan.program.serial.th1, plan.program.serial.smod)
               for g in gaps), (gaps, period)
    exact(plan, trace, 40, (Choice(0, 0),) * 4)


def test_expand_follows_the_loop_rule():
    built = build_text(HEAD + 'main {\n  move lo\n  loop {\n    wait "a"\n    send "b"\n  }\n}\n')
    frames = list(__import__("itertools").islice(plan_mod.expand(built.plan, (Choice(0, 0),) * 3), 6))
    assert [f.sent for f in frames] == [(), (98,), (98,), (98,), (), ()]


def test_the_six_command_serial_arm_answers_every_command():
    # examples/serial_arm.servo at 11.0592 MHz and 9600 baud: every command answered in order,
    # the unknown byte dropped, four commands back to back queued and run in turn
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent
    text = (root / "examples/serial_arm.servo").read_text(encoding="utf-8")
    scenario = (root / "examples/events/serial_arm.events").read_text(encoding="utf-8")
    frames = 2000                                       # 10.6 s: every reply is out by then
    plan, evs, trace = simulate_events(text, scenario, frames)
    assert "".join(chr(b) for _, b in trace.sent) == "RLPRDWH"
    report = api.check_events(plan, trace, frames, evs)
    assert report.ok and report.bytes_sent == 7, (report.summary(), [str(m) for m in report.mismatches[:4]])
