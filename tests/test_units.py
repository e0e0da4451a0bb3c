"""servoc.units: the spec's exact conversions, checked against hand-computed values."""

from __future__ import annotations

from fractions import Fraction

import pytest

from servoc import units
from servoc.units import (deg_to_n, fmt_deg, fmt_ms, frames_for, frames_needed, move_frames, n_to_deg,
                          n_to_width_us, round_half_up, t_dav_from_speed, width_on_grid, width_to_n)


# ---- positions ---------------------------------------------------------------

@pytest.mark.parametrize("deg, n", [(0, 0), (45, 61), (90, 122), (180, 243), (185, 250)])
def test_spec_angle_table(deg, n):
    assert deg_to_n(Fraction(deg)) == n


def test_angle_rounds_half_up_exactly():
    # 0.37deg is exactly half a DAV: 0.37 x 250/185 = 1/2, which rounds up to 1.
    assert deg_to_n(Fraction(37, 100)) == 1
    # Just under half a DAV stays at 0.
    assert deg_to_n(Fraction(369, 1000)) == 0
    # 1.11deg is exactly 1.5 DAV: rounds up to 2.
    assert deg_to_n(Fraction(111, 100)) == 2
    # 0.74deg is exactly one DAV.
    assert deg_to_n(Fraction(74, 100)) == 1


def test_angle_is_computed_exactly_not_in_floats():
    # 92.87deg x 250/185 = 125.5 exactly; a float computation can land on 125.49999.
    assert Fraction(9287, 100) * 250 / 185 == Fraction(251, 2)
    assert deg_to_n(Fraction(9287, 100)) == 126


@pytest.mark.parametrize("width, n", [(500, 0), (508, 1), (1500, 125), (2500, 250), (1496, 125), (1503, 125),
                                      (1504, 126), (1501, 125), (1499, 125)])
def test_width_to_n_rounds_half_up_to_the_grid(width, n):
    # (W - 500) / 8: 1504 is exactly 125.5 and rounds up; 1503 is 125.375.
    assert width_to_n(Fraction(width)) == n


def test_width_on_grid():
    assert width_on_grid(Fraction(1500)) and width_on_grid(Fraction(500)) and width_on_grid(Fraction(2500))
    assert not width_on_grid(Fraction(1501))
    assert not width_on_grid(Fraction(3001, 2))


def test_n_back_to_width_and_angle():
    assert n_to_width_us(0) == 500 and n_to_width_us(125) == 1500 and n_to_width_us(250) == 2500
    assert n_to_deg(250) == 185
    assert n_to_deg(1) == Fraction(74, 100)


def test_round_half_up_goes_towards_plus_infinity():
    assert round_half_up(Fraction(1, 2)) == 1
    assert round_half_up(Fraction(3, 2)) == 2
    assert round_half_up(Fraction(-1, 2)) == 0
    assert round_half_up(Fraction(-3, 2)) == -1
    assert round_half_up(Fraction(249, 100)) == 2


# ---- speed ---------------------------------------------------------------------

def test_default_t_dav_is_2467_us():
    # 0.74deg x 0.2s / 60deg = 2466.67 us
    assert units.DEFAULT_T_DAV_US == Fraction(7400, 3)
    assert fmt_ms(units.DEFAULT_T_DAV_US) == "2.467 ms"


def test_speed_option_t_dav():
    # speed 0.25s/60deg: 250000 x 0.74 / 60 = 3083.33 us per DAV
    assert t_dav_from_speed(Fraction(250_000), Fraction(60)) == Fraction(9250, 3)
    # speed 3ms/0.74deg: exactly 3 ms per DAV
    assert t_dav_from_speed(Fraction(3000), Fraction(74, 100)) == 3000
    # the default servo written out: speed 0.2s/60deg
    assert t_dav_from_speed(Fraction(200_000), Fraction(60)) == units.DEFAULT_T_DAV_US


# ---- frames --------------------------------------------------------------------

@pytest.mark.parametrize("dur_us, period, frames", [
    (40_000, 10_000, 4), (44_000, 10_000, 4), (45_000, 10_000, 5), (44_999, 10_000, 4),
    (4_000, 10_000, 0), (5_000, 10_000, 1), (0, 10_000, 0), (300_000, 6_000, 50), (400_000, 6_000, 67),
    (1_000_000, 6_000, 167), (200_000, 5_300, 38)])
def test_hold_frames(dur_us, period, frames):
    assert frames_for(Fraction(dur_us), period) == frames


@pytest.mark.parametrize("dur_us, period, frames", [
    (40_000, 10_000, 4), (45_000, 10_000, 5), (4_000, 10_000, 1), (0, 10_000, 1), (4_999, 10_000, 1),
    (15_000, 10_000, 2), (14_999, 10_000, 1)])
def test_move_frames_is_at_least_one(dur_us, period, frames):
    assert move_frames(Fraction(dur_us), period) == frames


def test_frames_needed_is_a_ceiling():
    # 100 DAV x 2466.67 us = 246.67 ms over P = 10 ms: 24.67 -> 25 frames
    assert frames_needed(100, units.DEFAULT_T_DAV_US, 10_000) == 25
    # exactly 37 frames: 100 x 3700 us = 370 ms
    assert frames_needed(100, Fraction(3700), 10_000) == 37
    assert frames_needed(-100, Fraction(3700), 10_000) == 37
    assert frames_needed(0, Fraction(3700), 10_000) == 0
    # 150 DAV of the default servo at P = 7.4 ms: 150 x 7400/3 = 370000 = 50 x 7400
    assert frames_needed(150, units.DEFAULT_T_DAV_US, 7_400) == 50
    assert frames_needed(151, units.DEFAULT_T_DAV_US, 7_400) == 51


# ---- message formatting ------------------------------------------------------------

def test_fmt_ms_is_exact_for_whole_microseconds():
    assert fmt_ms(Fraction(5300)) == "5.3 ms"
    assert fmt_ms(Fraction(2752)) == "2.752 ms"
    assert fmt_ms(Fraction(65535)) == "65.535 ms"
    assert fmt_ms(Fraction(1)) == "0.001 ms"
    assert fmt_ms(Fraction(300_000)) == "300 ms"


def test_fmt_deg():
    assert fmt_deg(Fraction(124) * units.DAV_DEG) == "91.76°"
    assert fmt_deg(Fraction(90)) == "90°"
    assert fmt_deg(units.DAV_DEG) == "0.74°"


def test_default_period_floor_is_5_3_ms():
    assert units.DEFAULT_PERIOD_FLOOR_US == 5300
    assert units.LONGEST_PULSE_US == 2500
