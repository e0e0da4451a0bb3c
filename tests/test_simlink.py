"""`servoc sim`: the firmware in ucsim, its UART on a pseudo-terminal, driven by a real client.

The client here is what any host program does: os.open the printed path, make it raw with
termios, write bytes, read the answers. Each test starts `servoc sim` as a subprocess (its
signals and its exit status are part of what is checked) and takes a few seconds of real time.
"""

from __future__ import annotations

import os
import re
import select
import signal
import subprocess
import sys
import termios
import time
import tty
from pathlib import Path

import pytest

from servoc import cli

pytestmark = pytest.mark.toolchain

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "examples" / "serial_arm.servo"

BUTTON = """\
serial 4800
input button = P3.2
servo arm = P1.0
pose low { arm: 30deg }
pose high { arm: 150deg }
main {
  move low
  send "R"
  loop {
    select {
      on press button { send "P" }
      on "h" { move high; send "H" }
      on other { send "?" }
    }
  }
}
"""


class Sim:
    """`servoc sim ARGS` as a subprocess: its output lines as they come, and the serial line."""

    def __init__(self, args: list[str], tmp: Path):
        self.tmp = tmp / "tmpdir"
        self.tmp.mkdir()
        env = dict(os.environ, TMPDIR=str(self.tmp), PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen([sys.executable, "-m", "servoc", "sim", *args], cwd=ROOT, env=env,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.lines: list[str] = []
        self.cursor = 0                     # lines before it are read
        self.eof = False
        self._buf = b""
        self.fd: int | None = None
        self.got = b""

    def _pump(self, timeout: float) -> None:
        fds = [self.proc.stdout] + ([self.fd] if self.fd is not None else [])
        ready, _, _ = select.select(fds, [], [], timeout)
        if self.proc.stdout in ready:
            data = os.read(self.proc.stdout.fileno(), 65536)
            self.eof = not data
            self._buf += data
            *done, self._buf = self._buf.split(b"\n")
            self.lines += [ln.decode() for ln in done]
        if self.fd is not None and self.fd in ready:
            try:
                self.got += os.read(self.fd, 4096)
            except OSError:
                pass

    def wait_line(self, pattern: str, timeout: float = 15) -> re.Match:
        """The next line (after the last one matched) that matches `pattern`."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for k in range(self.cursor, len(self.lines)):
                m = re.search(pattern, self.lines[k])
                if m:
                    self.cursor = k + 1
                    return m
            if self.eof:
                break
            self._pump(0.1)
        raise AssertionError(f"no line matching {pattern!r}; output so far:\n" + "\n".join(self.lines)
                             + "\nstderr: " + self.stderr_if_done())

    def stderr_if_done(self) -> str:
        return self.proc.stderr.read().decode() if self.proc.poll() is not None else "(still running)"

    def open(self, path: str) -> None:
        """Open the serial line as a host program would."""
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        attrs = termios.tcgetattr(self.fd)
        attrs[4] = attrs[5] = termios.B9600
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)

    def read(self, n: int, timeout: float = 10) -> bytes:
        end = time.monotonic() + timeout
        while len(self.got) < n and time.monotonic() < end:
            self._pump(0.05)
        data, self.got = self.got[:n], self.got[n:]
        return data

    def send(self, data: bytes) -> None:
        os.write(self.fd, data)

    def finish(self, timeout: float = 15) -> tuple[int, str, str]:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        out, err = self.proc.communicate(timeout=timeout)
        self.lines += (self._buf + out).decode().splitlines()
        self._buf = b""
        return self.proc.returncode, "\n".join(self.lines), err.decode()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def children(pid: int) -> list[int]:
    """The processes whose parent is `pid` (ucsim, under servoc sim)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                found.append(int(entry))
    return found


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_a_host_drives_the_example_arm_through_the_pty_and_link(tmp_path):
    """examples/serial_arm.servo: the arm answers "R" at power-up; "l" turns the base (seen in the
    pulses) and is answered "L" once it is there; a byte no command uses is dropped. The link names
    the pty; the speed line comes every few seconds; SIGTERM ends it with 0 and removes the link,
    the FIFOs and ucsim."""
    link = tmp_path / "ttyARM"
    sim = Sim([str(ARM), "--link", str(link), "--view", "--view-every", "10"], tmp_path)
    try:
        path = sim.wait_line(r"^serial: (/dev/\S+)$").group(1)
        sim.wait_line(rf"^link: {re.escape(str(link))} -> {re.escape(path)}$")
        assert os.readlink(link) == path
        sim.wait_line(r"^baud: 9600, 8 data bits, no parity, 1 stop bit$")
        sim.open(str(link))                 # through the fixed name, as a host configured once would
        assert sim.read(1) == b"R"
        ucsim = children(sim.proc.pid)
        assert len(ucsim) == 1 and alive(ucsim[0])
        assert sim.wait_line(r"^view: .* base (\d+) ").group(1) == "1476"        # 90°: N 122
        sim.send(b"x")                      # no `on` names it: dropped, no answer
        sim.send(b"l")
        assert sim.read(1) == b"L"
        # the base goes to 150°: N 203, 2124 µs (in machine cycles of 11.0592 MHz, within 1 µs)
        sim.wait_line(r"^view: .* base 212[345] ")
        assert sim.read(1, timeout=0.3) == b""          # nothing for the "x"
        speed = sim.wait_line(r"^speed: (\d+\.\d+)x real time \(the last", timeout=10)
        assert float(speed.group(1)) > 0.1
        assert sim.tmp.exists() and any(sim.tmp.iterdir())      # the FIFOs, while it runs
        sim.proc.send_signal(signal.SIGTERM)
        rc, out, err = sim.finish()
    finally:
        sim.kill()
    assert rc == 0, err
    assert "Traceback" not in err
    assert re.search(r"^speed: \d+\.\d+x real time \(\d+\.\d+ s simulated in \d+\.\d+ s; stopped\)$", out, re.M)
    assert not os.path.lexists(link)
    assert list(sim.tmp.iterdir()) == []
    assert not alive(ucsim[0])


@pytest.mark.parametrize("head", ["serial 4800\n", "target stc89c52rc clock 11.0592MHz mode 6T\nserial 9600\n"],
                         ids=["12MHz", "6T"])
def test_bytes_go_through_unchanged_and_seconds_end_the_run(tmp_path, head):
    """Every byte value reaches the firmware, 0x18 (ucsim's menu key on a terminal) and 0xFF
    included; --seconds stops at that simulated time, exit 0; on a 6T chip too, whose cycle is
    6 clocks (ucsim runs it as the 12-clock core at twice the crystal)."""
    prog = tmp_path / "button.servo"
    prog.write_text(BUTTON.replace("serial 4800\n", head, 1))
    sim = Sim([str(prog), "--seconds", "2.5"], tmp_path)
    try:
        sim.open(sim.wait_line(r"^serial: (/dev/\S+)$").group(1))
        assert sim.read(1) == b"R"
        sim.send(b"\x18\x00\xff\x11")         # at most 4 back to back: what the queue promises
        assert sim.read(4) == b"????"
        sim.send(b"\x13\r\n")
        assert sim.read(3) == b"???"
        sim.send(b"h")
        assert sim.read(1) == b"H"
        rc, out, err = sim.finish()
    finally:
        sim.kill()
    assert rc == 0, err
    assert re.search(r"^speed: \d+\.\d+x real time \(2\.50 s simulated in \d+\.\d+ s; the time asked for is over\)$",
                     out, re.M), out
    assert list(sim.tmp.iterdir()) == []


def test_events_drive_the_inputs_and_send_bytes(tmp_path):
    """--events: a press at 300 ms is answered "P", a byte at 600 ms "?", at those simulated times."""
    prog = tmp_path / "button.servo"
    prog.write_text(BUTTON)
    events = tmp_path / "run.events"
    events.write_text('300ms button active\n400ms button inactive\n600ms "z"\n')
    sim = Sim([str(prog), "--events", str(events), "--seconds", "1"], tmp_path)
    try:
        sim.open(sim.wait_line(r"^serial: (/dev/\S+)$").group(1))
        assert sim.read(3) == b"RP?"
        rc, out, err = sim.finish()
    finally:
        sim.kill()
    assert rc == 0, err


def test_bytes_sent_while_no_host_has_the_line_open_wait_for_the_next_host(tmp_path):
    """What the firmware sends before a host opens the line (the power-up "R", a press's "P"), or
    between two hosts, is read by the next host, although pyserial empties the input as it opens
    the port. The speed lines say how far the simulation has run: each host opens only after the
    bytes it must read were sent."""
    import serial       # pyserial, one of the test tools
    prog = tmp_path / "button.servo"
    prog.write_text(BUTTON)
    events = tmp_path / "run.events"
    events.write_text("300ms button active\n400ms button inactive\n12s button active\n12.1s button inactive\n")
    sim = Sim([str(prog), "--events", str(events), "--seconds", "40"], tmp_path)
    simulated = r"^speed: .*; (\d+\.\d+) s simulated in"
    try:
        path = sim.wait_line(r"^serial: (/dev/\S+)$").group(1)
        while (at := float(sim.wait_line(simulated).group(1))) < 0.4:
            pass
        assert at < 11, "the simulation ran too far ahead for this test"
        with serial.Serial(path, 4800, timeout=10) as port:
            assert port.read(2) == b"RP"
        while float(sim.wait_line(simulated).group(1)) < 12.1:
            pass
        with serial.Serial(path, 4800, timeout=10) as port:
            assert port.read(1) == b"P"
            port.write(b"z")
            assert port.read(1) == b"?"
        sim.proc.send_signal(signal.SIGTERM)
        rc, _, err = sim.finish()
    finally:
        sim.kill()
    assert rc == 0, err


def run_cli(args: list[str], capsys) -> tuple[int, str, str]:
    rc = cli.main(args)
    out, err = capsys.readouterr()
    return rc, out, err


def test_a_program_without_serial_is_refused(capsys):
    rc, out, err = run_cli(["sim", str(ROOT / "examples" / "greeter.servo")], capsys)
    assert rc == 2 and out == ""
    assert err.startswith("servoc: error: ") and "declares no serial line" in err and "`serial BAUD`" in err


def test_a_program_with_errors_exits_1(tmp_path, capsys):
    prog = tmp_path / "bad.servo"
    prog.write_text("serial 4800\nservo arm = P1.0\nmain { move nowhere }\n")
    rc, out, err = run_cli(["sim", str(prog)], capsys)
    assert rc == 1 and "error:" in err and "Traceback" not in err


@pytest.mark.parametrize("args, message", [
    (["--seconds", "0"], "--seconds 0: give a positive number"),
    (["--seconds", "soon"], "--seconds soon: give a positive number"),
    (["--view-every", "0"], "--view-every must be at least 1"),
    (["--link", ""], "--link needs a path"),
    (["--events", "missing.events"], "cannot read missing.events"),
])
def test_usage_errors(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "button.servo").write_text(BUTTON)
    rc, out, err = run_cli(["sim", "button.servo", *args], capsys)
    assert rc == 2 and message in err and "Traceback" not in err


def test_link_never_replaces_a_file(tmp_path, capsys):
    prog = tmp_path / "button.servo"
    prog.write_text(BUTTON)
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    rc, out, err = run_cli(["sim", str(prog), "--link", str(taken)], capsys)
    assert rc == 2 and "is a file, not a symlink" in err
    assert taken.read_text() == "keep me"


def test_events_file_errors_are_usage_errors(tmp_path, capsys):
    prog = tmp_path / "button.servo"
    prog.write_text(BUTTON)
    events = tmp_path / "bad.events"
    events.write_text("100ms nobody active\n")
    rc, out, err = run_cli(["sim", str(prog), "--events", str(events)], capsys)
    assert rc == 2 and "line 1" in err and "`nobody` is not an input" in err


def test_sim_is_listed_in_help(capsys):
    rc, out, _ = run_cli(["--help"], capsys)
    assert rc == 0 and re.search(r"^\s+sim\s+run the firmware in ucsim", out, re.M)
    rc, out, _ = run_cli(["sim", "--help"], capsys)
    assert rc == 0 and "--link" in out and "--seconds" in out and "--view" in out
