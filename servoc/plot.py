"""A plan drawn as a PNG: the positions over time, as written, and where the servos really are.

`plot_plan(plan, path, source)` draws one row per servo that gets pulses
(`plan.channels`), sharing a time axis in seconds:

* the commanded position as written in the program, in degrees (N x 0.74 deg):
  the plan's N are output N, after `reverse` and `trim`, and are drawn with
  both undone (`written_n`), so a pose reads as its source; frame i (0-based)
  of the golden frames (`plan.expand`) is commanded from i x P to (i + 1) x P,
  drawn as a step line;
* on a second axis, right, the pulse width of the output N, 500 + 8 N us
  (decreasing upwards for a reversed servo);
* the follower, dashed: a servo that moves at its top speed (1 DAV per
  t_DAV us) toward the current commanded target, the model of `follow`;
* in red, the frames where the servo is asked for more than its top speed, by
  the linter's own rule (`servoc.speed`, `over_speed_frames`): every moving
  frame of a move instance that is too fast (`infeasible-speed`), and the
  frames of an eased move whose step is more than one frame at top speed
  (`eased-overspeed`). A program with no speed finding has no red; a feasible
  linear move never has, though its rounded steps may be one N above average;
* a vertical line where a statement's frames start, labelled with its source
  line (`L12`), and a black dashed line where `main` ends.

The title counts the program's frames as `servoc plan` does in its `total:`
line. Frames are drawn up to the end of `main` plus a tail, or `max_frames`
frames for programs that loop forever (or whose main is longer). Statements
are told apart by their span, so consecutive runs of one statement (`repeat
3 { move a }`) show a single start line.

The output is deterministic: matplotlib's default style is used whatever the
user's matplotlibrc says, and the PNG metadata carries no time or version.
matplotlib is an optional dependency (extra `plot`), imported only when a
plot is drawn; its absence raises `MissingExtra`.
"""

from __future__ import annotations

import io
import itertools
import math
import os
from fractions import Fraction
from typing import Sequence

from . import model
from .plan import expand, GoldenFrame, move_frames_at
from .steps import MoveStep, Plan, steps
from .source import SourceFile
from .speed import frames_over, motion_frames_over, t_dav_of
from .toolchain import write_atomic
from .units import BASE_US, DAV_DEG, DIV_US, N_MAX, fmt_ms

__all__ = ["MissingExtra", "follow", "follow_points", "frames_to_plot", "over_speed_frames", "plot_figure",
           "plot_plan", "render_plan", "statement_starts", "title_text", "width_us", "written_deg", "written_n"]

DPI = 100
WIDTH_IN = 12.0
ROW_IN = 1.5            # height of one servo's row
TOP_IN = 1.0            # title, legend and line labels above the first row
BOTTOM_IN = 0.55        # the time axis below the last row
LEFT_IN = 1.1           # servo names
RIGHT_IN = 0.85         # the pulse-width axis
COMMANDED_COLOR = "tab:blue"
FOLLOWER_COLOR = "tab:orange"
OVER_SPEED_COLOR = "#ff0000"
BOUNDARY_COLOR = "0.72"
MIN_LABEL_GAP = 0.012   # fraction of the time axis between two source-line labels


class MissingExtra(ImportError):
    """An optional dependency of an output format is not installed."""

    def __init__(self, feature: str, extra: str, package: str):
        self.feature = feature
        self.extra = extra
        self.package = package
        self.pip_command = f"pip install 'servoc[{extra}]'"
        super().__init__(f"{feature} needs the Python package {package}, which is not installed; "
                         f"install it with: {self.pip_command}  (or: pip install {package})", name=package)


# ----------------------------------------------------------------- the models (pure)

def written_n(servo: model.Servo, n: int | Fraction) -> int | Fraction:
    """The N as written in the program for output N `n`: trim, then reverse, undone."""
    n = n - servo.trim
    return N_MAX - n if servo.reverse else n


def written_deg(servo: model.Servo, n: int | Fraction) -> float:
    """The angle as written for output N `n`, in degrees."""
    return float(written_n(servo, n) * DAV_DEG)


def width_us(servo: model.Servo, deg):
    """The pulse width (us) sent for a position written as `deg` degrees: 500 + 8 x output N.
    Affine, so it takes numbers or numpy arrays (the plot's second axis)."""
    n = deg / float(DAV_DEG)
    out = (N_MAX - n if servo.reverse else n) + servo.trim
    return BASE_US + DIV_US * out


