"""How fast `servoc sim` runs against real time, measured side by side in one run:

    .venv/bin/python benchmarks/sim_speed.py

For the two serial examples (`serial_arm.servo`: 4 servos, 11.0592 MHz, 9600 baud;
`hexapod_serial.servo`: 24 servos, 12 MHz, 4800 baud), `SECONDS` of simulated time each:
`servoc sim` as a user runs it, the same with `--view`, and the same without ucsim's
check-input-every-cycle flag (what that flag costs; without it the UART takes a byte from
its input only at ucsim's console polls, so `servoc sim` keeps it on). Each figure is the
simulated time over the real time, as `servoc sim` prints it at the end; the last column
is the plain run's speed over the flagless one's.
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import simlink  # noqa: E402
from servoc.cli import main as cli  # noqa: E402

SECONDS = 10
EXAMPLES = ("serial_arm.servo", "hexapod_serial.servo")
_FACTOR = re.compile(r"speed: ([0-9.]+)x real time \(([0-9.]+) s simulated in ([0-9.]+) s; the time asked for")


def speed(name: str, *options: str, flag: bool = True) -> float:
    """`servoc sim EXAMPLE --seconds SECONDS OPTIONS`: its final speed line's factor."""
    script = simlink._Link._script
    if not flag:
        def without_flag(self, stops):
            return script(self, stops).replace("expr uart_0_cfg[1]=1\n", "")
        simlink._Link._script = without_flag
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
            rc = cli(["sim", str(ROOT / "examples" / name), "--seconds", str(SECONDS), *options])
    finally:
        simlink._Link._script = script
    m = _FACTOR.search(out.getvalue())
    if rc != 0 or m is None:
        raise SystemExit(f"servoc sim {name} failed:\n{out.getvalue()}")
    return float(m.group(1))


def main() -> None:
    print(f"`servoc sim`, {SECONDS} s simulated each; speed = simulated time / real time\n")
    print("| program | plain | --view | without the input flag | plain / without |")
    print("|---|---|---|---|---|")
    for name in EXAMPLES:
        plain, view, bare = speed(name), speed(name, "--view"), speed(name, flag=False)
        print(f"| {name} | {plain:.2f}x | {view:.2f}x | {bare:.2f}x | {plain / bare:.2f} |")


if __name__ == "__main__":
    main()
