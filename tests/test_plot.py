"""servoc.plot: the follower model, the over-speed marks, statement starts, and the PNG itself.

The models are checked against hand-computed values. The red marks come from
the linter's own rule (`servoc.speed`): a program without speed findings has
none, one with findings has them exactly on the frames the rule names. The
figure is inspected through its artists (found by gid: `commanded:SERVO`,
`follower:SERVO`, `over-speed:SERVO`, `width:SERVO`) and the PNG decoded with
Pillow (a matplotlib dependency): the red of an over-speed step must be
there exactly when some frame is over speed.
"""

from __future__ import annotations

import io
import os
import random
import re
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from servoc import api, cli, plot, speed
from servoc.plan import expand
from servoc.plot import (MissingExtra, follow, follow_points, frames_to_plot, over_speed_frames, plot_figure,
                         plot_plan, render_plan, statement_starts, width_us, written_deg, written_n)
from servoc.source import SourceFile
from servoc.units import DAV_DEG, DEFAULT_T_DAV_US

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


# ============================================================ over speed: the linter's rule

ROOT = Path(__file__).resolve().parent.parent
README_PROGRAM = re.search(r"```servo\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S).group(1)
README_FIXED = README_PROGRAM.replace("move crouch in 100ms ease in-out", "move crouch in 345ms ease in-out")
README_124 = README_PROGRAM.replace("move crouch in 100ms ease in-out", "move crouch in 124ms ease in-out")


def any_front(text: str, name: str = "prog.servo"):
    """The front end of a program whose plan exists, lint errors allowed: (front end, diagnostics)."""
    source = SourceFile(name, text)
    reporter = api.Reporter(source)
    fe = api.front_end(source, reporter)
    assert fe.plan is not None, [str(d) for d in reporter.diagnostics]
    return fe, reporter.sorted()


def speed_lines(fe, diags) -> set[int]:
    return {fe.source.line_col(d.span.start)[0] for d in diags if d.code in ("infeasible-speed", "eased-overspeed")}


def marked_lines(fe, frames, flags) -> set[int]:
    return {fe.source.line_col(frames[i].span.start)[0]
            for per_channel in flags for i, bad in enumerate(per_channel) if bad}


def first_frames(plan, count: int | None = None):
    return [fr for fr, _ in zip(expand(plan), range(count or (plan.total_frames or 400) + 5))]


def test_frames_over_hand_computed():
    t_dav = DEFAULT_T_DAV_US                   # 2466.67 us per N; P = 5300 us: 2 N fit in a frame, 3 do not
    # linear, feasible, though rounding steps 2 N at 2 of 3 frames: 5 N x 2466.7 = 12333 us <= 3 x 5300
    assert speed.curve_steps(0, 5, 3, "linear") == [2, 1, 2]
    assert speed.frames_over(0, 5, 3, "linear", t_dav, 5300) == [False, False, False]
    # linear, 7 N in 3 frames: 17267 us > 15900 us: every moving frame of the move
    assert speed.frames_over(0, 7, 3, "linear", t_dav, 5300) == [True, True, True]
    assert speed.frames_over(10, 3, 3, "linear", t_dav, 5300) == [True, True, True]
    # a servo slower than a frame (t_DAV 6000 us > P = 4000 us): 3 N in 4 frames is infeasible
    # (18000 us > 16000 us); only its moving frames are marked
    assert speed.curve_steps(0, 3, 4, "linear") == [1, 1, 0, 1]
    assert speed.frames_over(0, 3, 4, "linear", Fraction(6000), 4000) == [True, True, False, True]
    # 2 N in 3 frames is not (12000 us <= 12000 us), though each step of 1 N takes longer than a frame
    assert speed.frames_over(0, 2, 3, "linear", Fraction(6000), 4000) == [False, False, False]
    # eased, feasible on average (12 N x 2466.7 us <= 8 x 5300 us): only the last step, 3 N, is marked
    steps = speed.curve_steps(0, 12, 8, "in")
    assert steps == [0, 1, 1, 1, 2, 2, 2, 3]
    assert speed.frames_over(0, 12, 8, "in", t_dav, 5300) == [False] * 7 + [True]
    assert speed.frames_over(12, 0, 8, "in", t_dav, 5300) == [False] * 7 + [True]
    assert speed.peak_step(0, 12, 8, "in") == 3
    # exactly top speed is not over it: 3 N x 1666.7 us = 5000 us = P
    assert speed.frames_over(0, 12, 8, "in", Fraction(5000, 3), 5000) == [False] * 8
    # a servo set at once, and a move that goes nowhere, are never over speed
    assert speed.frames_over(None, 250, 2, "linear", t_dav, 5300) == [False, False]
    assert speed.frames_over(7, 7, 2, "in", t_dav, 5300) == [False, False]


def test_readme_fixed_example_has_no_red():
    # line 13, `move stand` at 98 % of the knee's top speed, steps 2 N in some frames (2 x 3083 us > 6 ms):
    # lint accepts the move (40 x 3083 us <= 21 x 6 ms), so the plot does not mark it either
    fe, diags = any_front(README_FIXED)
    assert speed_lines(fe, diags) == set() and not any(d.is_error for d in diags)
    plan = fe.plan
    frames = first_frames(plan)
    knee = plan.channel_of("knee").index
    steps = [abs(b.n[knee] - a.n[knee]) for a, b in zip(frames, frames[1:]) if a.n[knee] is not None]
    assert max(steps) == 2                   # the old per-frame test marked these
    assert not any(any(f) for f in over_speed_frames(plan, frames))
    fig = plot_figure(plan, fe.source)
    assert [a for ax in fig.axes for a in ax.collections if (a.get_gid() or "").startswith("over-speed:")] == []
    img = decode(render_plan(plan, fe.source))
    assert red_pixels(img) == 0


def test_readme_124ms_example_is_red_on_the_knees_steepest_frames():
    fe, diags = any_front(README_124)
    assert [d.code for d in diags if d.code not in ("inexact-angle", "no-home")] == ["eased-overspeed"]
    assert speed_lines(fe, diags) == {11}
    plan = fe.plan
    frames = first_frames(plan)
    flags = over_speed_frames(plan, frames)
    knee = plan.channel_of("knee")
    assert marked_lines(fe, frames, flags) == {11}
    assert not any(flags[plan.channel_of("hip").index]) and not any(flags[plan.channel_of("foot").index])
    # exactly the frames of line 11 whose step is more than one frame at the knee's top speed
    t_dav = plan.class_t_dav_us[knee.speed_class]
    on_11 = [i for i, fr in enumerate(frames) if fe.source.line_col(fr.span.start)[0] == 11]
    step = {i: abs(frames[i].curve[knee.index] - frames[i - 1].curve[knee.index]) for i in on_11}
    want = [i in step and step[i] * t_dav > plan.period_us for i in range(len(frames))]
    assert flags[knee.index] == want and sum(want) >= 3 * 5          # three bobs, a handful of frames each
    # the steepest frames of each bob (3 N: 9.25 ms of a 6 ms frame) are among them, and nothing of 1 N is
    assert max(step.values()) == 3
    assert all(want[i] for i in on_11 if step[i] == 3) and not any(want[i] for i in on_11 if step[i] <= 1)
    # and the figure draws one red segment per marked frame, in the knee's row only
    fig = plot_figure(plan, fe.source)
    red = {a.get_gid(): a for ax in fig.axes for a in ax.collections if (a.get_gid() or "").startswith("over-speed:")}
    assert list(red) == ["over-speed:knee"] and len(red["over-speed:knee"].get_segments()) == sum(want)
    assert red_pixels(decode(render_plan(plan, fe.source))) > 100


@pytest.mark.parametrize("name", ["biped.servo", "hexapod.servo", "pan_tilt.servo", "README", "README_124",
                                  "FAST", "SLOW", "INFEASIBLE"])
def test_red_exactly_where_lint_reports_speed(name):
    text = {"README": README_FIXED, "README_124": README_124, "FAST": FAST, "SLOW": SLOW,
            "INFEASIBLE": README_PROGRAM}.get(name) or (ROOT / "examples" / name).read_text(encoding="utf-8")
    fe, diags = any_front(text)
    plan = fe.plan
    frames = first_frames(plan, min(6000, (plan.total_frames or 3000) + 5))
    assert marked_lines(fe, frames, over_speed_frames(plan, frames)) == speed_lines(fe, diags)
    # and per move instance: some frame is over speed exactly when lint would speak of its statement
    flagged = {id(inst.step) for inst in plan.moves for m in inst.motions if any(speed.motion_frames_over(plan, inst, m))}
    assert {fe.source.line_col(st.span.start)[0] for st in (i.step for i in plan.moves)
            if id(st) in flagged} == speed_lines(fe, diags)


def test_infeasible_move_is_red_on_every_moving_frame():
    fe, diags = any_front(README_PROGRAM)             # `in 100ms`: infeasible-speed on line 11
    assert "infeasible-speed" in [d.code for d in diags]
    plan = fe.plan
    frames = first_frames(plan)
    flags = over_speed_frames(plan, frames)
    knee = plan.channel_of("knee").index
    on_11 = [i for i, fr in enumerate(frames) if fe.source.line_col(fr.span.start)[0] == 11]
    moving = [i for i in on_11 if frames[i].curve[knee] != frames[i - 1].curve[knee]]
    assert moving and [i for i, bad in enumerate(flags[knee]) if bad] == moving


def test_fast_program_is_over_speed_and_the_follower_lags():
    plan = front(FAST).plan
    targets = channel_targets(plan, plan.total_frames + 5)
    a = plan.channel_of("a")
    t_dav = plan.class_t_dav_us[a.speed_class]
    over = over_speed_frames(plan, first_frames(plan, plan.total_frames + 5))
    assert any(over[a.index])
    pos = follow(targets["a"], t_dav, plan.period_us)
    assert max(abs(p - t) for p, t in zip(pos, targets["a"])) > 5          # lags more than 5 N
    assert pos[plan.total_frames - 1] == targets["a"][plan.total_frames - 1]   # and arrives by the end
    slow = front(SLOW).plan
    assert not any(any(f) for f in over_speed_frames(slow, first_frames(slow, slow.total_frames + 5)))


# ============================================================ positions as written, widths, title

REVERSED = """\
frame 10ms
servo a = P1.0 reverse trim -3
servo b = P1.1 trim 4
servo c = P1.2
pose lo { a: 20deg, b: 30deg, c: 1000us }
pose hi { a: 150deg, b: 60deg, c: 2000us }
main {
  move lo
  move hi in 1s
  hold 100ms
  move lo in 1s ease out
}
"""


def test_written_n_undoes_reverse_and_trim():
    fe = front(REVERSED)
    plan = fe.plan
    for pose in plan.program.poses:
        for target in pose.targets:
            servo = plan.channel_of(target.servo).servo
            assert written_n(servo, target.n) == target.position.n
            assert width_us(servo, target.position.n * float(DAV_DEG)) == pytest.approx(500 + 8 * target.n)
    a = plan.channel_of("a").servo
    assert (a.reverse, a.trim) == (True, -3)
    assert written_n(a, 250 - 27 - 3) == 27 and written_deg(a, 220) == pytest.approx(27 * 0.74)


def test_plotted_positions_are_as_written():
    fe = front(REVERSED)
    plan = fe.plan
    fig = plot_figure(plan, fe.source)
    lines = {ln.get_gid(): ln for ax in fig.axes for ln in ax.lines if ln.get_gid()}
    frames = first_frames(plan, frames_to_plot(plan, 4000))
    written = {p.name: {t.servo: t.position.n for t in p.targets} for p in plan.program.poses}
    for ch in plan.channels:
        y = list(lines[f"commanded:{ch.name}"].get_ydata())
        n_out = [fr.n[ch.index] for fr in frames]
        assert y[:-1] == pytest.approx([float(written_n(ch.servo, n) * DAV_DEG) for n in n_out])
        # the first frame is pose lo, the last pose hi's return to lo: the values written in the program
        assert y[0] == pytest.approx(written["lo"][ch.name] * float(DAV_DEG))
        assert max(y[:-1]) == pytest.approx(max(written["lo"][ch.name], written["hi"][ch.name]) * float(DAV_DEG))
        follower = lines[f"follower:{ch.name}"].get_ydata()
        assert min(follower) >= min(y[:-1]) - 1e-9 and max(follower) <= max(y[:-1]) + 1e-9
    # the second axis: the output width for the row's positions (500 + 8 N, N after reverse and trim)
    fig.canvas.draw()
    for ax in fig.axes:
        width = next((c for c in ax.child_axes if (c.get_gid() or "").startswith("width:")), None)
        if width is None:
            continue
        servo = plan.channel_of(width.get_gid().split(":", 1)[1]).servo
        lo, hi = ax.get_ylim()
        assert sorted(width.get_ylim()) == pytest.approx(sorted([width_us(servo, lo), width_us(servo, hi)]))
        assert width.get_ylabel() == "width (µs)"
    assert sum(1 for ax in fig.axes for c in ax.child_axes if (c.get_gid() or "").startswith("width:")) == 3
    ylabels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel().startswith("a\n")]
    assert ylabels == ["a\nP1.0 (deg)\nas written (reverse, trim -3)"]


@pytest.mark.parametrize("text, max_frames", [(README_FIXED, 4000), (REVERSED, 4000), (STARTS, 4000), (STARTS, 12),
                                              (STARTS.replace("repeat 2", "loop"), 300)])
def test_title_counts_the_frames_plan_prints(text, max_frames, tmp_path, capsys):
    path = tmp_path / "prog.servo"
    path.write_text(text)
    assert cli.main(["plan", str(path)]) == 0
    total = capsys.readouterr().out.splitlines()[-1]
    fe = front(text)
    title = plot_figure(fe.plan, fe.source, max_frames=max_frames).get_suptitle()
    if fe.plan.total_frames is None:
        assert total == "total: the program loops forever"
        assert title.endswith(f"loops forever (the first {max_frames} frames shown)")
    else:
        m = re.fullmatch(r"total: (\d+ frames = [\d.]+ m?s), then the last targets repeat", total)
        assert m and f", {m.group(1)}" in title
        assert int(m.group(1).split()[0]) == fe.plan.total_frames
        shown = frames_to_plot(fe.plan, max_frames)
        assert title.endswith("then the last targets repeat" if shown >= fe.plan.total_frames
                              else f"(the first {shown} shown)")
    assert title.startswith("prog.servo: P = ")


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