def width_to_deg(servo: model.Servo, width):
    """The inverse of `width_us`."""
    n = (width - BASE_US) / DIV_US - servo.trim
    return (N_MAX - n if servo.reverse else n) * float(DAV_DEG)


def over_speed_frames(plan: Plan, frames: Sequence[GoldenFrame]) -> list[list[bool]]:
    """Per channel, per frame: the servo is asked for more than its top speed (`servoc.speed`).

    Each run of a move statement's frames is matched with the plan's move instance for the
    state it starts from (the instances the linter reads), and marked by `speed.frames_over`.
    Frames after `main` ends, holds, and servos set at once are never over speed."""
    count = len(plan.channels)
    flags = [[False] * len(frames) for _ in range(count)]
    moves = {st.span: st for st in steps(plan) if isinstance(st, MoveStep)}
    instances = {(id(inst.step), tuple(m.n0 for m in inst.motions)): inst for inst in plan.moves}
    classes = tuple(c.speed_class for c in plan.channels)
    end = len(frames) if plan.total_frames is None else min(len(frames), plan.total_frames)
    i = 0
    while i < end:
        step = moves.get(frames[i].span)
        if step is None:
            i += 1
            continue
        state = frames[i - 1].n if i > 0 else (None,) * count
        inst = instances.get((id(step), tuple(state[ch] for ch, _ in step.targets)))
        if inst is not None:
            f = inst.frames
            marks = [(m.channel, motion_frames_over(plan, inst, m)) for m in inst.motions]
        else:       # not a context the planner walked: the same rule on the state seen here
            f = move_frames_at(step, state, plan.speed_tables, classes)
            marks = [(ch, frames_over(state[ch], n1, f, step.ease, t_dav_of(plan, ch), plan.period_us))
                     for ch, n1 in step.targets]
        for ch, over in marks:
            for k, bad in enumerate(over[:end - i]):
                flags[ch][i + k] = bad
        i += f
    return flags


def title_text(plan: Plan, source: SourceFile, count: int) -> str:
    """The plot's title: the program, P, the servos, and the program's frames as `servoc plan`
    counts them (its `total:` line), with how many are drawn when that is fewer."""
    name = os.path.basename(source.path)
    servos = len(plan.channels)
    head = f"{name}: P = {fmt_ms(plan.period_us)}, {servos} servo{'s' if servos != 1 else ''}, "
    if plan.total_frames is None:
        return head + f"loops forever (the first {count} frames shown)"
    total = (f"{plan.total_frames} frame{'' if plan.total_frames == 1 else 's'} = "
             f"{fmt_ms(plan.total_frames * plan.period_us)}")
    if count < plan.total_frames:
        return head + f"{total} (the first {count} shown)"
    return head + f"{total}, then the last targets repeat"


def _follow_frames(targets: Sequence[int | None], t_dav_us: Fraction, period_us: int):
    """(start position, end position, arrival time within the frame or None) per frame, exact.

    Positions are in N (Fractions). The servo is at its first target when that target
    appears (set at once); before that, and while a frame has no target after it, it
    holds still (positions None before the first target)."""
    reach = Fraction(period_us) / Fraction(t_dav_us)      # N travelled in one frame at top speed
    pos: Fraction | None = None
    for target in targets:
        if target is None:
            yield pos, pos, None
            continue
        if pos is None:
            pos = Fraction(target)
        start = pos
        gap = target - pos
        if abs(gap) <= reach:
            arrival = None if gap == 0 else abs(gap) * Fraction(t_dav_us)
            pos = Fraction(target)
        else:
            arrival = None
            pos = pos + (reach if gap > 0 else -reach)
        yield start, pos, arrival


def follow(targets: Sequence[int | None], t_dav_us: Fraction, period_us: int) -> list[Fraction | None]:
    """Where a servo at top speed is at the end of each frame, in N (exact Fractions).

    `targets[i]` is the N commanded during frame i, which lasts from i x P to
    (i + 1) x P; the servo moves toward it at 1 N per `t_dav_us` microseconds and
    stops on it. When the first target appears the servo is already there. The
    result has one entry per frame: the position at time (i + 1) x P, None
    before the first target.
    """
    return [end for _, end, _ in _follow_frames(targets, t_dav_us, period_us)]


