"""Drive examples/ssc32_arm.servo (or any `host ssc32` program) as SSC-32 host software does.

    pip install pyserial
    servoc sim examples/ssc32_arm.servo --link /tmp/arm     # or the board's /dev/ttyUSB0
    python examples/ssc32_client.py /tmp/arm

Commands are ASCII lines ended by CR (docs/host-protocol.md). The firmware moves every servo of a
group together, never faster than the servo's `speed`; `Q` answers b"+" while a move is under way.
"""

import sys
import time

import serial   # pyserial


def wait_done(port: serial.Serial) -> None:
    while True:
        port.write(b"Q\r")
        if port.read(1) == b".":
            return
        time.sleep(0.05)


def main(name: str) -> int:
    with serial.Serial(name, 9600, timeout=5) as port:
        port.write(b"VER\r")
        print("version:", port.read_until(b"\r").decode("ascii").strip())
        port.write(b"#0 P1000 #1 P1800 T800\r")       # a group move of 0.8 s
        wait_done(port)
        port.write(b"QP0\r")
        print("base at", 10 * port.read(1)[0], "us")
        port.write(b"#7 P2000 S500\r")                # the grip at 500 us per second
        time.sleep(0.5)
        port.write(b"STOP 7\r")
        port.write(b"PL 0 SQ 0\r")                    # the program's first sequence
        wait_done(port)
        print("done")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "/dev/ttyUSB0"))
