"""`servoc verify` watches the firmware: which branch each select took, at which look, with what
queued, is read from probes in ucsim, never guessed from the pulses. A firmware that does what the
spec says never fails; a firmware that does something else (branches swapped, a send removed, a
target one N off, a look a frame late) always does; and the report says what it did not check."""

from __future__ import annotations

import json
import re

import pytest
from hypothesis import HealthCheck, Phase, given, settings, strategies as st

from conftest import build_text
from servoc import api, events, toolchain
from servoc.cli import main

pytestmark = pytest.mark.toolchain


def watch(built, scenario: str, frames: int, firmware=None):
    """Run `firmware` (default: the one built) driven by `scenario`, watched by its probes, and
    check it against `built`'s plan: the report."""
    plan = built.plan
    fw = firmware or built.firmware
    evs = events.parse(scenario, plan.program.inputs, plan.program.serial is not None)
    stim = api.stimulus(plan, evs)
    cycles = max(api.cycles_needed(plan, frames), stim.last() + 1)
    for _ in range(2):
        trace = api.simulate(fw.hex_text, cycles, plan.program.target, stim, api.probes(fw))
        choices, report = api.events_report(plan, trace, frames, evs)
        if api.cycles_needed(plan, frames, choices) <= trace.cycles:
            break
        cycles = api.cycles_needed(plan, frames, choices)
    return trace, report


def rebuilt(built, asm: str) -> api.Firmware:
    """`built`'s firmware with its assembly text changed."""
    import dataclasses
    unit = dataclasses.replace(built.firmware.unit, text=asm)
    return dataclasses.replace(built.firmware, unit=unit, image=toolchain.assemble(asm))


def cli_verify(tmp_path, capsys, text: str, scenario: str | None, *more: str) -> tuple[int, dict | str]:
    prog = tmp_path / "p.servo"
    prog.write_text(text)
    args = ["verify", str(prog)]
    if scenario is not None:
        ev = tmp_path / "p.events"
        ev.write_text(scenario)
        args += ["--events", str(ev)]
    if "--text" in more:
        rc = main(args + [m for m in more if m != "--text"])
        out = capsys.readouterr()
        return rc, out.out + out.err
    rc = main(args + ["--format", "json"] + list(more))
    out = capsys.readouterr()
    return rc, (json.loads(out.out) if out.out.strip() else out.err)


def problems(report) -> str:
    return "\n".join(str(m) for m in report.mismatches[:8])


# ---------------------------------------------------------------- what was wrong before

NOTHING_CHANGES = """\
target at89c52 clock 11.0592MHz
serial 9600
servo a = P1.0
servo b = P1.1
pose p0 { a: 40, b: 50 }
pose same_a { a: 40 }
pose same_b { b: 50 }
main {
  move p0 in 100ms
  loop {
    select {
      on "a" { move same_a in 700ms; send "A" }
      on "b" { move same_b in 700ms; send "B" }
    }
  }
}
"""


def test_a_branch_whose_first_move_changes_nothing_is_checked(tmp_path, capsys):
    built = build_text(NOTHING_CHANGES)
    trace, report = watch(built, '0.4s "a"\n3s "b"\n', 800)
    assert report.ok, problems(report)
    assert [b for _, b in trace.sent] == [ord("A"), ord("B")]
    assert [r.branch for r in report.reactions] == ['on "a"', 'on "b"']
    rc, data = cli_verify(tmp_path, capsys, NOTHING_CHANGES, '0.4s "a"\n3s "b"\n')
    assert rc == 0 and data["ok"] and data["bytes_sent"] == 2, data


def test_branches_whose_first_byte_is_the_same_are_told_apart(tmp_path, capsys):
    text = ("target at89c52 clock 11.0592MHz\nserial 300\nservo a = P1.0\npose p0 { a: 10 }\n"
            'main {\n  move p0 in 100ms\n  select {\n    on "s" { send "P" }\n    on "t" { send "P"; send "R" }\n'
            "  }\n}\n")
    rc, data = cli_verify(tmp_path, capsys, text, '0.5s "t"\n')
    assert rc == 0 and data["ok"], data
    assert [s["branch"] for s in data["selects"]] == ['on "t"'] and data["bytes_sent"] == 2
    assert any('`on "s"` never taken' in n for n in data["not_checked"]) and data["partial"]


