"""A pyserial client drives a `host ssc32` firmware in `servoc sim`, as host software drives a board.

The client here is written from docs/host-protocol.md, not from the firmware: it opens the printed
pseudo-terminal with pyserial, sends SSC-32 command lines and reads the answers. It runs a move, a
group move with T and S, Q, QP, VER, STOP and PL; the same session, as an events file, passes
`servoc verify` (tests/test_host.py and examples/events/ssc32_arm.events).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import serial

from test_simlink import Sim

pytestmark = pytest.mark.toolchain

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "examples" / "ssc32_arm.servo"


class Client:
    """An SSC-32 host program: pyserial on the path `servoc sim` printed."""

    def __init__(self, path: str):
        self.port = serial.Serial(path, 9600, timeout=20)

    def ask(self, line: bytes, n: int = 1) -> bytes:
        self.port.write(line + b"\r")
        return self.port.read(n)

    def moving(self) -> bool:
        answer = self.ask(b"Q")
        assert answer in (b"+", b"."), answer
        return answer == b"+"

    def until_still(self, limit: float = 30) -> float:
        start = time.monotonic()
        while self.moving():
            assert time.monotonic() - start < limit, "the move never ended"
            time.sleep(0.02)
        return time.monotonic() - start

    def width(self, channel: int) -> int:
        return 10 * self.ask(b"QP%d" % channel)[0]


def test_a_pyserial_client_runs_a_whole_session(tmp_path):
    sim = Sim([str(ARM), "--seconds", "60"], tmp_path)
    try:
        path = sim.wait_line(r"^serial: (\S+)", timeout=120).group(1)
        client = Client(path)
        client.port.write(b"VER\r")
        assert client.port.read_until(b"\r") == b"SSC32-servoc-0.1\r"
        # home: rest, 90deg = N 122: (500 + 976) / 10 = 147 -> 1470
        assert client.width(0) == 1470 and not client.moving()
        # a group move with T: base and shoulder, 0.6 s of simulated time
        client.port.write(b"#0 P1000 #1 P1800 T600\r")
        time.sleep(0.05)
        assert client.moving()
        client.until_still()
        assert client.width(0) == 1000 and client.width(1) == 1800      # 1000 and 1800 are on the 8 us grid
        # S: the grip (channel 7) at 400 us/s: 2000 - 988 us takes 2.53 s
        client.port.write(b"#7 P2000 S400\r")
        time.sleep(0.3)
        client.port.write(b"STOP 7\r")
        time.sleep(0.1)
        stopped = client.width(7)
        assert 988 < stopped < 2000
        assert not client.moving()              # STOP 7 ends the grip's part: no servo is on its way
        client.until_still()
        assert client.width(7) == stopped
        # a single servo move: the elbow, reversed: P600 is N 13, reversed N 237 = 2396 us
        client.ask(b"#2P600", 0)
        client.until_still()
        assert client.width(2) == 2390          # (500 + 8 x 237) / 10 = 239.6 -> 239
        # PL 0 SQ 0: the wave (tuck, then rest); Q answers '+' after it, '.' once it is over
        client.ask(b"PL 0 SQ 0", 0)
        time.sleep(0.1)
        client.until_still()
        assert client.width(1) == 1470          # rest: 90deg
        # channel 5 has no servo: QP answers 0
        assert client.width(5) == 0
        client.port.close()
    finally:
        sim.kill()
