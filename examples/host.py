"""Drive examples/hexapod_serial.servo from a computer: send a command, wait for its answer.

    pip install pyserial
    python examples/host.py /dev/ttyUSB0 w w l s

The hexapod answers each command ("w" walk, "s" stand, "l" look around) with
its capital letter when the command is done, and sends "R" once it stands
after reset. The line runs at 4800 baud, 8 data bits, no parity, 1 stop bit.
"""

import sys

import serial   # pyserial

ANSWERS = {"w": b"W", "s": b"S", "l": b"L"}


def main(port_name: str, commands: list[str]) -> int:
    with serial.Serial(port_name, 4800, timeout=10) as port:
        if port.read(1) != b"R":
            print("no `R`: is the hexapod on, and just reset?")
            return 1
        for command in commands:
            port.write(command.encode("ascii"))
            answer = port.read(1)
            print(command, "done" if answer == ANSWERS[command] else f"no answer ({answer!r})")
    return 0


if __name__ == "__main__":
    if len(sys.argv) < 3 or any(c not in ANSWERS for c in sys.argv[2:]):
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1], sys.argv[2:]))
