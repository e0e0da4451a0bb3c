"""Inputs and selects in the firmware, run in ucsim with timed input levels.

Each scenario drives the program's inputs (`servoc verify --events`): the branch
the firmware takes at each select is read from the trace, every pulse must
then match the plan of that run exactly, and each `on` branch must start
within 2 P of its input becoming active (or of the select beginning to wait,
if the input was active already).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import build_text, simulate_events
from servoc import api, cli, codegen, events, verify

pytestmark = pytest.mark.toolchain

ROOT = Path(__file__).resolve().parent.parent

TWO = """\
input left = P3.2
input right = P3.3 high
servo arm = P1.0
servo leg = P2.4
pose home { arm: 20, leg: 20 }
pose l { arm: 230, leg: 40 }
pose r { arm: 100, leg: 200 }
main {
  move home
  loop {
    select {
      on left { move l in 600ms; move home in 600ms }
      on right { move r in 600ms; hold 100ms; move home in 600ms }
      after 700ms { move r in 900ms; move home in 900ms }
    }
    wait left
    move l in 600ms
    move home in 600ms
  }
}
"""


def run(text: str, scenario: str, frames: int):
    plan, evs, trace = simulate_events(text, scenario, frames)
    return plan, trace, evs, api.check_events(plan, trace, frames, evs)


def delays(plan, trace, frames, evs) -> list[float]:
    """Event to the first rise of the branch it started, in ms, for every `on` taken."""
    found = verify.event_delays(plan, trace, evs)
    assert all(delay is not None for _, _, delay in found)
    return [delay / 1000 for _, _, delay in found]


SCENARIOS = {
    "nothing": "",
    "left soon": "50ms left active\n200ms left inactive\n1.5s left active\n1.6s left inactive\n",
    "right, then left held": "300ms right active\n450ms right inactive\n2.2s left active\n4s left inactive\n",
    "both at once": "1s left active\n1s right active\n1.3s left inactive\n1.3s right inactive\n"
                    "3.1s left active\n3.2s left inactive\n",
    "short blips": "".join(f"{t}ms left active\n{t + 6}ms left inactive\n" for t in range(100, 3000, 137)),
}


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scenarios_verify_exactly(name):
    plan, trace, evs, report = run(TWO, SCENARIOS[name], 900)
    assert report.ok and report.max_error_cycles == 0, (name, report.summary(), [str(m) for m in report.mismatches[:4]])
    assert all(d <= 2 * plan.period_us / 1000 for d in delays(plan, trace, 900, evs))


def test_both_inputs_at_once_take_the_first_branch_written():
    plan, trace, evs, report = run(TWO, SCENARIOS["both at once"], 900)
    choices = verify.choices_of(trace.observation)
    assert report.ok
    taken = [c.branch for c in choices]
    assert 0 in taken and 1 not in taken[:2]     # `on left` is written first


def test_inverted_input_is_caught():
    """Firmware that reads `left` the wrong way round (JNB for JB) takes its branch while nobody
    presses: verify with no events fails."""
    built = build_text(TWO)
    text = built.firmware.unit.text
    assert "JB      P3.2," in text
    from dataclasses import replace
    unit = replace(built.firmware.unit, text=text.replace("JB      P3.2,", "JNB     P3.2,"))
    firmware = api.assemble(unit, api.Reporter(built.source))
    report = api.verify(built.plan, firmware, 400)
    assert not report.ok


def test_greeter_example_and_its_scenario(capsys):
    rc = cli.main(["verify", str(ROOT / "examples" / "greeter.servo"),
                   "--events", str(ROOT / "examples" / "events" / "greeter.events")])
    out = capsys.readouterr().out
    assert rc == 0 and ": OK: " in out


def test_events_file_errors(tmp_path, capsys):
    prog = tmp_path / "p.servo"
    prog.write_text(TWO)
    for text, message in [("1s door active\n", "`door` is not an input of the program (inputs: left, right)"),
                          ("1s left pressed\n", "say `active` or `inactive`"),
                          ('1s "w"\n', "the program declares no `serial`"),
                          ("soon left active\n", "is not `TIME NAME active|inactive`")]:
        ev = tmp_path / "e.events"
        ev.write_text(text)
        assert cli.main(["verify", str(prog), "--events", str(ev)]) == 2
        err = capsys.readouterr().err
        assert f"{ev}: line 1: " in err and message in err, err


@settings(max_examples=5, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.lists(st.tuples(st.integers(20, 4000), st.integers(3, 400), st.sampled_from(["left", "right"])),
                max_size=6))
def test_random_presses_verify_exactly(presses):
    lines = []
    for start, length, name in presses:
        lines += [(start, f"{start}ms {name} active"), (start + length, f"{start + length}ms {name} inactive")]
    scenario = "\n".join(text for _, text in sorted(lines)) + "\n"
    try:
        plan, trace, evs, report = run(TWO, scenario, 1000)
    except ValueError:          # two changes in one cycle: not a scenario the format can hold
        return
    assert report.ok, (scenario, report.summary(), [str(m) for m in report.mismatches[:4]])


def test_selects_verify_at_their_own_shortest_period():
    """The shortest period is read from the firmware with its selects (their checks are work
    between frames), and a run with presses holds it exactly."""
    fast = TWO.replace("servo arm = P1.0", "servo arm = P1.0 speed 0.0001s/60deg").replace(
        "servo leg = P2.4", "servo leg = P2.4 speed 0.0001s/60deg")
    built = build_text(fast)
    period = built.plan.min_period_us
    assert period == codegen.generate(built.plan).min_period_us
    at_min = f"frame {period}us\n" + fast
    plan, trace, evs, report = run(at_min, SCENARIOS["right, then left held"], 1500)
    assert plan.period_us == plan.min_period_us == period
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:4]])



def test_the_longest_after_the_firmware_counts():
    """An `after` of MAX_AFTER_FRAMES frames compiles (F + 1 checks fit 16 bits); one frame more is
    `too-long` in lint, before any firmware."""
    from conftest import front_end_text
    from servoc import layout
    base = ("frame 3ms\ninput b = P3.2\nservo a = P1.0\npose p {{ a: 10 }}\n"
            "main {{ move p; select {{ on b {{ move p }}; after {ms}ms {{ move p }} }} }}\n")
    most = base.format(ms=3 * layout.MAX_AFTER_FRAMES)
    built = build_text(most)
    assert built.firmware is not None
    select = next(st for st in built.plan.main if hasattr(st, "branches"))
    assert select.after.frames == layout.MAX_AFTER_FRAMES
    _, diags = front_end_text(base.format(ms=3 * (layout.MAX_AFTER_FRAMES + 1)))
    assert [d.code for d in diags if d.is_error] == ["too-long"]
