"""servoc.plot: the follower model, the over-speed rule, statement starts, and the PNG itself.

The models are checked against hand-computed values; the PNG is decoded
with Pillow (a matplotlib dependency) and its pixels inspected: the red of
an over-speed step must be there exactly when some frame is over speed.
"""

from __future__ import annotations

import io
import os
import random
import sys
from fractions import Fraction

import numpy as np
import pytest
from PIL import Image

from servoc import plot
from servoc.plan import expand
from servoc.plot import (MissingExtra, follow, follow_points, frames_to_plot, over_speed, plot_plan, render_plan,
                         statement_starts)
from servoc.units import DEFAULT_T_DAV_US

from conftest import front_end_text

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# Eased moves that ask servo `a` for more than its top speed (the linter warns, eased-overspeed).
FAST = """\
frame 20ms
servo a = P1.0
servo b = P2.3 speed 0.4s/60deg
pose lo { a: 40deg, b: 60deg }
pose hi { a: 140deg, b: 100deg }
main {
  move lo
  hold 100ms
  move hi in 400ms ease in-out
  hold 300ms
  move lo in 500ms ease in
  hold 200ms
}
"""

# The same servos, every step well within their top speed.
SLOW = FAST.replace("move hi in 400ms", "move hi in 1500ms").replace("move lo in 500ms ease in", "move lo in 1800ms")

# Statement starts by hand: frame 0 L7 (move lo, 1 frame), 1..5 L8 (hold 5), 6..15 L9 (10 frames),
# then twice: L11 (5 frames), L12 (2 frames).
STARTS = """\
frame 20ms
servo a = P1.0
pose lo { a: 10 }
pose hi { a: 40 }

main {
  move lo
  hold 100ms
  move hi in 200ms
  repeat 2 {
    move lo in 100ms
    hold 40ms
  }
}
"""


def front(text: str):
    fe, diags = front_end_text(text)
    assert fe.plan is not None, [str(d) for d in diags]
    assert not any(d.is_error for d in diags)
    return fe


def channel_targets(plan, count: int):
    frames = [fr for fr, _ in zip(expand(plan), range(count))]
    return {ch.name: [fr.n[ch.index] for fr in frames] for ch in plan.channels}


# ============================================================ the follower

def test_follow_hand_computed_lag_and_catch_up():
    # 1 N per 2000 us, frames of 5000 us: at most 2.5 N per frame.
    targets = [None, 10, 10, 20, 20, 20, 20, 14, 14]
    got = follow(targets, Fraction(2000), 5000)
    want = [None, 10, 10, Fraction(25, 2), 15, Fraction(35, 2), 20, Fraction(35, 2), 15]
    assert got == want
    # then it reaches 14 one frame later and stays there
    assert follow(targets + [14, 14], Fraction(2000), 5000)[-3:] == [15, 14, 14]


def test_follow_starts_on_the_first_target_and_reverses_at_top_speed():
    got = follow([None, None, 100, 0, 0, 100], Fraction(1000), 3000)       # 3 N per frame
    assert got == [None, None, 100, 97, 94, 97]


def test_follow_default_servo_exact_fractions():
    # HG14-M: t_DAV = 7400/3 us, P = 5.3 ms: 159/74 N per frame.
    reach = Fraction(5300) / DEFAULT_T_DAV_US
    assert reach == Fraction(159, 74)
    got = follow([0, 100, 100, 100], DEFAULT_T_DAV_US, 5300)
    assert got == [0, reach, 2 * reach, 3 * reach]
    # a step of 2 N fits in one frame (2 x 2466.7 us < 5300 us): no lag at all
    assert follow([50, 52, 54], DEFAULT_T_DAV_US, 5300) == [50, 52, 54]


