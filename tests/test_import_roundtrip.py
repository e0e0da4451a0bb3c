"""servoc import, end to end: one file of each format becomes a program that compiles and whose
firmware, run in ucsim, sends exactly the planned pulses; broken and hostile files are usage errors
that write nothing."""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path

import pytest

from servoc import api, cli
from servoc.plan import verify_frames

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples" / "import"
FIXTURES = ROOT / "tests" / "fixtures" / "import"
SOURCES = sorted(p for p in EXAMPLES.iterdir() if p.suffix in (".csv", ".xml", ".json", ".cpp"))


def test_there_is_an_import_example_of_each_format():
    formats = {api.read_motion(str(p))[0] for p in SOURCES}
    assert formats == set(api.IMPORT_FORMATS)


@pytest.mark.toolchain
@pytest.mark.parametrize("path", SOURCES, ids=[p.name for p in SOURCES])
def test_import_compile_verify(path, tmp_path, capsys):
    out = tmp_path / (path.stem + ".servo")
    assert cli.main(["import", str(path), "-o", str(out)]) == 0, capsys.readouterr().err
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None, [d.message for d in reporter.diagnostics if d.is_error]
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok, report.mismatches[:5]
    assert report.frames >= fe.plan.total_frames


def test_the_three_blender_exports_give_one_program(tmp_path, capsys):
    texts = []
    for name in ("anim.json", "anim.h", "anim.bin"):
        out = tmp_path / (name + ".servo")
        cli.main(["import", str(FIXTURES / "blender" / name), "-o", str(out), "--fps", "30"])
        texts.append(out.read_text().split("\n", 2)[2])      # the same below the header
    assert texts[0] == texts[1] == texts[2] and "move " in texts[0]


@pytest.mark.parametrize("name, content, words", [
    ("laughs.xml", b'<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;">]>'
                   b"<UscSettings><Channels/></UscSettings>", "DOCTYPE"),
    ("cut.xml", (FIXTURES / "maestro" / "wave_plain.xml").read_bytes()[:700], "XML"),
    ("cut.bin", (FIXTURES / "blender" / "anim.bin").read_bytes()[:31], "cut short"),
    ("types.json", b'{"fps": "thirty", "frames": 1, "positions": [{"0": 1500}]}', "fps"),
    ("cut.cpp", b'const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,2000,3000,1500\\n";\n'
                b'const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,500\\n";\n', "truncated"),
    ("empty.csv", b"time_ms,a\n", "no keyframe rows"),
])
def test_broken_and_hostile_files_are_usage_errors(tmp_path, capsys, name, content, words):
    src = tmp_path / name
    src.write_bytes(content)
    started = time.perf_counter()
    rc = cli.main(["import", str(src), "--fps", "30"] if name.endswith(".bin") else ["import", str(src)])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err and "internal error" not in err
    assert words.lower() in err.lower(), err
    assert os.listdir(tmp_path) == [name]
    assert time.perf_counter() - started < 5


def test_a_million_frames_is_a_clear_error_in_moments(tmp_path, capsys):
    src = tmp_path / "long.bin"
    src.write_bytes(b"<\x00\x05\xdc>\n" * 1_000_000)
    started = time.perf_counter()
    rc = cli.main(["import", str(src), "--fps", "30"])
    err = capsys.readouterr().err
    assert rc == 2 and "frames" in err and "Traceback" not in err
    assert not (tmp_path / "long.servo").exists()
    assert time.perf_counter() - started < 10


def test_import_overwrites_nothing_it_reads(tmp_path, capsys):
    src = tmp_path / "a.csv"
    shutil.copy(EXAMPLES / "pan_tilt.csv", src)
    assert cli.main(["import", str(src), "-o", str(src)]) == 2
    assert "is the file to import" in capsys.readouterr().err
    assert src.read_bytes() == (EXAMPLES / "pan_tilt.csv").read_bytes()


