"""Position rules: what a written position really becomes."""

from __future__ import annotations

from ..diagnostics import Reporter, Severity
from ..plan import Plan
from ..units import DAV_DEG, fmt_deg, n_to_width_us, width_on_grid
from . import rule


def _positions(plan: Plan):
    for pose in plan.program.poses:
        for t in pose.targets:
            yield pose, t


def _num(x) -> str:
    return str(x.numerator) if x.denominator == 1 else f"{float(x):g}"


@rule("off-grid-width", Severity.WARNING)
def off_grid_width(plan: Plan, reporter: Reporter) -> None:
    """A pulse width that is not 500 us + a multiple of 8 us is rounded half up."""
    for pose, t in _positions(plan):
        p = t.position
        if p.unit == "us" and not width_on_grid(p.value):
            written = _num(p.value) + "us"
            reporter.warning(
                "off-grid-width",
                f"pulse width {written} is not on the 8 µs grid: it becomes N {p.n} = {n_to_width_us(p.n)} µs",
                t.span, label=f"rounded to {n_to_width_us(p.n)}us",
                help=f"write `{n_to_width_us(p.n)}us` (widths are 500 µs + 8 µs × N)")


@rule("inexact-angle", Severity.NOTE)
def inexact_angle(plan: Plan, reporter: Reporter) -> None:
    """An angle between two steps of 0.74 deg; said once per distinct angle."""
    said = set()
    for pose, t in _positions(plan):
        p = t.position
        if p.unit != "deg" or p.value == p.n * DAV_DEG or p.value in said:
            continue
        said.add(p.value)
        reporter.note(
            "inexact-angle",
            f"{_num(p.value)}deg is not exactly reachable: N {p.n} = {fmt_deg(p.n * DAV_DEG)}",
            t.span, label=f"N {p.n}",
            help=f"positions move in steps of 0.74°; write `{p.n}` (the raw N) or "
                 f"`{_num(p.n * DAV_DEG)}deg` to silence this")