CLOCKED = """\
target stc89c52rc clock 11.0592MHz
serial 9600
input btn = P3.2
servo a = P1.0
pose lo { a: 30 }
pose hi { a: 100 }
main {
  move lo in 100ms
  loop {
    select {
      on btn { move hi in 300ms; move lo in 300ms }
      on "x" { move hi in 200ms; send "X"; move lo in 200ms }
    }
  }
}
"""


def test_time_is_counted_in_the_firmwares_cycles_over_a_long_run():
    """At 11.0592 MHz the period is 4884 cycles = 5299.479 µs, not 5300: a clock of 5300 µs would
    lose 0.5 ms every 5 s. Events late in a 31 s run are timed exactly."""
    built = build_text(CLOCKED)
    period = built.plan.program.target.cycles(built.plan.period_us)
    assert period == 4884
    scenario = ("3s \"x\"\n4.9986s btn active\n5.2s btn inactive\n"
                "29.0013s btn active\n29.2s btn inactive\n30s \"x\"\n")
    trace, report = watch(built, scenario, 5900)
    assert report.ok, problems(report)
    assert [r.branch for r in report.reactions] == ['on "x"', "on btn", "on btn", 'on "x"']
    cycle = float(built.plan.program.target.cycle_us)
    byte = 960                      # a byte's 10 bits at 9600 baud: 96 cycles each at 11.0592 MHz
    for r, at, stop in zip(report.reactions, (3.0, 4.9986, 29.0013, 30.0), (byte, 0, 0, byte)):
        event = round(at * 1e6 / cycle) + stop      # the input's change, or the byte's stop bit
        assert 0 < r.cycle - event <= 2 * period + 2, (r, at)     # the rise, 2 P at most after the event
        assert (r.cycle - report.reactions[0].cycle) % period == 0   # on the frame grid, to the cycle


SLOW_ARM = """\
target at89c52 clock 11.0592MHz
serial 9600
servo a = P1.0 speed 2s/60deg
pose lo { a: 10 }
pose hi { a: 240 }
main {
  move lo in 100ms
  loop {
    select {
      on "a" { move hi; send "A" }
      on "b" { move lo; send "B" }
      on "c" { send "C" }
    }
  }
}
"""


def test_a_full_queue_drops_and_the_later_byte_is_taken(tmp_path, capsys):
    # "a" starts a long move; while no select looks, four bytes fill the queue, a fifth is dropped,
    # and a sixth comes once the first four are taken
    scenario = '0.5s "a"\n1s "c" "c" "c" "b"\n1.1s "a"\n9s "c"\n'
    built = build_text(SLOW_ARM)
    trace, report = watch(built, scenario, 3000)
    assert report.ok, problems(report)
    assert [r.branch for r in report.reactions] == ['on "a"', 'on "c"', 'on "c"', 'on "c"', 'on "b"', 'on "c"']
    assert sum("the queue already held 4 bytes" in w for w in report.warnings) == 1, report.warnings
    assert bytes(b for _, b in trace.sent) == b"ACCCBC"


SIX_JOINTS = """\
target stc89c52rc clock 11.0592MHz
serial 9600
servo base = P1.0
servo shoulder = P1.1
servo elbow = P1.2
servo wrist = P2.0
servo twist = P2.1
servo grip = P2.2
pose home { base: 120, shoulder: 120, elbow: 120, wrist: 120, twist: 120, grip: 120 }
pose p1 { base: 60, shoulder: 90 }
pose p2 { elbow: 60, wrist: 180 }
pose p3 { twist: 30, grip: 200 }
main {
  move home
  loop {
    select {
      on "1" { move p1 in 400ms; send "1" }
      on "2" { move p2 in 400ms; send "2" }
      on "3" { move p3 in 400ms; send "3" }
      on "h" { move home; send "H" }
    }
  }
}
"""


def test_six_commands_back_to_back_are_all_checked_to_their_end(tmp_path, capsys):
    rc, data = cli_verify(tmp_path, capsys, SIX_JOINTS, '1s "1" "2" "3" "h"\n1.5s "1" "2"\n')
    assert rc == 0 and data["ok"], data
    assert [s["branch"] for s in data["selects"]] == ['on "1"', 'on "2"', 'on "3"', 'on "h"', 'on "1"', 'on "2"'], data["warnings"]
    assert data["bytes_sent"] == 6 and not any("queued" in w or "dropped" in w for w in data["warnings"])
    assert data["not_checked"] == [] and "waiting at the select" in data["ended"]


# ---------------------------------------------------------------- saying what was not checked