def test_follow_points_mark_the_arrival_inside_a_frame():
    # From 10 toward 13 at 1 N per 1000 us with P = 5000 us: arrives 3000 us into frame 1.
    pts = follow_points([10, 13, 13], Fraction(1000), 5000)
    assert pts == [(0, 10), (5000, 10), (8000, 13), (10000, 13), (15000, 13)]
    # a lagging servo has only frame boundaries, moving at exactly the top speed between them
    pts = follow_points([None, 0, 20], Fraction(1000), 5000)
    assert pts == [(5000, 0), (10000, 0), (15000, 5)]
    assert follow_points([None, None], Fraction(1000), 5000) == []


def test_follow_never_exceeds_top_speed_nor_overshoots():
    rng = random.Random(1234)
    for _ in range(200):
        t_dav = Fraction(rng.randint(500, 6000), rng.randint(1, 7))
        period = rng.randint(2000, 25000)
        targets = [rng.randint(0, 250) for _ in range(rng.randint(1, 40))]
        reach = Fraction(period) / t_dav
        pos = follow(targets, t_dav, period)
        prev = Fraction(targets[0])
        for target, p in zip(targets, pos):
            assert abs(p - prev) <= reach
            assert min(prev, target) <= p <= max(prev, target)      # toward the target, never past it
            assert p == target or abs(p - prev) == reach             # either there, or at full speed
            prev = p
        # the breakpoints describe the same path, with slopes within the top speed
        pts = follow_points(targets, t_dav, period)
        for (t0, n0), (t1, n1) in zip(pts, pts[1:]):
            assert t1 > t0
            assert abs(n1 - n0) * t_dav <= t1 - t0
        ends = {t: n for t, n in pts}
        assert [ends[(i + 1) * period] for i in range(len(targets))] == pos


def test_follow_catches_up_with_a_held_target():
    t_dav, period = DEFAULT_T_DAV_US, 5300
    targets = [0] + [250] * 130
    pos = follow(targets, t_dav, period)
    # 250 N at 159/74 N per frame: ceil(250 x 74 / 159) = 117 frames
    first = next(i for i, p in enumerate(pos) if p == 250)
    assert first == 117
    assert pos[first - 1] < 250
    assert all(p == 250 for p in pos[first:])


# ============================================================ over speed

def test_over_speed_hand_computed():
    t_dav = DEFAULT_T_DAV_US                   # 2466.67 us per N; P = 5300 us: 2 N fit, 3 do not
    assert over_speed([None, 0, 2, 5, 5, 2, 0, 3], t_dav, 5300) == [False, False, False, True, False, True,
                                                                     False, True]
    # exactly the top speed is not over it: 2 N x 2500 us = 5000 us = P
    assert over_speed([10, 12, 15, 12], Fraction(2500), 5000) == [False, False, True, True]
    # a servo set at once (no previous target) is never over speed
    assert over_speed([None, 250], Fraction(2500), 5000) == [False, False]
    assert over_speed([], Fraction(2500), 5000) == []


def test_fast_program_is_over_speed_and_the_follower_lags():
    plan = front(FAST).plan
    targets = channel_targets(plan, plan.total_frames + 5)
    a = plan.channel_of("a")
    t_dav = plan.class_t_dav_us[a.speed_class]
    over = over_speed(targets["a"], t_dav, plan.period_us)
    assert any(over)
    pos = follow(targets["a"], t_dav, plan.period_us)
    assert max(abs(p - t) for p, t in zip(pos, targets["a"])) > 5          # lags more than 5 N
    assert pos[plan.total_frames - 1] == targets["a"][plan.total_frames - 1]   # and arrives by the end
    slow = front(SLOW).plan
    for name, ts in channel_targets(slow, slow.total_frames + 5).items():
        ch = slow.channel_of(name)
        assert not any(over_speed(ts, slow.class_t_dav_us[ch.speed_class], slow.period_us))


# ============================================================ statement starts and frame count

