"""inexact-angle: an angle between two steps of 0.74 deg; said once per distinct angle."""

from __future__ import annotations

from ...diagnostics import Severity
from ...plan import Plan
from ...units import DAV_DEG, fmt_deg
from .. import Report, rule
from ..common import num, positions


@rule("inexact-angle", Severity.NOTE)
def inexact_angle(plan: Plan, report: Report) -> None:
    """An angle between two steps of 0.74 deg; said once per distinct angle."""
    said = set()
    for pose, t in positions(plan):
        p = t.position
        if p.unit != "deg" or p.value == p.n * DAV_DEG or p.value in said:
            continue
        said.add(p.value)
        report(f"{num(p.value)}deg is not exactly reachable: N {p.n} = {fmt_deg(p.n * DAV_DEG)}",
               t.span, label=f"N {p.n}",
               help=f"positions move in steps of 0.74°; write `{p.n}` (the raw N) or "
                    f"`{num(p.n * DAV_DEG)}deg` to silence this")
