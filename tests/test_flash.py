"""`servoc flash`: its arguments, its errors, and what it hands to stcgal, without a board.

stcgal is never imported for real: a fake `stcgal.frontend` module in
`sys.modules` records the options `StcGal` is built with and the bytes of the
HEX file it is given, and returns the exit status the test chooses. The
Atmel chips get the exact command line of `Chip.flash`, with the real path.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import types
from pathlib import Path

import pytest

from servoc import api, cli, flash
from servoc.target import CHIPS

pytestmark = pytest.mark.toolchain        # compiling runs SDCC's assembler

PROGRAM = """{target}frame 10ms
servo arm  = P1.0
servo grip = P1.1 speed 0.3s/60deg
pose rest {{ arm: 0, grip: 0 }}
pose reach {{ arm: 100, grip: 50 }}
main {{
  move rest
  move reach in 500ms
  hold 100ms
  move rest
}}
"""


def program(tmp_path: Path, target: str = "", name: str = "arm.servo") -> Path:
    path = tmp_path / name
    path.write_text(PROGRAM.format(target=f"target {target}\n" if target else ""))
    return path


def run(args: list[str], capsys) -> tuple[int, str, str]:
    rc = cli.main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err and "internal error" not in out + err
    return rc, out, err


def compiled_hex(path: Path) -> str:
    source, reporter = api.load_source(str(path))
    _, firmware = api.build(source, reporter)
    assert firmware is not None
    return firmware.hex_text


class FakeStcgal:
    """Installs fake `stcgal` and `stcgal.frontend` modules; records every StcGal made and run."""

    def __init__(self, monkeypatch, rc: int = 0):
        self.runs: list[dict] = []
        fake = self

        class StcGal:
            def __init__(self, opts):
                self.opts = opts

            def run(self):
                image = self.opts.code_image
                fake.runs.append({"opts": self.opts, "name": image.name, "data": image.read(),
                                  "mode": getattr(image, "mode", None)})
                print("Waiting for MCU, please cycle power: done")
                if rc:
                    print("Serial port error: could not open port", file=sys.stderr)
                return rc

        package = types.ModuleType("stcgal")
        frontend = types.ModuleType("stcgal.frontend")
        frontend.StcGal = StcGal
        package.frontend = frontend
        monkeypatch.setitem(sys.modules, "stcgal", package)
        monkeypatch.setitem(sys.modules, "stcgal.frontend", frontend)


@pytest.fixture
def no_stcgal(monkeypatch):
    monkeypatch.setitem(sys.modules, "stcgal", None)          # `import stcgal` raises ImportError
    monkeypatch.setitem(sys.modules, "stcgal.frontend", None)


# ---- the module's pure parts ----------------------------------------------------------------

def test_which_chips_use_stcgal():
    assert {name for name, chip in CHIPS.items() if flash.uses_stcgal(chip)} == {"stc89c52rc", "stc89c58rd"}
    assert all(chip.six_t == flash.uses_stcgal(chip) for chip in CHIPS.values())


@pytest.mark.parametrize("name, want", [
    ("at89s52", "avrdude -c usbasp -p 89s52 -U flash:w:/tmp/out/prog.hex:i"),
    ("at89c52", "minipro -p AT89C52 -w /tmp/out/prog.hex"),
    ("at89c55wd", "minipro -p AT89C55WD -w /tmp/out/prog.hex"),
])
def test_command_puts_the_real_path_in(name, want):
    assert flash.command(CHIPS[name], "/tmp/out/prog.hex") == want


def test_command_quotes_a_path_with_spaces():
    cmd = flash.command(CHIPS["at89s52"], "/tmp/my boards/leg.hex")
    assert shlex.split(cmd) == ["avrdude", "-c", "usbasp", "-p", "89s52", "-U", "flash:w:/tmp/my boards/leg.hex:i"]


def test_stcgal_options_are_those_of_its_command_line(tmp_path):
    hex_file = tmp_path / "a.hex"
    hex_file.write_text(":00000001FF\n")
    with open(hex_file, "rb") as image:
        opts = flash.stcgal_options("/dev/ttyUSB1", image, 57600, six_t=True)
    assert isinstance(opts, argparse.Namespace)
    # every attribute stcgal's own parser sets (stcgal 1.10, frontend.cli), nothing else
    assert set(vars(opts)) == {"code_image", "eeprom_image", "erase", "autoreset", "resetpin", "resetcmd",
                               "protocol", "port", "baud", "handshake", "option", "trim", "debug", "version"}
    assert (opts.protocol, opts.port, opts.baud, opts.handshake) == ("stc89", "/dev/ttyUSB1", 57600, 2400)
    assert opts.code_image is image and opts.eeprom_image is None and not opts.erase and not opts.version
    assert opts.option == ["cpu_6t_enabled=true"]
    with open(hex_file, "rb") as image:
        assert flash.stcgal_options("COM3", image).option == ["cpu_6t_enabled=false"]


# ---- the command line -----------------------------------------------------------------------

def test_flash_is_a_listed_command(capsys):
    rc, out, _ = run(["--help"], capsys)
    assert rc == 0 and "flash" in out and "servoc flash prog.servo --port /dev/ttyUSB0" in out
    rc, out, _ = run(["flash", "--help"], capsys)
    assert rc == 0 and all(opt in out for opt in ("--port PORT", "-o OUT.hex", "--baud N", "--format"))


def test_stc_flash_hands_stcgal_the_compiled_hex(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB0"], capsys)
    assert rc == 0, err
    hex_path = tmp_path / "arm.hex"
    assert len(fake.runs) == 1
    handed = fake.runs[0]
    assert handed["data"].decode("ascii") == compiled_hex(path) == hex_path.read_text()
    assert Path(handed["name"]) == hex_path and handed["mode"] == "rb"
    opts = handed["opts"]
    assert (opts.protocol, opts.port, opts.baud, opts.handshake) == ("stc89", "/dev/ttyUSB0", 115200, 2400)
    assert opts.option == ["cpu_6t_enabled=false"]
    assert "Waiting for MCU" in out                        # stcgal speaks to the user directly
    last = out.splitlines()[-1]
    assert last.startswith(f"{hex_path}: 2 servos on P1, P = 10 ms (frame; shortest ")
    assert last.endswith("program 86 frames = 860 ms; written to the STC89C52RC on /dev/ttyUSB0")
    assert "power-cycle the board" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.hex", "arm.servo"]      # no temporary left


def test_stc_flash_with_output_baud_and_6t(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c58rd clock 6MHz mode 6T")
    out_hex = tmp_path / "fw.ihx"
    rc, out, err = run(["flash", path, "--port", "COM3", "-o", out_hex, "--baud", "19200"], capsys)
    assert rc == 0, err
    opts = fake.runs[0]["opts"]
    assert (opts.port, opts.baud, opts.option) == ("COM3", 19200, ["cpu_6t_enabled=true"])
    assert fake.runs[0]["data"] == out_hex.read_bytes() and not (tmp_path / "arm.hex").exists()
    assert "6T mode" in err and "STC89C58RD+" in out


def test_stc_flash_json(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", "--format", "json", path, "--port", "/dev/ttyUSB0"], capsys)
    assert rc == 0 and len(fake.runs) == 1
    data = json.loads(out)                                  # stcgal's chatter does not break the result
    assert data == {"file": str(path), "hex": str(tmp_path / "arm.hex"), "chip": "STC89C52RC", "six_t": False,
                    "flashed": True, "port": "/dev/ttyUSB0", "baud": 115200, "command": None,
                    "stcgal_output": "Waiting for MCU, please cycle power: done\n"}
    assert json.loads(err) == {"diagnostics": [], "summary": {"errors": 0, "warnings": 0, "notes": 0}}


def test_stc_flash_that_fails_exits_1(tmp_path, capsys, monkeypatch):
    FakeStcgal(monkeypatch, rc=1)
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB9"], capsys)
    assert rc == 1 and "Serial port error" in err
    assert "servoc: error: stcgal could not write" in err and "/dev/ttyUSB9" in err
    rc, out, err = run(["flash", "--format", "json", path, "--port", "/dev/ttyUSB9"], capsys)
    data = json.loads(out)
    assert rc == 1 and data["flashed"] is False and "Serial port error" in data["stcgal_output"]
    assert "error" not in json.loads(err)


def test_stc_flash_without_port_exits_2(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c52rc")
    for port in ([], ["--port", ""]):
        rc, out, err = run(["flash", path, *port], capsys)
        assert rc == 2 and out == ""
        assert err.startswith("servoc: error: the STC89C52RC is written through its serial bootloader: "
                              "name its serial port with --port")
    rc, out, err = run(["flash", "--format", "json", path], capsys)
    data = json.loads(err)
    assert rc == 2 and out == "" and data["error"]["kind"] == "usage" and "--port" in data["error"]["message"]
    assert fake.runs == [] and not (tmp_path / "arm.hex").exists()


def test_stc_flash_without_stcgal_exits_2(tmp_path, capsys, no_stcgal):
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB0"], capsys)
    assert rc == 2 and out == ""
    assert err == "servoc: error: servoc flash needs stcgal: pip install 'servoc[flash]'\n"
    rc, out, err = run(["flash", "--format", "json", path, "--port", "/dev/ttyUSB0"], capsys)
    assert rc == 2 and json.loads(err)["error"] == {"kind": "missing-extra", "message": flash.MISSING}
    assert not (tmp_path / "arm.hex").exists()


def test_stcgal_needs_a_hex_name(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB0", "-o", tmp_path / "fw.bin"], capsys)
    assert rc == 2 and "*.hex" in err and fake.runs == [] and not (tmp_path / "fw.bin").exists()


@pytest.mark.parametrize("target, want", [
    ("at89s52", "avrdude -c usbasp -p 89s52 -U flash:w:HEX:i"),
    ("", "minipro -p AT89C52 -w HEX"),
    ("at89c55wd", "minipro -p AT89C55WD -w HEX"),
])
def test_atmel_flash_prints_the_command(tmp_path, capsys, no_stcgal, target, want):
    path = program(tmp_path, target)
    rc, out, err = run(["flash", path], capsys)
    hex_path = tmp_path / "arm.hex"
    assert rc == 0 and err == ""
    first, command = out.splitlines()
    assert command == want.replace("HEX", str(hex_path))
    assert first.startswith(f"{hex_path}: written. servoc does not program the ")
    assert hex_path.read_text() == compiled_hex(path)
    if target == "at89s52":
        assert "avrdude 7.1 or later" in first and "drives reset active-high" in first


def test_atmel_flash_with_output_json_and_ignored_port(tmp_path, capsys, no_stcgal):
    path = program(tmp_path, "at89s52")
    out_hex = tmp_path / "build dir" / "leg.hex"
    out_hex.parent.mkdir()
    rc, out, err = run(["flash", "--format", "json", path, "-o", out_hex], capsys)
    data = json.loads(out)
    assert rc == 0 and data["flashed"] is False and data["chip"] == "AT89S52" and data["hex"] == str(out_hex)
    assert shlex.split(data["command"])[-1] == f"flash:w:{out_hex}:i" and out_hex.exists()
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB0", "-o", out_hex], capsys)
    assert rc == 0 and "--port is for the STC89's serial bootloader; ignored for the AT89S52" in err


def test_compile_errors_exit_1_without_flashing(tmp_path, capsys, monkeypatch):
    fake = FakeStcgal(monkeypatch)
    path = tmp_path / "bad.servo"
    path.write_text(PROGRAM.format(target="target stc89c52rc\n").replace("move reach in 500ms", "move reach in 50ms"))
    rc, out, err = run(["flash", path, "--port", "/dev/ttyUSB0"], capsys)
    assert rc == 1 and out == "" and "[infeasible-speed]" in err
    assert fake.runs == [] and not (tmp_path / "bad.hex").exists()


@pytest.mark.parametrize("args, words", [
    (["flash", "PROG", "--baud", "12345"], "--baud 12345 is not a rate stcgal can ask for"),
    (["flash", "PROG", "--baud", "300"], "--baud 300 is not a rate stcgal can ask for"),
    (["flash", "PROG", "--baud", "fast"], "invalid int value"),
    (["flash", "PROG", "-o", "PROG"], "cannot write PROG: it is the program, PROG (-o)"),
    (["flash", "PROG", "-o", "DIR/missing/x.hex"], "does not exist (-o)"),
    (["flash", "DIR/nope.servo", "--port", "/dev/ttyUSB0"], "No such file"),
    (["flash"], "the following arguments are required: FILE.servo"),
    (["flsh", "PROG"], "did you mean `servoc flash`"),
])
def test_flash_usage_errors_before_any_work(tmp_path, capsys, monkeypatch, args, words):
    fake = FakeStcgal(monkeypatch)
    path = program(tmp_path, "stc89c52rc")

    def forbidden(*_):
        raise AssertionError("servoc compiled before checking its arguments")
    monkeypatch.setattr(cli.api, "build", forbidden)
    sub = lambda a: a.replace("PROG", str(path)).replace("DIR", str(tmp_path))  # noqa: E731
    before = sorted(p.name for p in tmp_path.iterdir())
    rc, out, err = run([sub(a) for a in args], capsys)
    assert rc == 2 and out == "" and "servoc: error: " in err and sub(words) in err, err
    assert fake.runs == [] and sorted(p.name for p in tmp_path.iterdir()) == before


def test_real_stcgal_takes_the_options(tmp_path, capsys):
    """The real stcgal (in the test extra) runs its own StcGal on servoc's options and reports a
    port that does not exist; servoc exits with 1."""
    import stcgal.frontend  # noqa: F401  (the test extra installs it: this must not be skipped)
    path = program(tmp_path, "stc89c52rc")
    rc, out, err = run(["flash", path, "--port", tmp_path / "no-such-port"], capsys)
    assert rc == 1 and "Serial port error" in err and "servoc: error: stcgal could not write" in err