WAITS_FIRST = """\
input btn = P3.2
servo a = P1.0
pose p0 { a: 0 }
pose p1 { a: 200 }
main {
  wait press btn
  move p0 in 100ms
  move p1 in 500ms
}
"""


def test_a_program_waiting_before_its_first_move_is_not_a_bare_ok(tmp_path, capsys):
    rc, out = cli_verify(tmp_path, capsys, WAITS_FIRST, None, "--text")
    assert rc == 0 and "OK (partial:" in out and re.search(r"line 7: never reached", out), out
    assert "when the run ended: waiting at the select at line 6 for `on press btn`" in out
    rc, data = cli_verify(tmp_path, capsys, WAITS_FIRST, "1s btn active\n1.2s btn inactive\n")
    assert rc == 0 and data["ok"] and not data["partial"] and data["pulses"] > 100, data
    assert 0 < data["selects"][0]["time_us"] - 1_000_000 <= 2 * 5300


def test_a_run_that_ends_in_a_loop_without_frames_says_the_loop(tmp_path, capsys):
    # each pass of the loop takes no frame (it sends a byte and waits for the next frame): the run
    # ends in the loop at line 6, not at the move before it nor at the `home` declaration
    for head, body in (("", "  move p\n"), ("home p\n", "")):
        text = f"serial 4800\nservo a = P1.0\npose p {{ a: 100 }}\n{head}main {{\n{body}  loop {{ send \"a\" }}\n}}\n"
        rc, out = cli_verify(tmp_path, capsys, text, None, "--text")
        line = text.splitlines().index('  loop { send "a" }') + 1
        assert rc == 0 and f"when the run ended: at line {line} (`loop {{ send \"a\" }}`)" in out, out


def test_a_loop_longer_than_the_span_and_a_short_frames_are_said(tmp_path, capsys, monkeypatch):
    from servoc import verify
    monkeypatch.setattr(verify, "MAX_SPAN_CYCLES", 3_000_000)
    text = ("servo a = P1.0\npose p { a: 10 }\npose q { a: 200 }\n"
            "main {\n  loop {\n    move p in 10s\n    move q in 10s\n  }\n}\n")
    rc, data = cli_verify(tmp_path, capsys, text, None)
    assert rc == 0 and data["ok"] and data["partial"], data
    assert any("line 5: a loop whose first pass did not end" in n for n in data["not_checked"])
    assert any("line 7: never reached" in n for n in data["not_checked"])
    rc, data = cli_verify(tmp_path, capsys, "servo a = P1.0\npose p { a: 10 }\npose q { a: 200 }\n"
                          "main {\n  move p in 2s\n  move q in 2s\n}\n", None, "--frames", "50")
    assert rc == 0 and data["partial"] and data["frames"] == 50 and abs(data["span_s"] - 50 * 0.0053) < 1e-6
    assert any("verify checked the first 50" in n for n in data["not_checked"]), data["not_checked"]


def test_every_events_file_fault_is_a_usage_error_with_its_line(tmp_path, capsys):
    for scenario, line in (('1s "a"\n1.0005s "b"\n', 2),           # the second starts before the first is through
                           ("1s nobody active\n", 1), ("2s \"a\"\n1s \"b\"\n", 2), ("1s ~\n", 1)):
        rc, err = cli_verify(tmp_path, capsys, NOTHING_CHANGES, scenario, "--text")
        assert rc == 2 and f"line {line}:" in err and "Traceback" not in err and "internal" not in err, err


def test_a_press_after_a_cut_select_is_one_no_select_waited_for(tmp_path, capsys):
    # the inner select waits in the outer one's meanwhile body; the first press takes the outer
    # branch and cuts the inner select; main then ends: the second press (100 ms, many frames long)
    # found no select waiting, not one it fell between two looks of
    text = ("input k = P3.2\nservo a = P1.0\npose p { a: 100 }\nhome p\nmain {\n  select {\n    on k { }\n"
            "    meanwhile {\n      select { on k { } meanwhile { hold 10s } }\n    }\n  }\n}\n")
    rc, data = cli_verify(tmp_path, capsys, text, "0.3s k active\n0.6s k inactive\n0.9s k active\n1.0s k inactive\n")
    assert rc == 0 and data["ok"], data
    assert any("0.9000 s" in w and "no select was waiting" in w for w in data["warnings"]), data["warnings"]
    assert not any("fell between two looks" in w for w in data["warnings"]), data["warnings"]