def test_statement_starts_follow_the_source_lines():
    fe = front(STARTS)
    plan = fe.plan
    assert plan.total_frames == 30
    frames = [fr for fr, _ in zip(expand(plan), range(34))]
    assert statement_starts(frames, fe.source) == [(0, 7), (1, 8), (6, 9), (16, 11), (21, 12), (23, 11), (28, 12)]
    # one statement: every frame, the repeated last ones included, carries its span
    one = front("servo a = P1.0\npose lo { a: 10 }\nmain {\n  move lo in 100ms\n}\n")
    frames = [fr for fr, _ in zip(expand(one.plan), range(40))]
    assert statement_starts(frames, one.source) == [(0, 4)]


def test_frames_to_plot():
    plan = front(STARTS).plan                       # 30 frames
    assert frames_to_plot(plan, 4000) == 40          # main and a tail of at least 10 frames
    assert frames_to_plot(plan, 25) == 25
    looping = front(STARTS.replace("repeat 2", "loop")).plan
    assert looping.total_frames is None
    assert frames_to_plot(looping, 123) == 123


# ============================================================ the PNG

def pixels(img: Image.Image) -> np.ndarray:
    return np.asarray(img.convert("RGB")).reshape(-1, 3).astype(int)


def red_pixels(img: Image.Image) -> int:
    px = pixels(img)
    return int(((px[:, 0] >= 200) & (px[:, 1] <= 60) & (px[:, 2] <= 60)).sum())


def colors(img: Image.Image) -> set[tuple[int, int, int]]:
    return {tuple(p) for p in np.unique(pixels(img), axis=0).tolist()}


def decode(data: bytes) -> Image.Image:
    assert data[:8] == PNG_SIGNATURE
    img = Image.open(io.BytesIO(data))
    img.verify()
    img = Image.open(io.BytesIO(data))
    assert img.format == "PNG"
    return img.convert("RGB")


def test_png_of_an_over_speed_program(tmp_path):
    fe = front(FAST)
    out = tmp_path / "fast.png"
    plot_plan(fe.plan, str(out), fe.source)
    data = out.read_bytes()
    assert len(data) > 10_000
    img = decode(data)
    # 12 in wide at 100 dpi; two rows of 1.5 in plus the margins
    assert img.size == (1200, round(100 * (plot.TOP_IN + plot.BOTTOM_IN + 2 * plot.ROW_IN)))
    found = colors(img)
    assert len(found) > 50
    assert red_pixels(img) > 200
    assert (31, 119, 180) in found             # tab:blue, the commanded angle
    assert (255, 127, 14) in found             # tab:orange, the follower
    assert sorted(os.listdir(tmp_path)) == ["fast.png"]       # no temporary file left behind


def test_png_without_over_speed_has_no_red(tmp_path):
    fe = front(SLOW)
    out = tmp_path / "slow.png"
    plot_plan(fe.plan, str(out), fe.source)
    img = decode(out.read_bytes())
    assert red_pixels(img) == 0
    assert len(colors(img)) > 50


def test_png_is_deterministic_and_bounded_for_endless_programs():
    fe = front(STARTS.replace("repeat 2", "loop"))
    first = render_plan(fe.plan, fe.source, max_frames=300)
    assert first == render_plan(fe.plan, fe.source, max_frames=300)
    assert b"Matplotlib" not in first                      # no version text in the metadata
    img = decode(first)
    assert img.size[0] == 1200
    with pytest.raises(ValueError):
        render_plan(fe.plan, fe.source, max_frames=0)


def test_missing_matplotlib_raises_missing_extra(tmp_path, monkeypatch):
    fe = front(STARTS)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    out = tmp_path / "x.png"
    with pytest.raises(MissingExtra) as info:
        plot_plan(fe.plan, str(out), fe.source)
    assert isinstance(info.value, ImportError)
    assert "pip install 'servoc[plot]'" in str(info.value)
    assert info.value.pip_command == "pip install 'servoc[plot]'"
    assert not out.exists()
