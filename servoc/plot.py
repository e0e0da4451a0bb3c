"""A plan drawn as a PNG: commanded angles over time, and where the servos really are.

`plot_plan(plan, path, source)` draws one row per servo that gets pulses
(`plan.channels`), sharing a time axis in seconds:

* the commanded angle, N x 0.74 deg of the golden frames (`plan.expand`),
  as a step line: frame i (0-based) is commanded from i x P to (i + 1) x P;
* the follower, dashed: a servo that moves at its top speed (1 DAV per
  t_DAV us) toward the current commanded target, the model of `follow`;
* in red, the frames whose step from the previous frame is more than the
  servo can travel in one frame (|N_i - N_(i-1)| x t_DAV > P, `over_speed`);
* a vertical line where a statement's frames start, labelled with its source
  line (`L12`), and a black dashed line where `main` ends.

Frames are drawn up to the end of `main` plus a tail, or `max_frames` frames
for programs that loop forever (or whose main is longer). Statements are told
apart by their span, so consecutive runs of one statement (`repeat 3 { move
a }`) show a single start line.

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

from .plan import GoldenFrame, Plan, expand
from .source import SourceFile
from .toolchain import write_atomic
from .units import DAV_DEG

__all__ = ["MissingExtra", "follow", "follow_points", "frames_to_plot", "over_speed", "plot_plan", "render_plan",
           "statement_starts"]

DPI = 100
WIDTH_IN = 12.0
ROW_IN = 1.5            # height of one servo's row
TOP_IN = 1.0            # title, legend and line labels above the first row
BOTTOM_IN = 0.55        # the time axis below the last row
LEFT_IN = 1.1           # servo names
RIGHT_IN = 0.25
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

def over_speed(targets: Sequence[int | None], t_dav_us: Fraction, period_us: int) -> list[bool]:
    """Per frame: the step from the previous frame's N is more than the servo travels in P.

    A frame whose previous frame has no target (the servo is set at once) is never over speed.
    """
    t_dav = Fraction(t_dav_us)
    result = [False] * len(targets)
    for i in range(1, len(targets)):
        a, b = targets[i - 1], targets[i]
        if a is not None and b is not None and abs(b - a) * t_dav > period_us:
            result[i] = True
    return result


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


def render_plan(plan: Plan, source: SourceFile, max_frames: int = 4000) -> bytes:
    """The PNG bytes of the plan's plot (see the module docstring)."""
    if max_frames < 1:
        raise ValueError(f"max_frames must be at least 1, got {max_frames!r}")
    matplotlib, FigureCanvasAgg, LineCollection, Figure, Line2D, blended = _matplotlib()
    count = frames_to_plot(plan, max_frames)
    frames = list(itertools.islice(expand(plan), count))
    period = plan.period_us
    seconds = [i * period / 1e6 for i in range(count + 1)]
    channels = plan.channels
    rows = max(1, len(channels))
    height = TOP_IN + BOTTOM_IN + ROW_IN * rows

    starts = statement_starts(frames, source)
    main_end = plan.total_frames if plan.total_frames is not None and plan.total_frames <= count else None

    name = os.path.basename(source.path)
    shown = f"first {count} frames" if plan.total_frames is None or count < plan.total_frames else f"{count} frames"
    title = (f"{name}: P = {period / 1000:g} ms, {len(channels)} servo{'s' if len(channels) != 1 else ''}, "
             f"{shown}{', loops forever' if plan.total_frames is None else ''}")

    with matplotlib.style.context("default"):
        fig = Figure(figsize=(WIDTH_IN, height), dpi=DPI)
        FigureCanvasAgg(fig)
        fig.subplots_adjust(left=LEFT_IN / WIDTH_IN, right=1 - RIGHT_IN / WIDTH_IN,
                            top=1 - TOP_IN / height, bottom=BOTTOM_IN / height, hspace=0.22)
        axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
        fig.suptitle(title, x=LEFT_IN / WIDTH_IN, y=1 - 0.12 / height, ha="left", va="top", fontsize=11)
        any_over = False
        for ax, ch in zip(axes, channels):
            targets = [fr.n[ch.index] for fr in frames]
            t_dav = plan.class_t_dav_us[ch.speed_class]
            deg = [math.nan if n is None else float(n * DAV_DEG) for n in targets]
            ax.step(seconds, deg + deg[-1:], where="post", color=COMMANDED_COLOR, linewidth=1.2, zorder=2)
            segments = []
            for i, over in enumerate(over_speed(targets, t_dav, period)):
                if over:
                    segments.append([(seconds[i], deg[i - 1]), (seconds[i], deg[i]), (seconds[i + 1], deg[i])])
            if segments:
                any_over = True
                ax.add_collection(LineCollection(segments, colors=OVER_SPEED_COLOR, linewidths=2.4, zorder=3))
            path = follow_points(targets, t_dav, period)
            if path:
                ax.plot([float(t) / 1e6 for t, _ in path], [float(n * DAV_DEG) for _, n in path],
                        color=FOLLOWER_COLOR, linestyle="--", linewidth=1.2, zorder=4)
            ax.set_ylabel(f"{ch.name}\n{ch.servo.pin} (deg)", fontsize=8)
            ax.tick_params(labelsize=7)
            known = [d for d in deg if not math.isnan(d)]
            if known:
                lo, hi = min(known), max(known)
                pad = max(2.0, (hi - lo) * 0.12)
                ax.set_ylim(lo - pad, hi + pad)
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

        handles = [Line2D([], [], color=COMMANDED_COLOR, linewidth=1.2, label="commanded"),
                   Line2D([], [], color=FOLLOWER_COLOR, linestyle="--", linewidth=1.2, label="servo at top speed")]
        if any_over:
            handles.append(Line2D([], [], color=OVER_SPEED_COLOR, linewidth=2.4, label="step over top speed"))
        handles.append(Line2D([], [], color=BOUNDARY_COLOR, linewidth=0.8, label="statement start (line)"))
        fig.legend(handles=handles, loc="upper right", bbox_to_anchor=(1 - RIGHT_IN / WIDTH_IN, 1 - 0.05 / height),
                   ncol=len(handles), fontsize=8, frameon=False)

        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=DPI, metadata={"Software": None, "Title": name})
    return buf.getvalue()


def plot_plan(plan: Plan, path: str, source: SourceFile, max_frames: int = 4000) -> None:
    """Draw the plan (see the module docstring) and write it to `path` as a PNG, atomically."""
    write_atomic(path, render_plan(plan, source, max_frames))