def test_statements_that_take_no_frame_are_reached_when_the_run_passes_them(tmp_path, capsys):
    # a repeat of a hold shorter than half a frame, and a play of an empty sequence: the run goes
    # through them (the move after them is checked), so they are not "never reached"
    text = ("servo a = P1.0\npose p { a: 10 }\npose q { a: 30 }\nsequence e { }\nsequence h { hold 1ms }\n"
            "main {\n  move p in 1ms\n  repeat 3 { hold 1ms; play h }\n  play e\n  move q in 53ms\n}\n")
    rc, data = cli_verify(tmp_path, capsys, text, None)
    assert rc == 0 and data["ok"] and not data["partial"] and data["not_checked"] == [], data
    rc, data = cli_verify(tmp_path, capsys, text.replace("  play e\n", "  loop { move p in 1s }\n  play e\n"), None)
    assert rc == 0 and any("never reached" in n and "play e" in n for n in data["not_checked"]), data["not_checked"]


def test_more_frames_than_the_simulators_clock_counter_holds_is_a_usage_error(tmp_path, capsys):
    from servoc import verify
    for frames in (10 ** 9, 10 ** 5):       # 5.3 ms frames at 12 MHz: 358 s at most, 67,500 frames
        rc, err = cli_verify(tmp_path, capsys, "servo a = P1.0\npose p { a: 10 }\nmain { move p }\n",
                             None, "--text", "--frames", str(frames))
        assert rc == 2 and "is more than verify can run" in err and "internal" not in err, err
    for text in (NOTHING_CHANGES, NOTHING_CHANGES.replace("at89c52 clock 11.0592MHz", "stc89c52rc clock 11.0592MHz mode 6T")):
        b = build_text(text)
        most = verify.max_frames(b.plan)
        ticks = b.plan.program.target.cycles(b.plan.period_us) * 12   # ucsim's ticks a frame, in 6T mode too
        assert (most + 2) * ticks < 1 << 32 < (most + 6) * ticks


def test_an_events_file_that_is_not_text_is_a_usage_error_at_its_line_and_utf16_is_read(tmp_path, capsys):
    from servoc.cli import main as cli_main
    prog = tmp_path / "p.servo"
    prog.write_text(NOTHING_CHANGES)
    ev = tmp_path / "p.events"
    for data, line in ((b'0.5s "a"\n1s "\xff"\n', 2), (b"\xef\xbb\xbf\n\n0.2s \"\xc3\"\n", 3)):
        ev.write_bytes(data)
        rc = cli_main(["verify", str(prog), "--events", str(ev)])
        err = capsys.readouterr().err
        assert rc == 2 and f"line {line}: not UTF-8 text" in err and "Traceback" not in err, err
    ev.write_bytes('0.5s "a"\n'.encode("utf-16"))       # with its BOM: read like UTF-8
    rc, data = cli_verify(tmp_path, capsys, NOTHING_CHANGES, None, "--events", str(ev))
    assert rc == 0 and data["ok"], data


PRESSES = """\
input btn = P3.2
input knob = P3.3
serial 4800
servo a = P1.0
pose p0 { a: 20 }
pose p1 { a: 80 }
main {
  move p0 in 100ms
  select {
    on btn {
      select {
        on "y" { move p1 in 200ms }
        on press knob { move p0 in 200ms }
      }
    }
    after 2s { wait btn }
  }
}
"""


def test_the_words_say_what_happened(tmp_path, capsys):
    # a press of 1 ms between two looks; a byte no `on` names while the inner select waits; the
    # inner select's branch after the outer's: reactions in time order
    scenario = ("0.5002s btn active\n0.5012s btn inactive\n1s btn active\n1.1s btn inactive\n"
                '1.2s "z"\n1.4s "y"\n')
    rc, data = cli_verify(tmp_path, capsys, PRESSES, scenario)
    assert rc == 0 and data["ok"], data
    assert [s["branch"] for s in data["selects"]] == ["on btn", 'on "y"']
    times = [s["time_us"] for s in data["selects"]]
    assert times == sorted(times)
    assert any("shorter than a frame" in w and "0.5002 s" in w for w in data["warnings"]), data["warnings"]
    assert any('byte "z"' in w and "none of its `on`s names it" in w for w in data["warnings"]), data["warnings"]
    rc, data = cli_verify(tmp_path, capsys, "input btn = P3.2\nservo a = P1.0\npose p { a: 9 }\n"
                                            "main {\n  move p in 100ms\n  wait btn\n  move p in 1s\n}\n", None)
    assert rc == 0 and data["partial"] and "waiting at the select at line 6 for `on btn`" in data["ended"], data


