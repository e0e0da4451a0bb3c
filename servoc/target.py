"""The chips servoc builds for, and the machine cycle of a target: one table for every stage.

The checker resolves `target CHIP [clock FREQ] [mode 12T|6T]` against CHIPS;
the planner's timing, code generation (the top of code memory), the ROM
check, the simulator's crystal and the reports all read the resulting
`Target`. Every chip is 8052-class: Timer2 and 256 bytes of internal RAM.

Each line falls round_half_up((500 + 8 N) µs / t_c) machine cycles after its
port's rise (`Target.width_cycles`). The edge handler puts two edges of one
port as close as MIN_DIV_CYCLES cycles apart (`servoc/costs.py`), so a DIV
must be at least that many cycles: `Target.timing_problem` names the lowest
clock that works. With a 1 µs machine cycle (12 MHz, or 6 MHz in 6T mode)
C(N) = 500 + 8 N is computed; at other clocks it comes from a table.

The serial line's rate comes from Timer1 (`timer1_baud`: TH1, SMOD and the
rate they make), checked by the checker and read by firmware generation.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from functools import lru_cache
from fractions import Fraction

MHZ = 1_000_000


@dataclass(frozen=True)
class Chip:
    name: str            # lower case, as matched
    display: str         # as the maker writes it
    code_bytes: int      # on-chip code memory
    max_hz: int          # the highest crystal the maker rates it for (5 V parts)
    six_t: bool          # has the 6-clock (6T) mode
    flash: str           # the usual way to write a HEX file to it
    ram_bytes: int = 256
    xram_bytes: int = 0  # on-chip XRAM (MOVX @DPTR, page 0 up), on at reset


CHIPS: dict[str, Chip] = {c.name: c for c in (
    Chip("at89c52", "AT89C52", 8 * 1024, 24 * MHZ, False,
         "a parallel programmer, e.g. a TL866 with minipro: `minipro -p AT89C52 -w prog.hex`"),
    Chip("at89s52", "AT89S52", 8 * 1024, 33 * MHZ, False,
         "in-system, with avrdude 7.1 or later and a programmer that drives reset active-high: "
         "`avrdude -c usbasp -p 89s52 -U flash:w:prog.hex:i`"),
    Chip("at89c55wd", "AT89C55WD", 20 * 1024, 33 * MHZ, False,
         "a parallel programmer, e.g. a TL866 with minipro: `minipro -p AT89C55WD -w prog.hex`"),
    Chip("stc89c52rc", "STC89C52RC", 8 * 1024, 40 * MHZ, True,
         "its serial bootloader, with stcgal: `stcgal -P stc89 -p /dev/ttyUSB0 prog.hex`, then power-cycle the board",
         xram_bytes=256),
    Chip("stc89c58rd", "STC89C58RD+", 32 * 1024, 40 * MHZ, True,
         "its serial bootloader, with stcgal: `stcgal -P stc89 -p /dev/ttyUSB0 prog.hex`, then power-cycle the board",
         xram_bytes=1024),
)}
ALIASES = {"stc89c52": "stc89c52rc", "stc89c58": "stc89c58rd"}   # names boards use
DEFAULT_CHIP = "at89c52"


def chip(name: str) -> Chip | None:
    """The chip a `target` names (without case), or None."""
    key = name.lower()
    return CHIPS.get(ALIASES.get(key, key))
DEFAULT_CLOCK_HZ = 12 * MHZ
GRID_CYCLE_US = Fraction(1)          # the machine cycle at which a DIV is 8 whole cycles
MIN_DIV_CYCLES = 7                   # the closest two edges of one port the handler puts out (costs.STEP)
TIMER_CYCLES = 0xFFFF                # the longest time Timer0 counts from one edge to the next


@dataclass(frozen=True)
class Target:
    chip: Chip
    clock_hz: int
    six_t: bool = False

    @property
    def clocks_per_cycle(self) -> int:
        return 6 if self.six_t else 12

    @property
    def cycle_us(self) -> Fraction:
        """The machine cycle t_c in microseconds."""
        return Fraction(self.clocks_per_cycle * MHZ, self.clock_hz)

    @property
    def sim_hz(self) -> int:
        """The crystal for ucsim's 12-clock core that gives the same machine cycle."""
        return self.clock_hz * 12 // self.clocks_per_cycle

    def describe(self) -> str:
        mode = ", 6T" if self.six_t else ""
        return f"{self.chip.display} at {fmt_hz(self.clock_hz)}{mode}"

    @property
    def grid(self) -> bool:
        """True when a DIV (8 µs) is 8 whole machine cycles: C(N) = 500 + 8 N."""
        return self.cycle_us == GRID_CYCLE_US

    @property
    def div_cycles(self) -> Fraction:
        """Machine cycles in one DIV (8 µs)."""
        return 8 / self.cycle_us

    def cycles(self, us: int | Fraction) -> int:
        """round_half_up(us / t_c): a time in whole machine cycles."""
        return int(Fraction(us) / self.cycle_us + Fraction(1, 2))

    def width_cycles(self, n: int) -> int:
        """Machine cycles from a port's rise to the fall of a line with N = n."""
        return _widths(self.clock_hz, self.six_t)[n] if 0 <= n < 256 else self.cycles(500 + 8 * n)

    def width_error_us(self) -> Fraction:
        """The largest distance of a firmware width from 500 + 8 N µs over N = 0..250."""
        return max(abs(self.width_cycles(n) * self.cycle_us - (500 + 8 * n)) for n in range(251))

    def max_period_us(self) -> int:
        """The longest whole-µs frame period whose machine cycles Timer0 can count between two edges."""
        return self.us_at_least(TIMER_CYCLES + 1) - 1

    def us_at_least(self, cycles: int) -> int:
        """The shortest whole-µs period P with round_half_up(P / t_c) >= cycles."""
        q = (cycles - Fraction(1, 2)) * self.cycle_us
        return max(1, -(-q.numerator // q.denominator))

    def timing_problem(self) -> str | None:
        """Why the firmware cannot be timed on this target, or None."""
        if int(self.div_cycles) >= MIN_DIV_CYCLES:
            return None
        lowest = Fraction(MIN_DIV_CYCLES * self.clocks_per_cycle * MHZ, 8)
        return (f"at {fmt_hz(self.clock_hz)}{' in 6T mode' if self.six_t else ''} a DIV (8 µs) is "
                f"{float(self.div_cycles):.2f} machine cycles, and two lines one DIV apart need at least "
                f"{MIN_DIV_CYCLES}: the lowest clock that works is {fmt_hz(lowest)}"
                + (" (half that in 6T mode)" if self.chip.six_t and not self.six_t else ""))


@lru_cache(maxsize=32)
def _widths(clock_hz: int, six_t: bool) -> tuple[int, ...]:
    """Target.width_cycles for N = 0..255, worked out once per clock."""
    target = Target(CHIPS[DEFAULT_CHIP], clock_hz, six_t)
    return tuple(target.cycles(500 + 8 * n) for n in range(256))


DEFAULT = Target(CHIPS[DEFAULT_CHIP], DEFAULT_CLOCK_HZ)


def closest(name: str) -> list[str]:
    """The known chip names, the closest to `name` first."""
    near = difflib.get_close_matches(name.lower(), list(CHIPS), n=len(CHIPS), cutoff=0.0)
    return near + [c for c in CHIPS if c not in near]


def fmt_hz(hz: int | Fraction) -> str:
    """`12 MHz`, `11.0592 MHz`; a crystal that is not a round figure to the hertz, `10.499999 MHz`."""
    mhz = Fraction(hz) / MHZ
    text = f"{float(mhz):.4f}".rstrip("0").rstrip(".")
    if Fraction(text) != mhz:
        text = f"{float(mhz):.7f}".rstrip("0").rstrip(".")
    return f"{text} MHz"


def fmt_us(us: Fraction) -> str:
    text = f"{float(us):.4f}".rstrip("0").rstrip(".")
    return f"{text} µs"


# ---- the serial line: Timer1 in mode 2 (8-bit auto-reload) makes the baud rate ------------------

STANDARD_BAUDS = (300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 28800, 38400, 57600, 115200)
BAUD_TOLERANCE = Fraction(2, 100)        # the UART receives reliably within 2 % of the rate
# Crystals sold for 8051 boards, the baud-rate crystals first: what a hint may suggest.
CRYSTALS_HZ = (11_059_200, 22_118_400, 14_745_600, 18_432_000, 12 * MHZ, 24 * MHZ, 16 * MHZ, 20 * MHZ, 33 * MHZ)


@lru_cache(maxsize=256)
def timer1_baud(target: Target, baud: int) -> tuple[int, int, Fraction]:
    """(TH1, SMOD, actual rate) of the Timer1 setting nearest to `baud`, for the UART in mode 1 with
    Timer1 in mode 2: rate = 2^SMOD x (1 / t_c) / (32 x (256 - TH1)), t_c the machine cycle. The
    nearest by relative error; on a tie, SMOD 0 (PCON left alone), then the larger TH1."""
    cycles_per_s = Fraction(MHZ) / target.cycle_us
    best: tuple[Fraction, int, int, Fraction] | None = None
    for smod in (0, 1):
        for th1 in range(255, -1, -1):
            rate = (1 << smod) * cycles_per_s / (32 * (256 - th1))
            err = abs(rate - baud) / baud
            if best is None or err < best[0]:
                best = (err, th1, smod, rate)
    _, th1, smod, rate = best
    return th1, smod, rate


def byte_cycles(th1: int, smod: int) -> int:
    """Machine cycles of one byte on the line (start, 8 data, stop: 10 bits): a bit is 16 Timer1
    overflows with SMOD = 1, else 32, each 256 - TH1 machine cycles."""
    return 10 * (32 >> smod) * (256 - th1)


def baud_error(target: Target, baud: int) -> Fraction:
    """|actual - baud| / baud for the nearest rate Timer1 makes."""
    return abs(timer1_baud(target, baud)[2] - baud) / baud


def baud_works(target: Target, baud: int) -> bool:
    """Whether Timer1 makes `baud` within BAUD_TOLERANCE at the target's clock."""
    return baud_error(target, baud) <= BAUD_TOLERANCE


def working_bauds(target: Target) -> list[int]:
    """The standard rates Timer1 makes within the tolerance at the target's clock, ascending."""
    return [b for b in STANDARD_BAUDS if baud_works(target, b)]


def crystal_for(target: Target, baud: int) -> int | None:
    """A usual crystal, within the chip's rating, at which Timer1 makes `baud` exactly (else within the
    tolerance), in the target's mode; None when there is none."""
    fits = [hz for hz in CRYSTALS_HZ if hz <= target.chip.max_hz]
    for exact in (True, False):
        for hz in fits:
            err = baud_error(Target(target.chip, hz, target.six_t), baud)
            if err == 0 if exact else err <= BAUD_TOLERANCE:
                return hz
    return None