def follow_points(targets: Sequence[int | None], t_dav_us: Fraction,
                  period_us: int) -> list[tuple[Fraction, Fraction]]:
    """The follower's exact path as (time us, N) breakpoints, linear in between.

    The path starts when the first target appears; it has a point at every frame
    boundary and at every arrival inside a frame."""
    points: list[tuple[Fraction, Fraction]] = []
    for i, (start, end, arrival) in enumerate(_follow_frames(targets, t_dav_us, period_us)):
        if start is None:
            continue
        t0 = Fraction(i * period_us)
        if not points:
            points.append((t0, start))
        if arrival is not None and arrival < period_us:
            points.append((t0 + arrival, end))
        points.append((t0 + period_us, end))
    return points


def frames_to_plot(plan: Plan, max_frames: int) -> int:
    """How many frames to draw: main and a tail for the followers to settle, at most max_frames."""
    if plan.total_frames is None:
        return max_frames
    tail = max(10, math.ceil(plan.total_frames / 20))
    return max(1, min(max_frames, plan.total_frames + tail))


def statement_starts(frames: Sequence[GoldenFrame], source: SourceFile) -> list[tuple[int, int]]:
    """(0-based frame, 1-based source line) of every frame where a statement's frames start.

    A start is a frame whose span differs from the previous frame's; frames
    without a span (NO_SPAN) start nothing."""
    starts: list[tuple[int, int]] = []
    for i, fr in enumerate(frames):
        if (i == 0 or fr.span != frames[i - 1].span) and fr.span.end > fr.span.start:
            starts.append((i, source.line_col(fr.span.start)[0]))
    return starts


# ----------------------------------------------------------------- drawing

def _matplotlib():
    try:
        import matplotlib
        import matplotlib.style
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.transforms import blended_transform_factory
    except ImportError as exc:
        raise MissingExtra("plotting", "plot", "matplotlib") from exc
    return matplotlib, FigureCanvasAgg, LineCollection, Figure, Line2D, blended_transform_factory


def _servo_label(ch) -> str:
    servo = ch.servo
    label = f"{ch.name}\n{servo.pin} (deg)"
    undone = (["reverse"] if servo.reverse else []) + ([f"trim {servo.trim:+d}"] if servo.trim else [])
    return label + (f"\nas written ({', '.join(undone)})" if undone else "")


