"""Random programs with selects under random input changes: what `compile` accepts, `verify --events`
passes (the branch the firmware takes at each select, every pulse of that run, the 2 P rule)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, Phase, given, settings, strategies as st

from conftest import front_end_text
from test_select import run

pytestmark = pytest.mark.toolchain

POSES = ("p0", "p1", "p2")


@st.composite
def select_programs(draw):
    """A loop of a select with 1-2 `on`s (0-2 moves each) and maybe an `after`, then a move."""
    def moves(lo: int, hi: int) -> str:
        return "; ".join(f"move {draw(st.sampled_from(POSES))} in {draw(st.sampled_from([30, 120, 400]))}ms"
                         for _ in range(draw(st.integers(lo, hi))))
    ons = [f"on {name} {{ {moves(0, 2)} }}" for name in draw(st.sampled_from([["a"], ["b"], ["a", "b"], ["b", "a"]]))]
    after = [f"after {draw(st.sampled_from([0, 20, 90]))}ms {{ {moves(1, 2)} }}"] if draw(st.booleans()) else []
    return ("input a = P3.2\ninput b = P3.5 high\n"
            "servo x = P1.1 speed 0.0001s/60deg\nservo y = P1.6 speed 0.0001s/60deg\n"
            "pose p0 { x: 0, y: 250 }\npose p1 { x: 125, y: 3 }\npose p2 { x: 250, y: 120 }\n"
            f"main {{ move p0; loop {{ select {{ {'; '.join(ons + after)} }}; {moves(1, 1)} }} }}\n")


@settings(max_examples=10, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck),
          phases=[Phase.explicit, Phase.generate])
@given(select_programs(), st.lists(st.tuples(st.integers(5, 1500), st.integers(1, 300), st.sampled_from("ab")),
                                   max_size=5))
def test_random_select_programs_that_compile_verify(text, presses):
    fe, diags = front_end_text(text)
    if fe.plan is None or any(d.is_error for d in diags):
        return                                  # e.g. an empty loop: lint refuses it first
    lines = sorted((s, f"{s}ms {n} active") for s, _, n in presses) + \
        sorted((s + d, f"{s + d}ms {n} inactive") for s, d, n in presses)
    scenario = "\n".join(t for _, t in sorted(lines)) + "\n"
    plan, trace, evs, report = run(text, scenario, 300)
    assert report.ok, (text, scenario, report.summary(), [str(m) for m in report.mismatches[:4]])
