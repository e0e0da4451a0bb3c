"""inexact-angle: angles between two steps of 0.74 deg; one note for the whole program."""

from __future__ import annotations

from ...diagnostics import Severity
from ...steps import Plan
from ...units import DAV_DEG, deg_on_grid, fmt_deg
from .. import Report, rule
from ..common import num, positions

SHOWN = 3       # angles the note names; it counts the others


@rule("inexact-angle", Severity.NOTE)
def inexact_angle(plan: Plan, report: Report) -> None:
    """Angles between two steps of 0.74 deg: one note, at the first of them, naming the first few."""
    places = {}         # span -> target, each written position once (a derived pose shares its base's)
    for _pose, t in positions(plan):
        p = t.position
        if p.unit == "deg" and not deg_on_grid(p.value, p.n):
            places.setdefault((t.span.start, t.span.end), t)
    if not places:
        return
    ordered = [places[k] for k in sorted(places)]
    angles = {}         # value -> first target with it, in source order
    for t in ordered:
        angles.setdefault(t.position.value, t)
    first = ordered[0].position

    def exact(p) -> str:
        return f"N {p.n} = {fmt_deg(p.n * DAV_DEG)}"

    if len(angles) == 1:
        more = len(ordered) - 1
        message = f"{num(first.value)}deg is not exactly reachable: {exact(first)}" + (
            f" (here and at {more} more position{'s' if more > 1 else ''})" if more else "")
        help_ = (f"positions move in steps of 0.74°; write `{first.n}` (the raw N) or "
                 f"`{num(first.n * DAV_DEG)}deg` to silence this")
    else:
        named = [f"{num(t.position.value)}deg ({exact(t.position)})" for t in list(angles.values())[:SHOWN]]
        rest = len(angles) - len(named)
        message = (f"{len(angles)} angles, at {len(ordered)} positions, are not exactly reachable: "
                   + ", ".join(named) + (f" and {rest} more" if rest else ""))
        help_ = (f"positions move in steps of 0.74°; write the raw N or the exact angle (here `{first.n}` "
                 f"or `{num(first.n * DAV_DEG)}deg`) to silence this")
    report(message, ordered[0].span, label=f"N {first.n}", help=help_)
