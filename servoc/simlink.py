"""`servoc sim`: the firmware runs in ucsim with its UART on a pseudo-terminal, so that any host
program can open it as it would `/dev/ttyUSB0`.

Input
    `Setup`: the Intel HEX image, the target's clock, the serial rate, the servos (for `--view`),
    the outside levels of the input pins and the bytes of an events file at their machine cycles,
    and how long to run (`seconds`, None: until `request_stop`, SIGINT, SIGTERM or SIGHUP).

Output
    Lines on `out`: the pseudo-terminal's path (and `--link`), the baud rate, every few seconds
    and at the end how fast the simulation runs against real time, and with `view` one line per
    N frames with each servo's pulse width. A warning on `err` when it runs slower than real time.
    `run` returns a `Summary`; it raises `LinkError` when ucsim cannot run the firmware.

How the bytes flow
    host --> pty slave --> pty master (here) --> rx.fifo --> ucsim's UART input
    ucsim's UART output --> tx.fifo --> here --> pty master --> pty slave --> host

    The pseudo-terminal is made raw (termios: no echo, no CR/LF translation, 8 bits; the slave
    keeps these settings while no host has it open) and its master is in packet mode (TIOCPKT).
    A host may open and close the slave as often as it likes. Bytes the firmware sends while no
    host has the slave open wait here (up to `MAX_BACKLOG`; older bytes are dropped, as on a line
    nobody listens to): the master reports POLLHUP while the slave is closed. A host that has
    just opened it usually empties its input (pyserial's open does, and so does `tty.setraw`),
    which would drop what waits in the pty, so bytes wait here until the host has done that (a
    TIOCPKT_FLUSHREAD packet), or has sent a byte, or `SETTLE` seconds after it opened the line.

ucsim 0.6.4 (Debian's sdcc-ucsim), measured for this module with small scripts driving s51:
    * `-S in=FILE,out=FILE` opens FILE with fopen: a FIFO's open blocks until the other end is
      open, so both FIFOs are opened here first with O_RDWR (which never blocks on Linux); the
      read end ucsim holds then never sees end of file (at EOF ucsim drops its input for good).
    * The UART takes a byte from its input file only with its "check input at every cycle" flag
      on (`uart_0_cfg[1]`); it then calls select() on the file before every instruction while the
      receiver is idle, which makes the simulation about 4.4 times slower
      (`benchmarks/sim_speed.py`: 5.3x to 5.6x real time without the flag, 1.25x with it). Without the flag ucsim only reads the file when it polls its consoles, once
      every million instructions (about 1.5 s simulated): one byte per poll. So the flag stays on.
    * A byte is taken from the FIFO when the receiver is idle, starts there and sets RI one byte
      time later: bytes a host writes at once go in back to back at the firmware's rate, in
      simulated time, whatever rate the host set on the pty. 0x18 (the menu key of ucsim's
      serial terminal) and every other byte pass unchanged, as the input is not a terminal.
    * ucsim's command console reads its input only once every million instructions while the
      simulation runs, and any line typed on it then stops the simulation ("User stopped"; the
      line is swallowed). A second console (`-Z PORT`) answers while the simulation runs, but it
      listens on 0.0.0.0 and speaks telnet, so it is not used: the one console is on another
      pseudo-terminal, and the simulation is stopped, asked `state` (its 64-bit clock count) and
      run on again every `REPORT_EVERY` seconds; the stop costs a few milliseconds.
    * `-P` makes the prompt a NUL byte: every command's answer (and every stop message) ends with
      one, and a running simulation prints none (the console that started it is "frozen").
    * A VCD input unit with `break` stops the run at an exact time (as in sim.py); the stop is
      reported as "(104) Breakpoint". It stops `--seconds` and applies the events file: pins with
      `set hardware port[N]`, bytes written to the FIFO while stopped, so the first one starts
      at the event's time.
    * Breakpoints on the ports' SFR and bit writes whose commands print `sim_ticks` and the latch
      and `run` on (`--view`) keep the console frozen; their cost is within the run-to-run
      spread of `benchmarks/sim_speed.py`.
    * `sim_ticks` is 32 bits (wraps after 357 s at 12 MHz); `state` prints the 64-bit count. The
      "Simulated N ticks" of a stop message counts from the last `run`, which each --view
      breakpoint restarts: the clock is always read with `state`.
    * A line typed on the console before the -C script has run can go unanswered (seen at
      start-up; ucsim sets up its console's terminal then, which may flush it): see `_start`.
"""

