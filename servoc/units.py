"""Exact unit conversions of the .servo language (all arithmetic in Fractions).

Pulse width = 500 us + 8 us x N, N in 0..250 (DIV = 8 us).
Angle: 185 deg over N 0..250 (DAV = 0.74 deg); A deg -> floor(A x 250/185 + 1/2).
Default servo (HG14-M): 0.2 s per 60 deg, so t_DAV = 0.74 deg x 0.2 s / 60 deg.
"""

from __future__ import annotations

from fractions import Fraction

BASE_US = 500
DIV_US = 8
N_MAX = 250
FULL_DEG = 185
DAV_DEG = Fraction(FULL_DEG, N_MAX)                     # 0.74 deg
DEFAULT_T_DAV_US = DAV_DEG * Fraction(200_000) / 60    # 2466.67 us per DAV
TAIL_US = 2800                                          # the source's gap after a port's pulses
LONGEST_PULSE_US = BASE_US + DIV_US * N_MAX             # 2500 us
DEFAULT_PERIOD_FLOOR_US = LONGEST_PULSE_US + TAIL_US    # 5.3 ms

TIME_UNITS_US = {"us": Fraction(1), "ms": Fraction(1000), "s": Fraction(1_000_000)}
FREQ_UNITS_HZ = {"Hz": Fraction(1), "kHz": Fraction(1000), "MHz": Fraction(1_000_000)}


def round_half_up(x: Fraction) -> int:
    """floor(x + 1/2) of a Fraction or int, exact in integers: (2p + q) // 2q for x = p/q."""
    return (2 * x.numerator + x.denominator) // (2 * x.denominator)


def deg_to_n(angle_deg: Fraction) -> int:
    """N for an angle: floor(A x 250/185 + 1/2), exact."""
    p, q = angle_deg.numerator, angle_deg.denominator
    return (2 * N_MAX * p + FULL_DEG * q) // (2 * FULL_DEG * q)


def deg_on_grid(angle_deg: Fraction, n: int) -> bool:
    """Whether an angle is exactly N steps of 0.74 deg (A = N x 185/250)."""
    return angle_deg.numerator * N_MAX == n * FULL_DEG * angle_deg.denominator


def width_to_n(width_us: Fraction) -> int:
    """N for a pulse width, rounded half up to the 8 us grid."""
    return round_half_up((Fraction(width_us) - BASE_US) / DIV_US)


def width_on_grid(width_us: Fraction) -> bool:
    return ((Fraction(width_us) - BASE_US) / DIV_US).denominator == 1


def n_to_deg(n: int) -> Fraction:
    return n * DAV_DEG


def n_to_width_us(n: int) -> int:
    return BASE_US + DIV_US * n


def t_dav_from_speed(duration_us: Fraction, angle_deg: Fraction) -> Fraction:
    """`speed D/A`: t_DAV = D x 0.74 deg / A."""
    return Fraction(duration_us) * DAV_DEG / Fraction(angle_deg)


def frames_for(duration_us: Fraction, period_us: int) -> int:
    """Frames a `hold` lasts: floor(D/P + 1/2)."""
    return round_half_up(Fraction(duration_us) / period_us)


def move_frames(duration_us: Fraction, period_us: int) -> int:
    """Frames of a `move ... in D`: F = max(1, floor(D/P + 1/2))."""
    return max(1, frames_for(duration_us, period_us))


def frames_needed(delta: int, t_dav_us: Fraction, period_us: int) -> int:
    """Frames a servo needs to travel |delta| DAV at its top speed: ceil(|d| x t_DAV / P)."""
    t = Fraction(t_dav_us)      # (in integers: a plan's speed tables take 251 of these per class)
    return -(-abs(delta) * t.numerator // (t.denominator * period_us))


def fmt_deg(x: Fraction) -> str:
    """An angle for messages: at most two decimals, no trailing zeros."""
    s = f"{float(x):.2f}".rstrip("0").rstrip(".")
    return s + "°"


def fmt_ms(us: Fraction) -> str:
    """A duration in ms for messages: at most three decimals (exact for whole microseconds)."""
    ms = Fraction(us) / 1000
    s = str(ms.numerator) if ms.denominator == 1 else f"{float(ms):.3f}".rstrip("0").rstrip(".")
    return s + " ms"
