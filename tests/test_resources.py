"""Resources sized to the program, and every figure servoc reports holding: the stack is the RAM
the ports, variables and features leave (as the docs' table says), programs lint accepts compile,
and the reported shortest period is one from which on every period holds."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from conftest import front_end_text
from servoc import costs, layout

ROOT = Path(__file__).resolve().parent.parent


def test_the_docs_table_of_nesting_levels_is_what_too_deep_allows():
    docs = (ROOT / "docs/language.md").read_text(encoding="utf-8")
    section = docs[docs.index("### too-deep (error)"):]
    rows = re.findall(r"^\| (\d)(?: \(or none\))? \| (\d+) bytes \| (\d+) \| (\d+) \| (\d+) \| (\d+) \|$", section, re.M)
    assert [int(r[0]) for r in rows] == [1, 2, 3] * 2      # the motion state in internal RAM, then in XRAM
    for k, (ports, room, *levels) in enumerate(rows):
        ports, xram = int(ports), k >= 3
        assert costs.stack_room(False, 0, ports, xram) == int(room)
        want = [costs.max_nesting(serial, watch, 0, ports, False, xram) for serial in (False, True)
                for watch in (False, True)]
        assert [int(x) for x in levels] == want
    assert costs.max_nesting(True, True, 4, 1) >= 8       # one port with serial: at least 8 levels


def nested(levels: int, ports: int = 1, serial: bool = True) -> str:
    servos = "".join(f"servo s{p} = P{p}.0\n" for p in (1, 2, 0)[:ports])
    poses = ", ".join(f"s{p}: {{}}" for p in (1, 2, 0)[:ports])
    body = "move q in 200ms"
    for _ in range(levels):
        body = f"repeat 2 {{ {body} }}"
    return (("serial 4800\n" if serial else "") + servos + "pose p { " + poses.format(*[10] * ports) + " }\n"
            + "pose q { " + poses.format(*[60] * ports) + " }\nmain {\n  move p in 100ms\n  " + body + "\n}\n")


@pytest.mark.parametrize("ports", [1, 2, 3])
def test_too_deep_counts_the_room_the_ports_leave(ports):
    limit = costs.max_nesting(True, False, 0, ports)
    fe, diags = front_end_text(nested(limit, ports))
    assert not [d for d in diags if d.is_error], [d.message for d in diags if d.is_error]
    fe, diags = front_end_text(nested(limit + 1, ports))
    deep = [d for d in diags if d.code == "too-deep"]
    assert len(deep) == 1 and f"room for {limit} level" in deep[0].message, [d.message for d in diags]


@pytest.mark.toolchain
def test_the_deepest_one_port_program_lint_accepts_compiles():
    from conftest import build_text
    built = build_text(nested(costs.max_nesting(True, False, 0, 1)))
    assert built.firmware.unit.ram_bytes <= 256
    assert built.verify(400).ok


@pytest.mark.toolchain
@pytest.mark.parametrize("for_size", [False, True])
def test_on_a_chip_with_xram_the_deepest_nesting_lint_accepts_compiles_with_the_motion_state_there(for_size, tmp_path):
    """On the STC89C52RC the motion state moves to XRAM where the stack needs its internal RAM, and
    `too-deep` counts the room that leaves (32 bytes more a port): three ports with a serial line
    nested as deep as lint accepts compile, for speed and for size, and run exactly in ucsim at
    their shortest period (1 us less refused); a
    level more is refused; the AT89C52, which has no XRAM, refuses that depth."""
    from conftest import build_text, compile_file
    stc, at89 = "target stc89c52rc clock 11.0592MHz\n", "target at89c52 clock 11.0592MHz\n"
    limit = costs.max_nesting(True, False, 0, 3, False, True)
    assert limit == costs.max_nesting(True, False, 0, 3) + 48
    _, diags = front_end_text(stc + nested(limit + 1, 3))
    deep = [d for d in diags if d.code == "too-deep"]
    assert len(deep) == 1 and f"room for {limit} levels" in deep[0].message, [d.message for d in diags]
    _, diags = front_end_text(at89 + nested(limit, 3))
    assert "too-deep" in [d.code for d in diags if d.is_error]
    shortest = build_text(stc + nested(limit, 3), for_size=for_size).plan.min_period_us
    built = build_text(stc + f"frame {shortest}us\n" + nested(limit, 3), for_size=for_size)
    unit = built.firmware.unit
    assert built.plan.compact == for_size and "XSTATE" in unit.text and unit.ram_bytes <= 256
    assert built.plan.period_us == built.plan.min_period_us == shortest
    report = built.verify(400)          # at exactly the shortest period, every pulse exact
    assert report.ok and report.max_error_cycles == 0, report.summary()
    path = tmp_path / "below.servo"
    path.write_text(stc + f"frame {shortest - 1}us\n" + nested(limit, 3), encoding="utf-8")
    below, _, diags = compile_file(str(path), for_size)
    assert below is None and "period-too-short" in [d.code for d in diags if d.is_error]


def _watched(levels: int, ports: int, serial: bool) -> str:
    """`nested` inside a select's meanwhile body, cut by a button (the select waiting: a level more)."""
    text = nested(levels, ports, serial)
    head, body = text.split("main {\n", 1)
    return ("input b = P3.2\n" + head + "main {\n  loop { select { on press b { move p in 200ms } meanwhile { loop {\n"
            + body.replace("in 100ms", "in 200ms").rstrip().rstrip("}") + " } } } }\n}\n")