from __future__ import annotations

import collections
import errno
import fcntl
import os
import re
import select
import shutil
import signal
import struct
import subprocess
import tempfile
import termios
import time
import tty
from dataclasses import dataclass
from fractions import Fraction
from typing import TextIO

from .sim import CLOCKS_PER_CYCLE, CPU_TYPE, PORT_SFR, die_with_parent, port_watch
from .toolchain import find_tool

__all__ = ["LinkError", "Setup", "Summary", "run", "request_stop"]

REPORT_EVERY = 3.0          # seconds (real) between two speed lines
MAX_BACKLOG = 1 << 16       # bytes kept for a host that does not read
STARTUP_TIMEOUT = 15.0      # seconds for ucsim to load the image and answer
QUIT_WAIT = 3.0             # seconds to wait for a last clock count when stopping
POLL = 0.1                  # seconds: the longest the loop sleeps
SETTLE = 0.5                # seconds a host that has opened the line has to set it up (see above)

_SYNC = 2718299             # `expr` values this module asks for, to recognise the answers
_STOP_LINE = b"expr 2718277\n"
_MARK = 2718200             # + port: a port write (--view), followed by the ticks and the latch
_CLKS = re.compile(r"\((\d+) clks\)")
_STOP = re.compile(r"Stop at (0x[0-9a-fA-F]+): \((\d+)\) ([^\n]*)")


class LinkError(Exception):
    """The serial line could not be set up, or ucsim could not run the firmware (it did not start,
    did not load the image, or stopped it); the message says which, in full."""


@dataclass(frozen=True)
class Setup:
    hex_text: str
    sim_hz: int                          # ucsim's crystal (a 6T chip runs as the 12-clock core at 2f)
    cycle_us: Fraction                   # one machine cycle
    baud: int                            # `serial BAUD`
    actual_baud: Fraction                # what Timer1 makes at the clock
    seconds: Fraction | None = None      # simulated time to run, None: until stopped
    link: str | None = None              # a symlink to the pty's slave
    servos: tuple = ()                   # the plan's channels (name, port, bit), for --view
    period_us: int = 20000               # frame period, to group pulses into frames (--view)
    view_every: int | None = None        # print the widths of one frame in N; None: no view
    pins: tuple[tuple[int, int, int], ...] = ()      # (cycle, port, outside level) of the input pins
    rx: tuple[tuple[int, bytes], ...] = ()           # (cycle, bytes) the events file sends


@dataclass
class Summary:
    sim_seconds: float = 0.0
    real_seconds: float = 0.0
    reason: str = ""                     # "time" (--seconds) or "signal" (a stop request)

    @property
    def factor(self) -> float:
        return self.sim_seconds / self.real_seconds if self.real_seconds > 0 else 0.0


_stop_requested = False


def request_stop(*_args) -> None:
    """Ask a running `run` to stop and clean up (the SIGINT/SIGTERM/SIGHUP handler)."""
    global _stop_requested
    _stop_requested = True


def run(setup: Setup, out: TextIO, err: TextIO) -> Summary:
    """Run the firmware until `setup.seconds` of simulated time, or a stop request; always removes
    the FIFOs, the link and the ucsim process. Raises LinkError (with the whole message) and
    `toolchain.ToolNotFound`; BrokenPipeError when `out` is closed."""
    global _stop_requested
    _stop_requested = False
    s51 = find_tool("s51")
    link = _Link(setup, out, err)
    handlers = _install_handlers()
    try:
        return link.run(s51)
    finally:
        link.close()
        _restore_handlers(handlers)


def _install_handlers() -> dict:
    saved = {}
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            saved[sig] = signal.signal(sig, request_stop)
        except (ValueError, OSError):       # not the main thread: the caller stops it
            pass
    return saved


def _restore_handlers(saved: dict) -> None:
    for sig, handler in saved.items():
        try:
            signal.signal(sig, handler)
        except (ValueError, OSError, TypeError):
            pass


def _raw(fd: int, baud: int | None = None) -> None:
    tty.setraw(fd)
    if baud is not None:
        speed = getattr(termios, f"B{baud}", None)
        if speed is not None:
            attrs = termios.tcgetattr(fd)
            attrs[4] = attrs[5] = speed
            termios.tcsetattr(fd, termios.TCSANOW, attrs)


