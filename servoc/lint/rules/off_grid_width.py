"""off-grid-width: a pulse width that is not 500 us + a multiple of 8 us is rounded half up."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...units import n_to_width_us, width_on_grid
from .. import Report, rule
from ..common import num, positions


@rule("off-grid-width", Severity.WARNING)
def off_grid_width(plan: Plan, report: Report) -> None:
    """A pulse width that is not 500 us + a multiple of 8 us is rounded half up."""
    for pose, t in positions(plan):
        p = t.position
        if p.unit == "us" and not width_on_grid(p.value):
            written = num(p.value) + "us"
            report(f"pulse width {written} is not on the 8 µs grid: it becomes N {p.n} = {n_to_width_us(p.n)} µs",
                   t.span, label=f"rounded to {n_to_width_us(p.n)}us",
                   help=f"write `{n_to_width_us(p.n)}us` (widths are 500 µs + 8 µs × N)")