def _draw(plan: Plan, source: SourceFile, max_frames: int, mpl):
    """The figure, drawn under matplotlib's default style (the caller holds the style context)."""
    if max_frames < 1:
        raise ValueError(f"max_frames must be at least 1, got {max_frames!r}")
    matplotlib, FigureCanvasAgg, LineCollection, Figure, Line2D, blended = mpl
    count = frames_to_plot(plan, max_frames)
    frames = list(itertools.islice(expand(plan), count))
    period = plan.period_us
    seconds = [i * period / 1e6 for i in range(count + 1)]
    channels = plan.channels
    rows = max(1, len(channels))
    height = TOP_IN + BOTTOM_IN + ROW_IN * rows

    starts = statement_starts(frames, source)
    main_end = plan.total_frames if plan.total_frames is not None and plan.total_frames <= count else None
    over = over_speed_frames(plan, frames)

    fig = Figure(figsize=(WIDTH_IN, height), dpi=DPI)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=LEFT_IN / WIDTH_IN, right=1 - RIGHT_IN / WIDTH_IN,
                        top=1 - TOP_IN / height, bottom=BOTTOM_IN / height, hspace=0.22)
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    fig.suptitle(title_text(plan, source, count), x=LEFT_IN / WIDTH_IN, y=1 - 0.12 / height, ha="left",
                 va="top", fontsize=11)
    any_over = False
    for ax, ch in zip(axes, channels):
        servo = ch.servo
        targets = [fr.n[ch.index] for fr in frames]
        t_dav = t_dav_of(plan, ch.index)
        deg = [math.nan if n is None else written_deg(servo, n) for n in targets]
        ax.step(seconds, deg + deg[-1:], where="post", color=COMMANDED_COLOR, linewidth=1.2, zorder=2,
                gid=f"commanded:{ch.name}")
        segments = [[(seconds[i], deg[i - 1] if i > 0 else deg[i]), (seconds[i], deg[i]), (seconds[i + 1], deg[i])]
                    for i, bad in enumerate(over[ch.index]) if bad]
        if segments:
            any_over = True
            ax.add_collection(LineCollection(segments, colors=OVER_SPEED_COLOR, linewidths=2.4, zorder=3,
                                             gid=f"over-speed:{ch.name}"))
        path = follow_points(targets, t_dav, period)
        if path:
            ax.plot([float(t) / 1e6 for t, _ in path], [written_deg(servo, n) for _, n in path],
                    color=FOLLOWER_COLOR, linestyle="--", linewidth=1.2, zorder=4, gid=f"follower:{ch.name}")
        ax.set_ylabel(_servo_label(ch), fontsize=8)
        ax.tick_params(labelsize=7)
        known = [d for d in deg if not math.isnan(d)]
        if known:
            lo, hi = min(known), max(known)
            pad = max(2.0, (hi - lo) * 0.12)
            ax.set_ylim(lo - pad, hi + pad)
        width = ax.secondary_yaxis("right", functions=(lambda d, s=servo: width_us(s, d),
                                                       lambda w, s=servo: width_to_deg(s, w)))
        width.set_gid(f"width:{ch.name}")
        width.set_ylabel("width (µs)", fontsize=8)
        width.tick_params(labelsize=7)
    if not channels:
        axes[0].text(0.5, 0.5, "no servo is moved", ha="center", va="center", transform=axes[0].transAxes)
    for ax in axes:
        for i, _ in starts:
            ax.axvline(seconds[i], color=BOUNDARY_COLOR, linewidth=0.6, zorder=1)
        if main_end is not None:
            ax.axvline(seconds[main_end], color="black", linestyle=":", linewidth=1.0, zorder=1)
        ax.grid(axis="y", color="0.92", linewidth=0.5)
    axes[0].set_xlim(0, seconds[-1])
    axes[-1].set_xlabel("time (s)", fontsize=9)

    top = axes[0]
    label_at = blended(top.transData, top.transAxes)
    last = -math.inf
    for i, line in starts:
        x = seconds[i]
        if x - last >= MIN_LABEL_GAP * seconds[-1]:
            top.text(x, 1.02, f"L{line}", transform=label_at, rotation=90, fontsize=6,
                     ha="center", va="bottom", color="0.35")
            last = x
    if main_end is not None:
        top.text(seconds[main_end], 1.02, "end", transform=label_at, rotation=90, fontsize=6,
                 ha="center", va="bottom", color="black")

    handles = [Line2D([], [], color=COMMANDED_COLOR, linewidth=1.2, label="commanded, as written"),
               Line2D([], [], color=FOLLOWER_COLOR, linestyle="--", linewidth=1.2, label="servo at top speed")]
    if any_over:
        handles.append(Line2D([], [], color=OVER_SPEED_COLOR, linewidth=2.4, label="over top speed (lint)"))
    handles.append(Line2D([], [], color=BOUNDARY_COLOR, linewidth=0.8, label="statement start (line)"))
    fig.legend(handles=handles, loc="upper left", bbox_to_anchor=(LEFT_IN / WIDTH_IN - 0.01, 1 - 0.36 / height),
               ncol=len(handles), fontsize=8, frameon=False, borderaxespad=0)
    return fig


def plot_figure(plan: Plan, source: SourceFile, max_frames: int = 4000):
    """The plan's plot (see the module docstring) as a matplotlib Figure, for inspection."""
    mpl = _matplotlib()
    with mpl[0].style.context("default"):
        return _draw(plan, source, max_frames, mpl)


def render_plan(plan: Plan, source: SourceFile, max_frames: int = 4000) -> bytes:
    """The PNG bytes of the plan's plot (see the module docstring)."""
    mpl = _matplotlib()
    with mpl[0].style.context("default"):
        fig = _draw(plan, source, max_frames, mpl)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=DPI,
                    metadata={"Software": None, "Title": os.path.basename(source.path)})
    return buf.getvalue()


def plot_plan(plan: Plan, path: str, source: SourceFile, max_frames: int = 4000) -> None:
    """Draw the plan (see the module docstring) and write it to `path` as a PNG, atomically."""
    write_atomic(path, render_plan(plan, source, max_frames))