def _nonblocking(fd: int) -> None:
    fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) | os.O_NONBLOCK)


def _fmt_s(seconds: float) -> str:
    return f"{seconds:.2f} s"


class _Link:
    def __init__(self, setup: Setup, out: TextIO, err: TextIO):
        self.setup, self.out, self.err = setup, out, err
        self.tmp: str | None = None
        self.proc: subprocess.Popen | None = None
        self.fds: list[int] = []
        self.linked = False
        self.slave_path = ""
        # the host side
        self.master = self.rx = self.tx = -1
        self.to_fifo = bytearray()          # host bytes not yet in rx.fifo
        self.to_host = bytearray()          # firmware bytes not yet in the pty
        self.host = "closed"                # the slave: "closed", "settling" (just opened) or "open"
        self.settle_until = 0.0
        self.hup = select.poll()            # the master's POLLHUP: no host has the slave open
        # the console
        self.con = -1
        self.con_buf = bytearray()
        self.chunk: list[str] = []          # lines since the last prompt (NUL)
        self.pending: collections.deque[str] = collections.deque()     # answers expected, in order
        self.running = False
        self.stop_sent = False              # a line that stops the run is on its way
        # time
        self.real_start = 0.0
        self.clks = 0                       # ucsim's clock at the last `state`
        self.clks_real = 0.0                # and the real time (monotonic) it was read at
        self.last = (0.0, 0)                # (real, clks) of the last speed line
        self.last_report = 0.0
        self.warned = False
        self.finished = ""                  # why the run ended
        self.quit_deadline: float | None = None
        # events and the limit, in machine cycles
        cycles_limit = None
        if setup.seconds is not None:
            cycles_limit = max(1, int(-(-Fraction(setup.seconds) * 1_000_000 // setup.cycle_us)))
        self.limit = cycles_limit
        start_pins = [p for p in setup.pins if p[0] <= 1]
        self.start_pins = start_pins
        self.pins = collections.deque(p for p in setup.pins if p[0] > 1 and (self.limit is None or p[0] < self.limit))
        self.bytes_due = collections.deque(b for b in setup.rx if self.limit is None or b[0] < self.limit)
        # --view
        self.marks: list[str] | None = None   # the lines of a port write being read
        self.levels = {p: 0xFF for p in PORT_SFR}
        self.wrap = 0
        self.last_ticks = 0
        self.rise: dict[int, int] = {}
        self.frame_start: int | None = None
        self.frame_widths: dict[int, int] = {}
        self.frames = 0
        self.period_cycles = max(2, int(Fraction(setup.period_us) / setup.cycle_us))

    # ---- set-up and clean-up ------------------------------------------------------------------

    def run(self, s51: str) -> Summary:
        try:
            self._set_up(s51)
        except OSError as exc:
            raise LinkError(f"cannot set up the serial line: {exc.strerror or exc}"
                            + (f" ({exc.filename})" if exc.filename else "")) from None
        self._start()
        self._announce()
        try:
            return self._loop()
        except BrokenPipeError:                 # our standard output: the caller's to handle
            raise
        except OSError as exc:
            raise LinkError(f"the serial line failed: {exc.strerror or exc}") from None

    def _set_up(self, s51: str) -> None:
        """The FIFOs, the image, ucsim's script, both pseudo-terminals, ucsim itself and the link."""
        s = self.setup
        self.tmp = tempfile.mkdtemp(prefix="servoc-sim-")
        for name in ("rx.fifo", "tx.fifo"):
            os.mkfifo(os.path.join(self.tmp, name), 0o600)
        # O_RDWR: never blocks, and ucsim never sees the other end closed
        self.rx = self._keep(os.open(os.path.join(self.tmp, "rx.fifo"), os.O_RDWR | os.O_NONBLOCK))
        self.tx = self._keep(os.open(os.path.join(self.tmp, "tx.fifo"), os.O_RDWR | os.O_NONBLOCK))
        with open(os.path.join(self.tmp, "fw.ihx"), "w", encoding="ascii") as f:
            f.write(s.hex_text)
        stops = sorted({at for at, _, _ in self.pins} | {at for at, _ in self.bytes_due}
                       | ({self.limit} if self.limit is not None else set()))
        if stops:
            with open(os.path.join(self.tmp, "stops.vcd"), "w", encoding="ascii") as f:
                f.write(_stops_vcd(stops, s.sim_hz))
        with open(os.path.join(self.tmp, "setup.cmd"), "w", encoding="ascii") as f:
            f.write(self._script(bool(stops)))

        self.master, slave = os.openpty()
        self._keep(self.master)
        try:
            _raw(slave, s.baud)
            self.slave_path = os.ttyname(slave)
        finally:
            os.close(slave)                 # a host's open ends the master's POLLHUP
        _nonblocking(self.master)
        fcntl.ioctl(self.master, termios.TIOCPKT, struct.pack("i", 1))
        self.hup.register(self.master, select.POLLIN)
        try:
            os.chmod(self.slave_path, 0o600)    # no `write`/`wall` messages into the serial line
        except OSError:
            pass
        con_master, con_slave = os.openpty()
        self.con = self._keep(con_master)
        _raw(con_slave)
        _nonblocking(self.con)
        argv = [s51, "-P", "-b", "-t", CPU_TYPE, "-X", str(s.sim_hz), "-S", "in=rx.fifo,out=tx.fifo",
                "-C", "setup.cmd"]
        try:
            self.proc = subprocess.Popen(argv, cwd=self.tmp, stdin=con_slave, stdout=con_slave, stderr=con_slave,
                                         start_new_session=True, preexec_fn=die_with_parent)
        except OSError as exc:
            raise LinkError(f"cannot start {s51}: {exc.strerror or exc}") from None
        finally:
            os.close(con_slave)
        if s.link:
            self._make_link(s.link)

    def _keep(self, fd: int) -> int:
        self.fds.append(fd)
        return fd

    def _make_link(self, path: str) -> None:
        tmp = os.path.join(os.path.dirname(path) or ".", f".{os.path.basename(path)}.servoc-{os.getpid()}")
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(self.slave_path, tmp)
        try:
            os.replace(tmp, path)           # atomic: a host never sees a half-made name
        except OSError:
            os.unlink(tmp)
            raise
        self.linked = True

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        if self.proc is not None:
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                pass
        if self.tx >= 0 and self.master >= 0:   # what the firmware sent last, for a host still reading
            try:
                self._watch_host(time.monotonic())
                if self.host == "settling":     # the last chance to hand them over
                    self.host = "open"
                self._pump_tx()
                self._pump_host_out()
            except OSError:
                pass
        if self.linked and self.setup.link:
            try:
                if os.path.islink(self.setup.link) and os.readlink(self.setup.link) == self.slave_path:
                    os.unlink(self.setup.link)
            except OSError:
                pass
            self.linked = False
        for fd in self.fds:
            try:
                os.close(fd)
            except OSError:
                pass
        self.fds = []
        if self.tmp is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp = None

    def _script(self, stops: bool) -> str:
        lines = ['file "fw.ihx"',
                 "expr uart_0_cfg[1]=1"]            # check input at every cycle (see the module docstring)
        levels: dict[int, int] = {}
        for _, port, level in self.start_pins:      # inputs inactive from reset
            levels[port] = level
        lines += [f"set hardware port[{port}] {level:#04x}" for port, level in sorted(levels.items())]
        if self.setup.view_every is not None:
            lines += port_watch(sorted({sv.port for sv in self.setup.servos}), _MARK)
        if stops:
            lines += ['set hardware vcd[0] input "stops.vcd"', "set hardware vcd[0] break", "set hardware vcd[0] start"]
        return "\n".join(lines) + "\n"

    # ---- the console ----------------------------------------------------------------------------

    def _send(self, line: str, expect: str | None) -> None:
        self._write_all(self.con, line.encode("ascii") + b"\n")
        if expect is not None:
            self.pending.append(expect)

    @staticmethod
    def _write_all(fd: int, data: bytes) -> None:
        view = memoryview(data)
        deadline = time.monotonic() + 5
        while view:
            try:
                n = os.write(fd, view)
                view = view[n:]
            except BlockingIOError:
                if time.monotonic() > deadline:
                    raise LinkError("ucsim does not read its console") from None
                select.select([], [fd], [], POLL)

    def _start(self) -> None:
        """Wait until ucsim has run the set-up script and answers, then start the run. A line
        typed before ucsim has set up its console can go unanswered: the question is asked again
        every 0.3 s until it is answered (answers to the extra ones come before the run starts, as
        prompts nobody waits for)."""
        deadline = time.monotonic() + STARTUP_TIMEOUT
        asked = 0.0
        text = bytearray()
        while not re.search(rb"(^|\n)%d\n\x00" % _SYNC, text):
            if _stop_requested:
                self.finished = "signal"
                return
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise LinkError(self._failed("did not start", text))
            if time.monotonic() - asked > 0.3:
                self._send(f"expr {_SYNC}", None)
                asked = time.monotonic()
            ready, _, _ = select.select([self.con], [], [], POLL)
            if ready:
                try:
                    text += os.read(self.con, 1 << 16)
                except OSError:
                    pass
        if b"words read from fw.ihx" not in text:
            raise LinkError(self._failed("did not load the firmware", text))
        self._send("run", None)
        self.running = True
        self.real_start = self.last_report = time.monotonic()

    def _failed(self, what: str, text: bytes) -> str:
        status = self.proc.poll()
        tail = [ln.strip() for ln in text.decode("utf-8", "replace").replace("\0", "\n").splitlines()
                if ln.strip() and not ln.startswith(("uCsim", "uCsim comes", "This is free", "under certain"))]
        how = f" (exit status {status})" if status is not None else ""
        return f"ucsim {what}{how}" + (f": {'; '.join(tail[-4:])}" if tail else "")

    def _console_input(self) -> None:
        try:
            data = os.read(self.con, 1 << 16)
        except BlockingIOError:
            return
        except OSError:                         # EIO: ucsim closed its console
            data = b""
        if not data:
            return
        self.con_buf += data
        while True:
            nl, nul = self.con_buf.find(b"\n"), self.con_buf.find(b"\0")
            cut = min(i for i in (nl, nul, len(self.con_buf)) if i >= 0)
            if cut == len(self.con_buf):
                break
            line = self.con_buf[:cut].decode("utf-8", "replace")
            sep = self.con_buf[cut]
            del self.con_buf[:cut + 1]
            if line:
                self._line(line)
            if sep == 0:
                self._prompt()

    def _line(self, line: str) -> None:
        if self.marks is not None:
            self.marks.append(line.strip())
            if len(self.marks) == 3:
                marks, self.marks = self.marks, None
                try:
                    self._port_write(int(marks[0]) - _MARK, int(marks[1]), int(marks[2]))
                except ValueError:
                    pass
            return
        text = line.strip()
        if text.isdigit() and _MARK <= int(text) < _MARK + 4 and self.setup.view_every is not None:
            self.marks = [text]
            return
        if not text.startswith("Simulation started"):     # each `run`, --view's too
            self.chunk.append(line)

    def _prompt(self) -> None:
        """The console printed a prompt: a command's answer, or a stop, is complete."""
        text = "\n".join(self.chunk)
        self.chunk = []
        stop = _STOP.search(text)
        if stop is not None:
            reason = stop.group(3).strip()
            if "User stopped" in reason:
                if self.pending and self.pending[0] == "stop":
                    self.pending.popleft()
                self.stop_sent = False
            elif "Breakpoint" not in reason:        # the VCD stops report as breakpoints
                raise LinkError(f"ucsim stopped the firmware at {stop.group(1)}: {reason}; report this program as "
                                "a bug in servoc")
            self.running = False
            self._send("state", "state")
            return
        if not self.pending:
            return
        kind = self.pending.popleft()
        if kind == "stop":          # the run had stopped already (at an event): the line ran as a command
            self.stop_sent = False
        elif kind == "state":
            m = _CLKS.search(text)
            if m is None:
                raise LinkError(f"unexpected answer from ucsim to `state`: {text.strip()[:200]!r}")
            self._stopped(int(m.group(1)))

    def _stopped(self, clks: int) -> None:
        """The run is stopped at `clks`: apply what is due, report, then run on (or end)."""
        now = time.monotonic()
        self.clks, self.clks_real = clks, now
        cycle = clks // CLOCKS_PER_CYCLE
        levels: dict[int, int] = {}
        while self.pins and self.pins[0][0] <= cycle:
            _, port, level = self.pins.popleft()
            levels[port] = level
        for port, level in sorted(levels.items()):
            self._send(f"set hardware port[{port}] {level:#04x}", "cmd")
        while self.bytes_due and self.bytes_due[0][0] <= cycle:
            self.to_fifo += self.bytes_due.popleft()[1]
        self._pump_fifo()
        if self.limit is not None and cycle >= self.limit:
            self.finished = "time"
            return
        if _stop_requested:
            self.finished = "signal"
            return
        if now - self.last_report >= REPORT_EVERY:
            self._report(now)
        self._send("run", None)
        self.running = True

    def _ask_stop(self) -> None:
        if self.running and not self.stop_sent:
            self._write_all(self.con, _STOP_LINE)
            self.pending.append("stop")
            self.stop_sent = True

    # ---- the speed line --------------------------------------------------------------------------

    def sim_seconds(self, clks: int | None = None) -> float:
        return (self.clks if clks is None else clks) / self.setup.sim_hz

    def _report(self, now: float) -> None:
        real, clks = self.last
        span = now - (self.real_start + real)
        factor = (self.sim_seconds() - self.sim_seconds(clks)) / span if span > 0 else 0.0
        self.last = (now - self.real_start, self.clks)
        self.last_report = now
        self._print(f"speed: {factor:.2f}x real time (the last {_fmt_s(span)}; {_fmt_s(self.sim_seconds())} "
                    f"simulated in {_fmt_s(now - self.real_start)})")
        if round(factor, 2) < 1 and not self.warned:
            self.warned = True
            self._warn(factor)

    def _warn(self, factor: float) -> None:
        self.err.write(f"servoc sim: warning: the simulation runs slower than real time ({factor:.2f}x): "
                       f"the firmware's frames and bytes come {1 / max(factor, 0.01):.2f} times slower than on "
                       "the chip; give the host longer timeouts (a busy machine, or --view, slows ucsim)\n")
        self.err.flush()

    def _print(self, text: str) -> None:
        self.out.write(text + "\n")
        self.out.flush()

    def _announce(self) -> None:
        s = self.setup
        self._print(f"serial: {self.slave_path}")
        if s.link:
            self._print(f"link: {s.link} -> {self.slave_path}")
        rate = f"baud: {s.baud}, 8 data bits, no parity, 1 stop bit"
        if s.actual_baud != s.baud:
            rate += f" (Timer1 makes {float(s.actual_baud):.1f})"
        self._print(rate)
        until = (f"for {_fmt_s(float(s.seconds))} of simulated time or until Ctrl-C" if s.seconds is not None
                 else "until Ctrl-C")
        self._print(f"running {until}; open the serial line as you would /dev/ttyUSB0")

    # ---- --view ------------------------------------------------------------------------------------

    def _port_write(self, port: int, ticks: int, value: int) -> None:
        if ticks < self.last_ticks:
            self.wrap += 1 << 32
        self.last_ticks = ticks
        cycle = (ticks + self.wrap) // CLOCKS_PER_CYCLE
        old, self.levels[port] = self.levels.get(port, 0xFF), value & 0xFF
        for k, sv in enumerate(self.setup.servos):
            if sv.port != port:
                continue
            was, now = (old >> sv.bit) & 1, (value >> sv.bit) & 1
            if now and not was:
                if self.frame_start is None or cycle - self.frame_start >= self.period_cycles // 2:
                    self._frame_done()
                    self.frame_start = cycle
                self.rise[k] = cycle
            elif was and not now and k in self.rise:
                self.frame_widths[k] = cycle - self.rise.pop(k)

    def _frame_done(self) -> None:
        if self.frame_start is None:
            return
        every = self.setup.view_every or 1
        if self.frames % every == 0:
            cells = []
            for k, sv in enumerate(self.setup.servos):
                width = self.frame_widths.get(k)
                cells.append(f"{sv.name} " + ("-" if width is None else f"{float(width * self.setup.cycle_us):.0f}"))
            t = float(self.frame_start * self.setup.cycle_us) / 1_000_000
            self._print(f"view: {t:9.3f} s  " + "  ".join(cells))
        self.frames += 1
        self.frame_widths = {}

    # ---- the bridge ----------------------------------------------------------------------------------

    def _pump_fifo(self) -> None:
        while self.to_fifo:
            try:
                n = os.write(self.rx, self.to_fifo)
            except BlockingIOError:
                return
            del self.to_fifo[:n]

    def _watch_host(self, now: float) -> None:
        """Follow the slave's opens and closes (see the module docstring)."""
        closed = any(ev & select.POLLHUP for _, ev in self.hup.poll(0))
        if closed:
            self.host = "closed"
        elif self.host == "closed":
            self.host, self.settle_until = "settling", now + SETTLE
        elif self.host == "settling" and now >= self.settle_until:
            self.host = "open"

    def _host_input(self) -> None:
        try:
            packet = os.read(self.master, 4097)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            if exc.errno == errno.EIO:      # the host closed the slave just now
                return
            raise
        if not packet:
            return
        if packet[0] != termios.TIOCPKT_DATA:       # a status packet: a flush, flow control
            if packet[0] & termios.TIOCPKT_FLUSHREAD and self.host == "settling":
                self.host = "open"                  # the host has emptied its input: send on
            return
        data = packet[1:]
        if self.host == "settling":
            self.host = "open"
        if self.finished or (self.limit is not None and self.clks // CLOCKS_PER_CYCLE >= self.limit):
            return
        self.to_fifo += data
        self._pump_fifo()

    def _pump_tx(self) -> None:
        while True:
            try:
                data = os.read(self.tx, 4096)
            except BlockingIOError:
                break
            if not data:
                break
            self.to_host += data
        if len(self.to_host) > MAX_BACKLOG:
            del self.to_host[:len(self.to_host) - MAX_BACKLOG]

    def _pump_host_out(self) -> None:
        while self.to_host and self.host == "open":
            try:
                n = os.write(self.master, self.to_host)
            except BlockingIOError:
                return
            except OSError as exc:
                if exc.errno == errno.EIO:
                    return
                raise
            del self.to_host[:n]

    # ---- the loop ------------------------------------------------------------------------------------

    def _loop(self) -> Summary:
        while not self.finished:
            now = time.monotonic()
            if _stop_requested:
                if not self.running and not self.pending:
                    self.finished = "signal"
                    break
                if self.quit_deadline is None:
                    self.quit_deadline = now + QUIT_WAIT
                    self._ask_stop()
                elif now > self.quit_deadline:
                    self.finished = "signal"
                    break
            elif self.running and now - self.last_report >= REPORT_EVERY:
                self._ask_stop()
            if self.proc.poll() is not None:
                raise LinkError(self._failed("ended", bytes(self.con_buf) + "\n".join(self.chunk).encode()))
            self._watch_host(now)
            listen = self.host != "closed"     # a closed slave makes the master readable (EIO)
            readers = [self.con, self.tx] + ([self.master] if listen else [])
            writers = ([self.rx] if self.to_fifo else []) + ([self.master] if self.to_host and self.host == "open"
                                                              else [])
            wait = POLL if self.host != "settling" else max(0.0, min(POLL, self.settle_until - now))
            try:
                ready_r, ready_w, _ = select.select(readers, writers, [], wait)
            except InterruptedError:
                continue
            if self.con in ready_r:
                self._console_input()
            if self.tx in ready_r:
                self._pump_tx()
            if self.master in ready_r:
                self._host_input()
            if self.rx in ready_w:
                self._pump_fifo()
            if self.to_host:
                self._pump_host_out()
        return self._finish()

    def _finish(self) -> Summary:
        self._pump_tx()
        self._pump_host_out()
        if self.setup.view_every is not None:
            self._frame_done_if_complete()
        # up to the last clock reading (a stop request that found no answer in QUIT_WAIT ends
        # without a fresh one)
        real = max(0.0, self.clks_real - self.real_start)
        sim = self.sim_seconds()
        factor = sim / real if real > 0 else 0.0
        how = {"time": "the time asked for is over", "signal": "stopped"}.get(self.finished, "stopped")
        self._print(f"speed: {factor:.2f}x real time ({_fmt_s(sim)} simulated in {_fmt_s(real)}; {how})")
        if round(factor, 2) < 1 and not self.warned and real >= 1:
            self.warned = True
            self._warn(factor)
        return Summary(sim, real, self.finished)

    def _frame_done_if_complete(self) -> None:
        if self.frame_start is not None and not self.rise:
            self._frame_done()
            self.frame_start = None


def _stops_vcd(cycles: list[int], sim_hz: int) -> str:
    """A VCD input file with one event half a machine cycle before each of `cycles` (increasing):
    with `break` on, ucsim stops at the first instruction boundary at or after each."""
    cycle_ps = Fraction(CLOCKS_PER_CYCLE * 10**12, sim_hz)
    text = ("$timescale 1ps $end\n$scope module servoc_sim $end\n"
            "$var wire 8 ! variables[0xf0] $end\n$upscope $end\n$enddefinitions $end\n")
    for k, at in enumerate(cycles):
        text += f"#{round((at - Fraction(1, 2)) * cycle_ps)}\nb{k % 255 + 1:08b} !\n"
    return text
