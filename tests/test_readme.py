"""Every command and every output shown in the README is what servoc really does."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from servoc.cli import main

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", README, re.S)


def run_cli(args, capsys):
    code = main(args)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_quick_start_test_command_is_what_ci_runs():
    quick = blocks("sh")[0].split("\n")
    assert quick[1].strip() == "./dev test"
    assert "./dev test" in (ROOT / ".ci" / "run").read_text()


@pytest.mark.toolchain
def test_quick_start_main_job_runs():
    first = blocks("sh")[0].split("\n")[0].split()
    assert first[:2] == ["./dev", "servoc"]
    proc = subprocess.run(first, cwd=ROOT, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    assert "OK:" in proc.stdout and "max error 0 cycles" in proc.stdout


@pytest.mark.toolchain
def test_servoc_commands_in_readme_work(tmp_path, monkeypatch, capsys):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    commands = [line.split()[1:] for line in blocks("sh")[1].strip().split("\n")]
    assert commands and all(line for line in commands)
    for args in commands:
        code, out, err = run_cli(args, capsys)
        assert code == 0, (args, err)
        for i, arg in enumerate(args):
            if arg in ("-o", "--asm", "--plot", "--vcd"):
                assert os.path.getsize(args[i + 1]) > 0, args
    assert (tmp_path / "arm.servo").exists()


@pytest.mark.toolchain
def test_first_program_outputs_match(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    program = blocks("servo")[0]
    shown = blocks("text")
    (tmp_path / "prog.servo").write_text(program, encoding="utf-8")
    code, out, err = run_cli(["compile", "prog.servo"], capsys)
    assert code == 1 and err == shown[0] and not (tmp_path / "prog.hex").exists()
    lines = program.split("\n")
    assert "With `in 124ms`" in README
    lines[10] = "  move crouch in 124ms ease in-out"
    (tmp_path / "prog.servo").write_text("\n".join(lines), encoding="utf-8")
    code, out, err = run_cli(["compile", "prog.servo"], capsys)
    assert code == 0 and err == shown[1]
    (tmp_path / "prog.hex").unlink()
    fixed = "move crouch in 345ms ease in-out"
    assert f"`{fixed}` on line 11" in README
    lines[10] = "  " + fixed
    (tmp_path / "prog.servo").write_text("\n".join(lines), encoding="utf-8")
    code, out, err = run_cli(["plan", "prog.servo"], capsys)
    assert code == 0 and out == shown[2]
    code, out, err = run_cli(["compile", "prog.servo"], capsys)
    assert code == 0 and out == shown[3] and err == "" and (tmp_path / "prog.hex").exists()
    code, out, err = run_cli(["verify", "prog.servo"], capsys)
    assert code == 0 and out == shown[4]


@pytest.mark.toolchain
def test_other_crystal_session_matches(tmp_path, monkeypatch, capsys):
    """The README's STC89C52RC session at 11.0592 MHz: each `$ servoc` line and what it prints."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    (session,) = blocks("console")
    steps = re.findall(r"^\$ servoc (.*)\n((?:[^$].*\n)*)", session, re.M)
    assert [args.split()[0] for args, _ in steps] == ["compile", "verify"]
    for args, shown in steps:
        code, out, err = run_cli(args.split(), capsys)
        assert code == 0 and out == shown, (args, out, err)


def test_events_sessions_match(capsys):
    """The README's `servoc verify --events` sessions: the greeter (inputs) and the serial hexapod."""
    sessions = re.findall(r"```text\n\$ servoc (verify [^\n]*--events[^\n]*)\n(.*?)```", README, re.S)
    assert [s[0].split()[1] for s in sessions] == ["examples/greeter.servo", "examples/hexapod_serial.servo"]
    for command, shown in sessions:
        args = [a if not a.startswith("examples/") else str(ROOT / a) for a in command.split()]
        code, out, err = run_cli(args, capsys)
        assert code == 0 and out.replace(str(ROOT) + "/", "") == shown, (out, err)


def test_import_session_matches(tmp_path, monkeypatch, capsys):
    """The README's `servoc import` session: what it prints, and the program it writes lints clean."""
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    (command, shown), = re.findall(r"```text\n\$ servoc (import [^\n]*)\n(.*?)```", README, re.S)
    code, out, err = run_cli(command.split(), capsys)
    assert code == 0 and out == shown, (out, err)
    out_file = command.split()[command.split().index("-o") + 1]
    code, out, err = run_cli(["lint", out_file], capsys)
    assert code == 0 and err.endswith("0 errors, 0 warnings, 1 note\n") and "[no-home]" in err