# ---------------------------------------------------------------- generated: right passes, wrong fails

CLOCKS = [("11.0592MHz", 9600), ("12MHz", 4800), ("22.1184MHz", 19200)]
LETTERS = "abcdefghijklmnop"


@st.composite
def programs(draw):
    clock, baud = draw(st.sampled_from(CLOCKS))
    nbytes = draw(st.integers(1, 16))
    with_input = draw(st.booleans())
    meanwhile = draw(st.booleans())
    nested = draw(st.booleans())
    lines = [f"target at89c52 clock {clock}", f"serial {baud}", "input btn = P3.2", "servo a = P1.0",
             "servo b = P1.1", "pose home { a: 40, b: 60 }"]
    branches = []
    for k in range(nbytes):
        n = draw(st.integers(10, 98))
        lines.append(f"pose q{k} {{ {'a' if k % 2 else 'b'}: {n} }}")
        visible = draw(st.booleans())
        body = f"move {'q' + str(k) if visible else 'home'} in {draw(st.sampled_from([300, 450]))}ms"
        if draw(st.booleans()):
            body += f'; send "{LETTERS[k].upper()}"'
        if nested and k == 0:
            inner = 'select { on "z" { move home in 300ms; send "Z" } after 150ms { send "T" } }'
            body = f"{inner}; {body}" if draw(st.booleans()) else f"{body}; {inner}"  # first: its reach is the branch's entry
        branches.append(f'      on "{LETTERS[k]}" {{ {body} }}')
    if with_input:
        branches.append('      on press btn { move home in 300ms; send "P" }')
    if meanwhile:
        branches.append("      meanwhile { move q0 in 400ms; move home in 400ms }")
    lines.append("main {\n  move home in 100ms\n  loop {\n    select {\n" + "\n".join(branches) + "\n    }\n  }\n}")
    text = "\n".join(lines) + "\n"
    times = sorted(37 * k for k in draw(st.lists(st.integers(5, 135), min_size=1, max_size=8, unique=True)))
    scenario = ""
    for t in times:
        if with_input and draw(st.booleans()):
            scenario += f"{t}ms btn active\n{t + 30}ms btn inactive\n"
        else:
            scenario += f'{t}ms "{draw(st.sampled_from(LETTERS[:nbytes] + "z"))}"\n'
    return text, scenario


def _swap_branches(asm: str) -> str:
    """The first select's dispatch runs branch 1 for branch 0 and the other way round (unchanged
    when it has one branch)."""
    lab = re.search(r"LJMP    (sel\d+)_b0\b", asm).group(1)
    if not re.search(rf"LJMP    {lab}_b1\b", asm):
        return asm
    return re.sub(rf"LJMP    {lab}_b([01])\b", lambda m: f"LJMP    {lab}_b{1 - int(m.group(1))}", asm)


def _drop_send(asm: str, byte: int) -> str:
    """Every `send` of `byte` left out."""
    return re.sub(rf"\n\s+MOV     R2, #0x{byte:02X}[^\n]*\n\s+LCALL   send_byte[^\n]*", "", asm)


def _late_look(asm: str) -> str:
    fcall = "frame_w" if "\nframe_w:" in asm else "frame_io"
    return re.sub(r"(\n\s+LCALL   (sel\d+)_ev\s+; a look as it is reached)", rf"\n        LCALL   {fcall}\1", asm, count=1)


@settings(max_examples=4, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True,
          phases=[Phase.explicit, Phase.generate])
@given(programs())
def test_generated_programs_right_firmware_passes_wrong_firmware_fails(case):
    text, scenario = case
    built = build_text(text)
    frames = int(7_000_000 / built.plan.period_us)
    _, report = watch(built, scenario, frames)
    assert report.ok, f"{problems(report)}\n{text}\n{scenario}"
    taken = [r.branch for r in report.reactions]
    asm = built.firmware.unit.text
    wrongs = {"a look a frame late": rebuilt(built, _late_look(asm))}
    if 'on "a"' in taken or 'on "b"' in taken:
        wrongs["branches swapped"] = rebuilt(built, _swap_branches(asm))
    sends = [c for c in LETTERS if f'on "{c}"' in taken and f'send "{c.upper()}"' in text]
    if sends:
        wrongs["a send removed"] = rebuilt(built, _drop_send(asm, ord(sends[0].upper())))
    moved = [k for k, c in enumerate(LETTERS) if f'on "{c}"' in taken and f"move q{k} in" in text]
    if moved:
        k = moved[0]
        n = int(re.search(rf"pose q{k} {{ \w: (\d+) }}", text).group(1))
        off = build_text(text.replace(f"pose q{k} {{", f"pose q{k} {{", 1).replace(
            re.search(rf"pose q{k} {{ \w: \d+ }}", text).group(0),
            re.search(rf"pose q{k} {{ \w: \d+ }}", text).group(0).replace(f": {n} ", f": {n + 1} ")))
        wrongs["a target one N off"] = off.firmware
    for what, wrong in wrongs.items():
        if wrong.hex_text == built.firmware.hex_text:
            continue
        _, bad = watch(built, scenario, frames, wrong)
        assert not bad.ok, f"{what} not caught:\n{text}\n{scenario}"