@pytest.mark.toolchain
@pytest.mark.parametrize("ports", [1, 2, 3])
@pytest.mark.parametrize("serial", [False, True])
@pytest.mark.parametrize("watch", [False, True])
def test_on_a_chip_with_xram_every_depth_lint_names_as_the_limit_compiles(ports, serial, watch):
    """On the STC89C52RC at 11.0592 MHz in 6T mode: nested as deep as `too-deep` says the stack has
    room for, with and without a serial line and a meanwhile body, the program compiles for speed and
    for size (the motion state in XRAM where the stack needs the room); a level more is refused."""
    from conftest import build_text
    stc = "target stc89c52rc clock 11.0592MHz mode 6T\n"
    make = (lambda n: _watched(n, ports, serial)) if watch else (lambda n: nested(n, ports, serial))
    _, diags = front_end_text(stc + make(90))
    (deep,) = [d.message for d in diags if d.code == "too-deep"]
    limit = int(re.search(r"room for (\d+) level", deep).group(1))
    assert limit >= costs.max_nesting(serial, watch, 0, ports) + 16 * ports - 4
    repeats = limit - watch
    for for_size in (False, True):
        built = build_text(stc + make(repeats), for_size=for_size)
        assert built.firmware.unit.ram_bytes <= 256 and built.plan.compact == for_size
    _, diags = front_end_text(stc + make(repeats + 1))
    assert [d.code for d in diags if d.is_error] == ["too-deep"]


def test_one_level_is_said_in_the_singular(monkeypatch):
    monkeypatch.setattr(costs, "max_nesting", lambda *args: 1)
    fe, diags = front_end_text(nested(2, 3))
    (msg,) = [d.message for d in diags if d.code == "too-deep"]
    assert "room for 1 level (2 bytes each)" in msg, msg


