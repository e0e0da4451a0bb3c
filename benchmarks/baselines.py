"""The two baseline firmwares, the positions they drive, and the decoder that measures any firmware.

Baselines (benchmarks/baselines/), each driving 8 servos on P1 with the same
positions `POSITIONS`:
- hobby.c: C for `sdcc -mmcs51 --model-small`, a 20 ms frame in eight 2.5 ms
  Timer0 slots;
- source_algorithm.asm: the source note's cycle transcribed plainly for
  sdas8051 (rise together, bubble sort, differences, DJNZ delays, 2.8 ms tail).

Every firmware, servoc's included, runs in ucsim (`servoc.api.simulate`) and
goes through the same decoder (`SimTrace.pulses` and `SimTrace.first_low`):
width error per channel (measured width minus 500 + 8 N), frame period (mean
rise-to-rise), jitter (max - min rise-to-rise) and how long the lines stay
high after reset.
"""

from __future__ import annotations

import re
import statistics
import subprocess
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

from servoc import api, toolchain
from servoc.sim import SimTrace
from servoc.units import BASE_US, DIV_US

BENCH_DIR = Path(__file__).resolve().parent
BASELINE_DIR = BENCH_DIR / "baselines"
HOBBY_C = BASELINE_DIR / "hobby.c"
SOURCE_ASM = BASELINE_DIR / "source_algorithm.asm"

POSITIONS = (0, 1, 125, 125, 200, 249, 250, 60)
"""N of P1.0..P1.7 in all three firmwares: both ends, a tie, adjacent values."""
PORT = 1
FRAMES = 50


class BuildError(Exception):
    """A baseline or a benchmark program did not build."""


def expected_width(n: int) -> int:
    return BASE_US + DIV_US * n


def baseline_positions(path: Path) -> tuple[int, ...]:
    """The 8 positions written in a baseline's source (its first 8-number list)."""
    text = path.read_text()
    if path.suffix == ".c":
        m = re.search(r"position\[SERVOS\]\s*=\s*\{([^}]*)\}", text)
    else:
        m = re.search(r"^table:\s*\.db\s+(.*)$", text, re.M)
    numbers = m[1] if m else ""
    return tuple(int(x, 0) for x in numbers.split(",") if x.strip())


def positions_source(frame: str | None = None) -> str:
    """servoc's program for POSITIONS on P1: raw N, set at once, then held."""
    lines = [] if frame is None else [f"frame {frame}"]
    lines += [f"servo s{b} = P{PORT}.{b}" for b in range(8)]
    pose = ", ".join(f"s{b}: {n}" for b, n in enumerate(POSITIONS))
    lines += [f"pose p {{ {pose} }}", "main {", "  move p in 100ms", "  hold 1s", "}"]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- building

def find_sdcc() -> str:
    """The SDCC compiler: it ships with packihx, so it is looked for beside servoc's packihx."""
    packihx = Path(toolchain.find_tool("packihx"))
    sdcc = packihx.with_name("sdcc")
    if not sdcc.is_file():
        raise toolchain.ToolNotFound("sdcc", f"not beside {packihx}")
    return str(sdcc)


def _run(argv: list[str], cwd: str, what: str, timeout: float) -> str:
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, stdin=subprocess.DEVNULL,
                          timeout=timeout, check=False)
    if proc.returncode != 0:
        raise BuildError(f"{what} failed:\n{proc.stdout}{proc.stderr}")
    return proc.stdout


def build_hobby(path: Path = HOBBY_C) -> str:
    """Compile hobby.c with SDCC (small model), pack it with packihx and return the HEX text."""
    sdcc, packihx = find_sdcc(), toolchain.find_tool("packihx")
    with tempfile.TemporaryDirectory(prefix="servoc-bench-") as tmp:
        (Path(tmp) / "hobby.c").write_text(path.read_text())
        _run([sdcc, "-mmcs51", "--model-small", "hobby.c"], tmp, f"sdcc on {path}", 120)
        hex_text = _run([packihx, "hobby.ihx"], tmp, "packihx on hobby.ihx", 60)
    if not hex_text.strip():
        raise BuildError("packihx wrote no HEX for hobby.ihx")
    return hex_text


def build_source_algorithm(path: Path = SOURCE_ASM) -> str:
    """Assemble source_algorithm.asm with sdas8051/sdld and return the HEX text."""
    return toolchain.assemble(path.read_text(), name="source_algorithm").hex_text


# ---------------------------------------------------------------- decoder

@dataclass
class Decoded:
    """The same figures for every firmware, from its SimTrace."""

    frames: int                     # pulses decoded per channel
    width_error_us: list[list[int]]  # per channel, per pulse: width - (500 + 8 N)
    max_abs_error_us: list[int]     # per channel
    max_abs_error_all_us: int
    exact_pulses: int               # pulses with zero error, all channels
    pulses: int
    period_mean_us: float           # mean rise-to-rise over all channels
    period_min_us: int
    period_max_us: int
    jitter_us: int                  # max over channels of (max - min rise-to-rise)
    reset_high_us: list[int | None]  # first_low per line
    reset_high_max_us: int | None

    def summary(self) -> dict:
        d = asdict(self)
        del d["width_error_us"]
        d["width_errors_seen_us"] = [sorted(set(e)) for e in self.width_error_us]
        return d


def decode(trace: SimTrace, port: int, positions: tuple[int, ...], frames: int) -> Decoded:
    """Widths, periods and reset figures of `frames` pulses per line of `port`."""
    errors: list[list[int]] = []
    periods: list[int] = []
    jitter = 0
    for bit, n in enumerate(positions):
        pulses = trace.pulses(port, bit)[:frames]
        if len(pulses) < frames:
            raise ValueError(f"P{port}.{bit}: only {len(pulses)} complete pulses, {frames} needed")
        errors.append([w - expected_width(n) for _, w in pulses])
        rr = [b[0] - a[0] for a, b in zip(pulses, pulses[1:])]
        periods += rr
        jitter = max(jitter, max(rr) - min(rr))
    firsts = [trace.first_low(port, bit) for bit in range(len(positions))]
    known = [f for f in firsts if f is not None]
    max_abs = [max(abs(e) for e in errs) for errs in errors]
    return Decoded(
        frames=frames,
        width_error_us=errors,
        max_abs_error_us=max_abs,
        max_abs_error_all_us=max(max_abs),
        exact_pulses=sum(e == 0 for errs in errors for e in errs),
        pulses=sum(len(errs) for errs in errors),
        period_mean_us=round(statistics.fmean(periods), 3),
        period_min_us=min(periods),
        period_max_us=max(periods),
        jitter_us=jitter,
        reset_high_us=firsts,
        reset_high_max_us=None if len(known) < len(firsts) else max(known),
    )


def simulate_frames(hex_text: str, port: int, frames: int, guess_period: int) -> SimTrace:
    """Simulate until every line of `port` has `frames` complete pulses (doubling the guess)."""
    cycles = (frames + 3) * guess_period + 20_000
    for _ in range(6):
        trace = api.simulate(hex_text, cycles)
        if all(len(trace.pulses(port, b)) >= frames for b in range(8)):
            return trace
        cycles *= 2
    return trace


def measure_baseline(hex_text: str, guess_period: int, frames: int = FRAMES) -> Decoded:
    """A firmware driving POSITIONS on P1, measured over `frames` pulses per line."""
    return decode(simulate_frames(hex_text, PORT, frames, guess_period), PORT, POSITIONS, frames)