def test_a_hex_whose_selects_cannot_be_watched_is_refused(tmp_path, capsys):
    other = tmp_path / "o.servo"
    other.write_text(NOTHING_CHANGES.replace('on "b" {', 'on "c" { send "C" }\n      on "b" {'))
    assert main(["compile", str(other), "-o", str(tmp_path / "o.hex")]) == 0
    capsys.readouterr()
    rc, err = cli_verify(tmp_path, capsys, NOTHING_CHANGES, '0.4s "a"\n', "--hex", str(tmp_path / "o.hex"), "--text")
    assert rc == 2 and "verify cannot watch its selects" in err, err
    same = tmp_path / "same.servo"
    same.write_text(NOTHING_CHANGES)
    assert main(["compile", str(same), "-o", str(tmp_path / "s.hex")]) == 0
    capsys.readouterr()
    rc, out = cli_verify(tmp_path, capsys, NOTHING_CHANGES, '0.4s "a"\n', "--hex", str(tmp_path / "s.hex"), "--text")
    assert rc == 0 and "OK" in out, out


LINT_OK_COMPILE_REFUSED = {
    "empty main, one servo": "servo arm = P1.0\nmain { }\n",
    "no servos at all": "main {}\n",
    "a frameless after in a nested select, in a loop": (
        'serial 4800\nservo arm = P1.0\npose p { arm: 10 }\nmain {\n  move p in 100ms\n'
        '  loop { select { on "V" { select { on "E" { hold 6ms; send "S" } after 30ms { } } } } }\n}\n'),
    "the same, in a repeat": (
        'serial 4800\nservo arm = P1.0\npose p { arm: 10 }\nmain {\n  move p in 100ms\n'
        '  repeat 3 { select { on "V" { select { on "E" { hold 6ms; send "S" } after 30ms { } } } } }\n}\n'),
}


@pytest.mark.parametrize("name", sorted(LINT_OK_COMPILE_REFUSED))
def test_programs_lint_accepts_compile_and_verify(name, tmp_path, capsys):
    text = LINT_OK_COMPILE_REFUSED[name]
    scenario = '0.1s "V"\n0.2s "E"\n0.4s "V"\n0.8s "V"\n0.815s "E"\n' if "serial" in text else None
    rc, data = cli_verify(tmp_path, capsys, text, scenario)
    assert rc == 0 and data["ok"], data
    if scenario:
        assert [s["branch"] for s in data["selects"]].count('on "E"') == 1, data["selects"]


def _nested(levels: int) -> str:
    body = "move q in 200ms; move p in 200ms"
    for i in range(levels):
        body = (f"repeat 2 {{ {body} }}" if i % 2 == 0 else
                f'select {{ on "a" {{ move p in 200ms }} on other {{ send "?"; move p in 200ms }} '
                f"after 2s {{ move q in 200ms }} meanwhile {{ {body} }} }}")
    return ("serial 4800\nservo s = P1.0\npose p { s: 10 }\npose q { s: 60 }\n"
            f"main {{\n  loop {{\n    {body}\n  }}\n}}\n")


def test_one_port_with_a_serial_line_nests_sixteen_levels(tmp_path, capsys):
    """RAM sized to the program: one port of servos with `serial` holds 8 repeats and 8 selects
    with `after` and meanwhile bodies nested in one another, and runs them exactly (a stack that
    grew into the motion state would show in the pulses)."""
    rc, data = cli_verify(tmp_path, capsys, _nested(16), '1s "x"\n1.5s "a"\n2s "x"\n')
    assert rc == 0 and data["ok"], data
    assert [s["branch"] for s in data["selects"]][:2] == ["on other", 'on "a"']
