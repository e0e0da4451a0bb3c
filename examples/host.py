"""Drive examples/hexapod_serial.servo from a computer: send a command, wait for its answer.

    pip install pyserial
    python examples/host.py /dev/ttyUSB0 w s l x

The hexapod sends "R" once it stands after reset. "w" starts a walk, answered
"W" at once; it walks until "s", which it answers "S" once it stands again
("s" also stands it up when it is not walking). "l" looks around and answers
"L" when done. Any other byte is answered "?". The line runs at 4800 baud,
8 data bits, no parity, 1 stop bit.
"""

import sys

import serial   # pyserial

ANSWERS = {"w": b"W", "s": b"S", "l": b"L"}     # any other byte: b"?"


def main(port_name: str, commands: list[str]) -> int:
    with serial.Serial(port_name, 4800, timeout=10) as port:
        if port.read(1) != b"R":
            print("no `R`: is the hexapod on, and just reset?")
            return 1
        for command in commands:
            port.write(command.encode("ascii"))
            answer = port.read(1)
            print(command, "done" if answer == ANSWERS.get(command, b"?") else f"no answer ({answer!r})")
    return 0


if __name__ == "__main__":
    if len(sys.argv) < 3 or any(len(c.encode("ascii", "replace")) != 1 for c in sys.argv[2:]):
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2:]))