def test_press_of_a_byte_is_a_bad_event():
    text = 'serial 4800\nservo a = P1.0\npose p { a: 9 }\nmain {\n  move p in 100ms\n  wait press "g"\n}\n'
    fe, diags = front_end_text(text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "bad-event" and "apply to inputs" in d.message and '`wait "g"`' in d.help


def test_a_loop_cut_by_until_is_a_wait_and_no_empty_loop():
    text = ("input b = P3.2\nservo a = P1.0\npose p { a: 9 }\nmain {\n  move p in 100ms\n"
            "  loop { hold 0ms } until press b\n  move p in 100ms\n}\n")
    fe, diags = front_end_text(text)
    assert not {d.code for d in diags} & {"empty-loop", "until-no-frame"}, [d.code for d in diags]


HEXAPOD = (ROOT / "examples/hexapod_serial.servo").read_text(encoding="utf-8")


def _without_tail_3(frame: str) -> str:
    text = re.sub(r"^servo tail_3 .*\n", "", HEXAPOD, flags=re.M).replace(", tail_3", "")
    return re.sub(r"^frame 20ms.*$", f"frame {frame}", text, flags=re.M)


def _without_tails(frame: str, baud: int = 4800) -> str:
    text = re.sub(r"^servo tail_[23] .*\n", "", HEXAPOD, flags=re.M).replace(", tail_3", "").replace(", tail_2", "")
    return re.sub(r"^frame 20ms.*$", f"frame {frame}", text, flags=re.M).replace("serial 4800", f"serial {baud}")


@pytest.mark.parametrize("clock,baud", [("", 4800), ("target stc89c52rc clock 11.0592MHz\n", 4800),
                                        ("target stc89c52rc clock 22.1184MHz\n", 2400)])
def test_the_shortest_period_leaves_the_sends_their_time(clock, baud):
    """The hexapod sends two bytes a frame apart at 4800 baud (2400 at 22.1184 MHz, where its work
    between frames is short enough that 4800 baud's bytes are out within the shortest period the
    frame model holds): the frame model holds from a shorter
    period on than the one at which those bytes are out before the next two are queued. The
    shortest period reported is the longer of the two, so that the program compiles there; 1 µs
    less is refused by `send-overrun`, and every period from the shortest on holds both."""
    from servoc import codegen
    fe, diags = front_end_text(clock + _without_tails("20ms", baud))
    assert fe.plan is not None, [d.message for d in diags if d.is_error]
    unit = codegen.generate(fe.plan)
    target, budget = fe.plan.program.target, unit.budget
    model = costs.frame_cycles(target, budget)
    shortest = fe.plan.min_period_us
    assert target.us_at_least(model) < shortest                 # the sends bind here, not the model
    fe, diags = front_end_text(clock + _without_tails(f"{shortest}us", baud))
    assert not [d for d in diags if d.is_error], [d.message for d in diags if d.is_error]
    _, diags = front_end_text(clock + _without_tails(f"{shortest - 1}us", baud))
    assert [d.code for d in diags if d.is_error] == ["send-overrun"], [d.message for d in diags if d.is_error]
    for period in (shortest + 1, shortest + 500, shortest + 1111, shortest + 2080, shortest + 4999):
        fe, diags = front_end_text(clock + _without_tails(f"{period}us", baud))
        assert fe.plan.period_holds and not [d for d in diags if d.is_error], period


def test_where_one_build_cannot_hold_the_sends_at_a_period_another_that_can_is_built():
    """At 22.1184 MHz on the STC89C52RC, the hexapod's two bytes a frame apart at 2400 baud are out
    before the next two are queued at a shorter period in the build with rises among falls (the
    motion state in XRAM) than in the builds with the ports one after another, which refuse that
    period (`send-overrun`). The period stage builds the one that holds it, so the shortest period
    reported is that build's: it compiles there, and every pulse and every byte sent is exact in
    ucsim."""
    from conftest import build_text
    from servoc import codegen
    clock = "target stc89c52rc clock 22.1184MHz\n"
    fe, _ = front_end_text(clock + _without_tails("20ms", 2400))
    shortest = fe.plan.min_period_us
    built = build_text(clock + _without_tails(f"{shortest}us", 2400))
    assert built.plan.period_holds and built.firmware.unit.budget.stagger
    with pytest.raises(layout.SendOverrun) as apart:
        codegen.generate(built.plan, stepping=False, stagger=False)
    assert apart.value.shortest_us > shortest
    from test_serial import run, sent
    plan, trace, _, report = run(clock + _without_tails(f"{shortest}us", 2400), '2s "x" "x" "x" "w"\n', 260)
    assert plan.period_us == shortest and sent(trace) == "R???W"
    assert report.ok and report.max_error_cycles == 0 and report.bytes_sent == 5, report.summary()


def test_a_period_too_short_for_one_build_names_the_limit_of_the_build_with_the_shortest(monkeypatch):
    """Where the build without steps does not hold the period asked for (its model needs more) and
    the build with steps would, but for its sends, the error is that build's `send-overrun` (the
    program's shortest period is that build's), not the other build's `period-too-short`; where the
    sends' period is not the shorter, the build without steps keeps its own verdict."""
    from servoc import codegen
    fe, _ = front_end_text("target stc89c52rc clock 22.1184MHz\n" + _without_tails("20ms"))
    plan = fe.plan
    real = codegen._generate_answers(plan, None, 0, False)
    without = dataclasses.replace(real, period_holds=False, min_period_us=5980)

    def answers(plan, source, hold_off, stepping, stagger=False, facts=None):
        if not stepping and not stagger:
            return without
        exc = layout.SendOverrun("the sends")
        exc.shortest_us = sends
        raise exc
    monkeypatch.setattr(codegen, "_generate_answers", answers)
    monkeypatch.setattr(codegen, "_steps_may_pay", lambda *units: True)
    sends = 5915
    with pytest.raises(layout.SendOverrun):
        codegen.generate(plan)
    sends = 5981
    assert codegen.generate(plan) is without


@pytest.mark.toolchain
def test_every_command_reports_the_build_the_period_stage_chose(tmp_path, capsys):
    """A program that fits only built for size: lint, plan (JSON) and compile say the same period
    and "built for size"; `--size` asks for that build for a program that fits built for speed."""
    import json
    import sys
    from servoc.cli import main
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import suite
    prog = tmp_path / "k.servo"
    prog.write_text(suite.keyframe_source(250))
    assert main(["lint", str(prog)]) == 0
    lint_line = capsys.readouterr().out.strip().splitlines()[-1]
    assert main(["plan", "--json", str(prog)]) == 0
    planned = json.loads(capsys.readouterr().out)
    assert main(["compile", "--format", "json", str(prog), "-o", str(tmp_path / "k.hex")]) == 0
    compiled = json.loads(capsys.readouterr().out)
    assert planned["built_for_size"] and compiled["built_for_size"] and "built for size" in lint_line
    assert planned["period_us"] == compiled["period_us"] and planned["min_period_us"] == compiled["min_period_us"]
    assert f"P = {compiled['period_us'] / 1000:g} ms" in lint_line
    small = tmp_path / "b.servo"
    small.write_text((ROOT / "examples/biped.servo").read_text(encoding="utf-8"))
    assert main(["compile", "--format", "json", str(small), "-o", str(tmp_path / "b.hex")]) == 0
    assert not json.loads(capsys.readouterr().out)["built_for_size"]
    assert main(["compile", "--size", "--format", "json", str(small), "-o", str(tmp_path / "s.hex")]) == 0
    assert json.loads(capsys.readouterr().out)["built_for_size"]
    assert main(["verify", "--size", str(small), "--frames", "300"]) == 0
    assert "OK" in capsys.readouterr().out


def test_serial_limits_point_at_their_causes():
    from servoc.source import SourceFile
    many = ("target stc89c52rc clock 11.0592MHz\nserial 19200\n" + "".join(f"servo s{i} = P1.{i}\n" for i in range(8))
            + "pose p { " + ", ".join(f"s{i}: {20 + 9 * i}" for i in range(8)) + " }\nmain {\n  move p in 100ms\n"
            + '  send "r"\n}\n')
    fe, diags = front_end_text(many)
    (d,) = [d for d in diags if d.is_error]
    line = SourceFile("x", many).line_col(d.span.start)[0]
    assert d.code == "serial-too-fast" and line == 2 and "from a host 2 % fast" in d.message
    rate = int(re.search(r"use `serial (\d+)`", d.help).group(1))
    fe, diags = front_end_text(many.replace("serial 19200", f"serial {rate}"))
    assert not [d for d in diags if d.is_error], [d.message for d in diags]        # the fix works
    chatty = ("serial 4800\nservo a = P1.0\npose p { a: 10 }\nmain {\n  move p in 100ms\n"
              '  loop { send "a"; ' + "send \"b\"; " * 32 + 'hold 100ms }\n}\n')      # 33 bytes: past the longest queue
    fe, diags = front_end_text(chatty)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "send-overrun" and SourceFile("x", chatty).snippet(d.span) == 'send "a"'
    assert [lab.message for lab in d.secondary] == ["sends too"] * 3


def test_a_frame_too_short_for_the_ports_is_said_before_any_send_overrun():
    text = ("serial 4800\nframe 1ms\nservo a = P1.0\npose p { a: 240 }\npose q { a: 250 }\nmain {\n"
            '  loop { move p in 30ms; send "a"; move q in 30ms; send "b" }\n}\n')
    fe, diags = front_end_text(text)
    assert [d.code for d in diags if d.is_error] == ["period-too-short"], [d.message for d in diags]


def test_the_lost_byte_check_has_the_host_margin():
    """19200 baud at 18.432 MHz: a byte every 800 cycles, 779 from a host 2 % fast; eight servos
    on a port, in a program that answers, can keep the line waiting 787 (their falls, a run for a
    byte sent, then the head): refused (it would pass without the margin)."""
    assert costs.rx_gap(800) == 779
    text = ("target stc89c52rc clock 18.432MHz\nserial 19200\n" + "".join(f"servo s{b} = P1.{b}\n" for b in range(8))
            + "pose x { " + ", ".join(f"s{b}: 50" for b in range(8))
            + ' }\nmain {\n  move x in 100ms\n  loop { select { on "a" { move x in 100ms; send "b" } } }\n}\n')
    fe, diags = front_end_text(text)
    errors = [d for d in diags if d.is_error]
    late = re.search(r"waiting (\d+) cycles", errors[0].message) if errors else None
    assert errors and errors[0].code == "serial-too-fast" and 779 < int(late.group(1)) <= 800, [d.message for d in diags]


# ---------------------------------------------------------------- lint accepts, compile builds

from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402


@st.composite
def lintable(draw):
    """Programs of every shape: 0-24 servos on 1-3 ports, selects nested 1-6 deep with every
    branch kind (bytes, other, inputs, edges, after, meanwhile), repeats, empty bodies, sends."""
    n = draw(st.integers(0, 24))
    pins = draw(st.permutations([(p, b) for p in (1, 2, 0) for b in range(8)]))[:n]
    serial = draw(st.booleans())
    lines = (["serial 4800"] if serial else []) + ["input btn = P3.2", "input knob = P3.3 high"]
    lines += [f"servo s{p}{b} = P{p}.{b}" for p, b in pins]
    names = [f"s{p}{b}" for p, b in pins]
    lines.append("pose a { " + ", ".join(f"{x}: {40 + 3 * i}" for i, x in enumerate(names)) + " }")
    lines.append("pose b { " + ", ".join(f"{x}: {60 + 3 * i}" for i, x in enumerate(names)) + " }")

    def body(depth: int) -> str:
        parts = []
        for _ in range(draw(st.integers(0, 3))):
            kind = draw(st.sampled_from(["move", "hold", "repeat", "select", "send", "empty"]))
            if kind == "move" and names:
                parts.append(f"move {draw(st.sampled_from('ab'))} in {draw(st.sampled_from([300, 500]))}ms")
            elif kind == "hold":
                parts.append(f"hold {draw(st.sampled_from([0, 6, 40]))}ms")
            elif kind == "repeat" and depth < 6:
                parts.append(f"repeat {draw(st.integers(1, 3))} {{ {body(depth + 1)} }}")
            elif kind == "select" and depth < 6:
                branches = []
                events = ['"x"', '"y"', "other"] if serial else []
                for ev in draw(st.lists(st.sampled_from(events + ["btn", "press btn", "release knob"]),
                                        min_size=1, max_size=3, unique=True)):
                    branches.append(f"on {ev} {{ {body(depth + 1)} }}")
                if draw(st.booleans()):
                    branches.append(f"after {draw(st.sampled_from([10, 60]))}ms {{ {body(depth + 1)} }}")
                if draw(st.booleans()):
                    branches.append(f"meanwhile {{ {body(depth + 1)} }}")
                parts.append("select { " + " ".join(branches) + " }")
            elif kind == "send" and serial:
                parts.append(f'send "{draw(st.sampled_from("ABC"))}"')
        return "; ".join(parts)

    main = body(0)
    if draw(st.booleans()):
        main = f"loop {{ {main}; hold 20ms }}" if main else "loop { hold 20ms }"
    lines.append(f"main {{ {main} }}")
    return "\n".join(lines) + "\n"


@pytest.mark.toolchain
@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(lintable())
def test_every_program_lint_accepts_compiles(text):
    from servoc import api
    from servoc.diagnostics import Reporter
    fe, diags = front_end_text(text)
    if fe.plan is None or any(d.is_error for d in diags):
        return                              # lint refused it: nothing to build
    reporter = Reporter(fe.source)
    unit = api.generate(fe.plan, fe.source, reporter)
    assert unit is not None and not reporter.has_errors, (
        [f"{d.code}: {d.message}" for d in reporter.diagnostics if d.is_error], text)
    firmware = api.assemble(unit, reporter)         # the assembler and linker take it (jump reach included)
    assert firmware is not None or [d.code for d in reporter.diagnostics if d.is_error] == ["rom-overflow"], text
    if fe.plan.nesting <= costs.max_nesting(fe.plan.program.serial is not None, True, 0, len(fe.plan.ports)):
        assert unit.stack_bytes <= costs.stack_room(fe.plan.program.serial is not None, 0, len(fe.plan.ports))


def test_serial_limits_come_all_at_once():
    text = ("target stc89c52rc clock 11.0592MHz\nserial 19200\n" + "".join(f"servo s{i} = P1.{i}\n" for i in range(8))
            + "pose p { " + ", ".join(f"s{i}: {20 + 9 * i}" for i in range(8)) + " }\nmain {\n  move p in 100ms\n"
            + '  loop { ' + 'send "a"; ' * 33 + 'hold 100ms }\n}\n')
    fe, diags = front_end_text(text)
    assert sorted(d.code for d in diags if d.is_error) == ["send-overrun", "serial-too-fast"], [d.message for d in diags]


def test_the_language_server_says_the_period_is_that_of_the_build_for_size():
    import sys
    from servoc import lsp
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import suite
    text = suite.keyframe_source(250)
    a = lsp.analyze("file:///k.servo", "k.servo", text)
    assert a.plan is not None and a.plan.compact
    at = text.index("move ", text.index("main"))
    shown = lsp.hover(a, at + 1)
    assert shown is not None and "built for size" in shown.contents.value, shown


@pytest.mark.toolchain
def test_the_rom_size_read_from_the_text_is_the_assemblers():
    """`layout.rom_end` decides without the toolchain which build fits the chip (codegen.generate,
    the period stage): it must be the end of what the assembler lays out, to the byte. The
    examples at three clocks (rises as steps, among falls, host protocol, serial, tables of frames
    needed), built for speed and for size, and keyframe and gait programs near the limit."""
    import sys
    from servoc import api, codegen, toolchain
    from servoc.diagnostics import Reporter
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import suite
    texts = [p.read_text(encoding="utf-8") for p in sorted((ROOT / "examples").glob("*.servo"))]
    fast = ["target at89c52 clock 22.1184MHz\n", "target at89c55wd clock 11.0592MHz\n"]
    texts += [clock + re.sub(r"^target .*$", "", t, flags=re.M) for clock in fast for t in texts[:]]
    texts += [suite.keyframe_source(n) for n in (20, 150)] + [suite.gait_source(40)]
    kinds = set()
    for text in texts:
        fe, _ = front_end_text(text)
        if fe.plan is None:
            continue
        for unit in (api.generate(fe.plan, fe.source, Reporter(fe.source)),
                     codegen.generate(dataclasses.replace(fe.plan, compact=True), fe.source)):
            image = toolchain.assemble(unit.text, name="servo")
            assert layout.rom_end(unit.text) == image.symbols["data_end"], text[:80]
            b = unit.budget
            kinds.add("stagger" if b and b.stagger else "steps" if b and b.steps else "size" if unit.for_size else "plain")
            kinds.add("tables" if unit.fneed_pages else "no tables")
    assert kinds >= {"stagger", "steps", "size", "plain", "tables", "no tables"}, kinds


@pytest.mark.parametrize("clock", ["12MHz", "11.0592MHz"])
def test_every_period_from_the_reported_shortest_holds_the_model(clock):
    """`costs.frame_cycles` searches the steps of the serial charge; here every period from the
    shortest on, cycle by cycle over four byte times, is checked against the model, and the one
    below it is not enough (or the shortest is the first that holds)."""
    from servoc import codegen
    text = f"target at89c52 clock {clock}\n" + _without_tail_3("20ms")
    fe, diags = front_end_text(text)
    assert fe.plan is not None, [d.message for d in diags if d.is_error]
    unit = codegen.generate(fe.plan)
    target, budget = fe.plan.program.target, unit.budget
    shortest = costs.frame_cycles(target, budget)
    assert all(costs.holds(target, budget, p) for p in range(shortest, shortest + 4 * budget.byte_cycles))
    assert not costs.holds(target, budget, shortest - 1)


@pytest.mark.toolchain
@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n"])
def test_the_serial_hexapod_verifies_at_exactly_its_shortest_period_under_bursts(tmp_path, capsys, clock):
    """The program of the issue at its own shortest period (the one from which on every period
    holds): in ucsim, walking and standing while four bytes come back to back every 50 ms, every
    pulse and every answer is exact; 1 µs less is refused."""
    from servoc.cli import main
    period = 9600
    for _ in range(6):                      # F depends on P: the period the code built at it reports
        fe, _ = front_end_text(clock + _without_tail_3(f"{period}us"))
        if fe.plan.min_period_us == period:
            break
        period = fe.plan.min_period_us
    assert fe.plan.min_period_us == period and fe.plan.period_holds
    target = fe.plan.program.target
    fe, diags = front_end_text(clock + _without_tail_3(f"{period - 1}us"))
    # refused by what binds there: the frame model, or the time its two sends a frame apart need
    assert [d.code for d in diags if d.is_error] in (["period-too-short"], ["send-overrun"])
    prog, ev = tmp_path / "h.servo", tmp_path / "h.events"
    prog.write_text(clock + _without_tail_3(f"{period}us"))
    ev.write_text('0.3s "w"\n' + "".join(f'{0.5 + 0.05 * k:.3f}s "x" "x" "x" "x"\n' for k in range(40))
                  + '2.6s "s"\n' + "".join(f'{2.8 + 0.05 * k:.3f}s "x" "x" "x" "x"\n' for k in range(20)))
    import json
    assert main(["verify", "--format", "json", str(prog), "--events", str(ev)]) == 0
    data = json.loads(capsys.readouterr().out)
    # the answers each checked (how many the select takes depends on the period: one a frame)
    assert data["ok"] and data["max_error_cycles"] == 0 and data["bytes_sent"] >= 50, data["mismatches"][:3]
    assert data["period_cycles"]["min"] == data["period_cycles"]["max"] == target.cycles(period)