@pytest.mark.parametrize("name, make", [
    ("long.csv", lambda n: b"time_ms,a\n" + b"".join(b"%d,1500\n" % k for k in range(n))),
    ("long.xml", lambda n: b'<UscSettings version="1"><Channels><Channel name="a" mode="Servo" min="3968" max="8000"/>'
                           b'</Channels><Sequences><Sequence name="s">'
                           + b'<Frame name="f" duration="20">6000</Frame>' * n + b"</Sequence></Sequences></UscSettings>"),
    ("long.cpp", lambda n: b'const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,2000,3000,1500\\n";\n'
                           b'const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,%d,0,1,0,8192,-1,0\\n";\n' % (n * 6)),
])
def test_a_million_frames_in_any_format_is_a_clear_error(tmp_path, capsys, name, make):
    src = tmp_path / name
    src.write_bytes(make(1_000_000))
    started = time.perf_counter()
    rc = cli.main(["import", str(src)])
    err = capsys.readouterr().err
    assert rc == 2 and "more than the 100,000" in err and "Traceback" not in err, err
    assert os.listdir(tmp_path) == [name]
    assert time.perf_counter() - started < 20


def test_the_import_sessions_in_the_docs_are_what_servoc_prints(tmp_path, monkeypatch, capsys):
    """Each `$ servoc import ...` block of docs/language.md: what it prints on standard output."""
    docs = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
    sessions = re.findall(r"```text\n\$ servoc (import [^\n]*)\n(.*?)```", docs, re.S)
    assert len(sessions) == 3
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    for command, shown in sessions:
        assert cli.main(command.split()) == 0
        assert capsys.readouterr().out == shown, command


def blender_json(path, fps: int, ids=("0",)) -> None:
    import json
    import math
    positions = [{i: round(1500 + 300 * math.sin(3 * k / fps)) for i in ids} for k in range(fps)]
    path.write_text(json.dumps({"description": "test", "fps": fps, "frames": fps, "seconds": 1, "bones": len(ids),
                                "file": "t.blend", "scene": "Scene", "positions": positions}))


@pytest.mark.toolchain
def test_a_fast_blender_export_meets_every_frame_at_p_1_over_fps(tmp_path, capsys):
    """200 fps is 5 ms a frame, under the 5.3 ms default but above what the firmware holds on one
    port: the import writes `frame 5ms`, every source frame lands on a frame, and the firmware holds
    that period in ucsim, pulse for pulse."""
    src, out = tmp_path / "fast.json", tmp_path / "fast.servo"
    blender_json(src, 200)
    assert cli.main(["import", str(src), "-o", str(out)]) == 0
    assert "frame 5ms\n" in out.read_text() and "one source frame in" not in capsys.readouterr().out
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None and fe.plan.period_us == 5000
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok and report.max_error_cycles == 0, report.mismatches[:5]


def test_an_export_faster_than_any_frame_meets_one_frame_in_step(tmp_path, capsys):
    """1000 fps (1 ms) is shorter than any frame the firmware holds: 6 ms frames, one source frame in
    6 met, and a note says so."""
    src, out = tmp_path / "kilo.json", tmp_path / "kilo.servo"
    blender_json(src, 1000)
    assert cli.main(["import", str(src), "-o", str(out)]) == 0
    assert "frame 6ms\n" in out.read_text()
    assert "one source frame in 6 is met" in capsys.readouterr().out


@pytest.mark.toolchain
def test_twenty_four_channels_on_three_ports_verify(tmp_path, capsys):
    """Channels 0-23 fill P1, P2 and P0; at 30 fps the frame is 1/30 s over 5 (the default on three
    ports, their pulses overlapping, is longer than 1/30 s over 6), and the firmware sends every
    pulse as planned."""
    src, out = tmp_path / "all.json", tmp_path / "all.servo"
    blender_json(src, 30, ids=tuple(str(i) for i in range(24)))
    assert cli.main(["import", str(src), "-o", str(out)]) == 0
    text = out.read_text()
    assert "frame 6.667ms\n" in text and "servo servo_23 = P0.7" in text and "servo servo_8 = P2.0" in text
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok and report.max_error_cycles == 0 and report.pulses >= 24 * 30, report.mismatches[:5]
