"""Rough edges a new user meets: each one a clear message or simply accepted."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import front_end_text
from servoc import cli, events


def codes_and_messages(text: str) -> list[tuple[str, str]]:
    _, diags = front_end_text(text)
    return [(d.code, d.message) for d in diags]


def test_a_select_on_one_line():
    text = ('serial 4800\ninput btn = P3.2\nservo a = P1.0\npose p { a: 20 }\npose q { a: 21 }\n'
            'main {\n  move p\n  select { on "a" { send "A" } on "b" { send "B" } }\n'
            '  select { on btn { move q } after 10ms { move p } }\n}\n')
    fe, diags = front_end_text(text)
    assert fe.plan is not None and not [d for d in diags if d.is_error], diags


def test_greek_mu_is_a_micro_sign():
    micro = codes_and_messages("servo a = P1.0\npose p { a: 1500\u00b5s }\nmain { move p }\n")
    greek = codes_and_messages("servo a = P1.0\npose p { a: 1500\u03bcs }\nmain { move p }\n")
    assert greek == micro and not [c for c, _ in greek if c == "syntax-error"]
    fe, _ = front_end_text("servo a = P1.0\npose p { a: 1500\u03bcs }\nmain { move p }\n")
    assert fe.plan.moves[0].motions[0].n1 == 125


def test_an_unknown_option_shows_the_commands_usage(tmp_path, capsys):
    assert cli.main(["lint", str(tmp_path / "x.servo"), "--bogus"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: servoc lint ") and "--bogus" in err


def test_a_closed_pipe_is_no_traceback(tmp_path):
    big = tmp_path / "big.servo"
    big.write_text("".join(f"servo s{k} = P9.{k}\n" for k in range(3000)))      # thousands of errors
    proc = subprocess.Popen([sys.executable, "-m", "servoc", "lint", str(big), "--format", "json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.read(100)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipe" not in err, err


def test_events_files():
    assert events.parse('\ufeff1s "a"\n', (), True)[0].data == b"a"          # a BOM
    assert events.parse("1s 0x41 0xff\n", (), True)[0].data == b"A\xff"      # hex bytes
    with pytest.raises(events.EventsError, match="line 2: this event at 1000 ms comes before"):
        events.parse('2s "a"\n1s "b"\n', (), True)
    for token in ("65.5", "0x100", "12ab"):
        with pytest.raises(events.EventsError, match=f"`{token}` is not a byte"):
            events.parse(f"1s {token}\n", (), True)


def test_widths_and_clocks_are_shown_as_written():
    found = codes_and_messages("servo a = P1.0\npose p { a: 500.0000001us }\nmain { move p }\n")
    assert any(c == "off-grid-width" and "500.0000001us is not on the 8 µs grid" in m for c, m in found)
    slow = codes_and_messages("target at89c52 clock 10499999Hz\nservo a = P1.0\npose p { a: 1 }\nmain { move p }\n")
    assert any(c == "bad-clock" and "10.499999 MHz" in m for c, m in slow), slow
    half = codes_and_messages("target at89c52 clock 12000000.5Hz\nservo a = P1.0\npose p { a: 1 }\nmain { move p }\n")
    assert any(c == "bad-clock" and "not a whole number of hertz" in m for c, m in half), half


def test_the_frame_limit_follows_the_clock():
    found = codes_and_messages("target at89c52 clock 24MHz\nframe 40ms\nservo a = P1.0\npose p { a: 1 }\n"
                               "main { move p }\n")
    assert any(c == "period-too-long" and "32.767 ms at most" in m for c, m in found), found


def test_lint_finds_what_compile_finds_without_the_assembler():
    text = ("target stc89c52rc clock 11.0592MHz\nserial 19200\n" +
            "".join(f"servo a{k} = P1.{k}\n" for k in range(8)) +
            "pose s { " + ", ".join(f"a{k}: {10 + 30 * k}" for k in range(8)) + " }\n"
            'main {\n  move s\n  loop { wait "g"; send "k" }\n}\n')
    assert [c for c, _ in codes_and_messages(text) if c == "serial-too-fast"] == ["serial-too-fast"]
    overrun = ('serial 4800\nservo a = P1.0\npose p { a: 20 }\n'
               'main { move p; loop { repeat 3 { wait "a"; send "b" } } }\n')
    assert "send-overrun" in [c for c, _ in codes_and_messages(overrun)]


def test_the_shortest_period_reported_is_one_whose_eased_tables_fit_the_chip():
    """An eased move of 30 s takes a curve table of a byte a frame: at the 2.611 ms the timing
    allows, 11,489 bytes, more than the AT89C52's 8 KB even built for size. The shortest period
    reported is the least at which the firmware fits (and holds P): `frame` at it builds, and 1 us
    less is refused, as too big for the chip."""
    import re
    text = "servo arm = P1.0\npose a { arm: 0 }\npose b { arm: 250 }\nmain {\n  move a\n  move b in 30s ease in-out\n}\n"
    fe, diags = front_end_text(text)
    shortest = fe.plan.min_period_us
    assert not [d for d in diags if d.is_error] and 2611 < shortest < 5300, shortest
    fe, diags = front_end_text(f"frame {shortest}us\n" + text)
    assert not [d for d in diags if d.is_error] and fe.plan.min_period_us == shortest
    _, diags = front_end_text(f"frame {shortest - 1}us\n" + text)
    assert [d.code for d in diags if d.is_error] == ["rom-overflow"]
    d = next(d for d in diags if d.is_error)
    assert re.search(r"eased curve tables \d+", d.message) and "a longer `frame` makes it smaller" in d.help


def test_too_deep_with_no_level_left_says_so():
    """24 servos, the serial line and three selects nested in meanwhile bodies: the stack has room
    for no level at all; `too-deep` says so, at the first select, not "room for -1 levels"."""
    pins = [f"P{p}.{b}" for p in (0, 1, 2) for b in range(8)]
    inner = 'move lo in 700ms; send "A"; move hi in 700ms'
    for _ in range(3):
        inner = f"select {{ on release b2 {{ hold 10ms }} after 5s {{ hold 10ms }} meanwhile {{ {inner} }} }}"
    text = ("serial 4800\ninput b2 = P3.3\n" + "".join(f"servo s{i} = {p}\n" for i, p in enumerate(pins))
            + "pose lo { P0: 0, P1: 0, P2: 0 }\npose hi { P0: 250, P1: 250, P2: 250 }\n"
            + f"main {{\n  loop {{ {inner} }}\n}}\n")
    _, diags = front_end_text(text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "too-deep" and "has room for no level" in d.message and "-1" not in d.message, d.message
    assert "reach level 1" in d.message


def test_a_program_with_no_servos_keeps_its_frames():
    """No port to pulse: Timer0 alone times the frames, so `hold 20ms` at P = 5.3 ms is 4 frames
    between two sends, to the machine cycle, at 12 MHz, at 11.0592 MHz and in 6T mode (the frames
    ran at no pace before: hundreds of bytes a second); verify says it checked none of the timing."""
    from conftest import build_text
    from servoc import api
    for head in ("", "target stc89c52rc clock 11.0592MHz\n", "target stc89c52rc clock 11.0592MHz mode 6T\n"):
        b = build_text(head + 'serial 4800\nmain { loop { send "a"; hold 20ms } }\n')
        period = b.plan.program.target.cycles(b.plan.period_us)
        trace = api.simulate(b.firmware.hex_text, 12 * 4 * period, b.plan.program.target, api.stimulus(b.plan))
        starts = [t for t, _ in trace.sent]
        assert len(starts) >= 10 and all(b_ - a == 4 * period for a, b_ in zip(starts[1:], starts[2:])), \
            (head, period, [b_ - a for a, b_ in zip(starts, starts[1:])])
        from servoc.verify import verify_span
        assert any("drives no servo line" in note for note in verify_span(b.plan, None, None).notes)
