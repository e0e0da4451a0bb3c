"""Selects one after another, each setting other servos: the states a program can be in multiply
(3 branches x 6 selects: 3^6 combinations). The plan keeps at most `plan.MAX_STATES` apart at one
point of a body and their hull past that, so that linting stays linear in the program, with the
same speed verdicts as from every state apart, and firmware that verifies at the period it reports."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from conftest import front_end_text
from servoc import plan as plan_mod
from servoc.source import Span
from servoc.steps import Reach, join
from test_select import run


def _generator():
    spec = importlib.util.spec_from_file_location(
        "select_states", Path(__file__).resolve().parent.parent / "benchmarks" / "select_states.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


program = _generator().program      # the benchmark's programs: benchmarks/select_states.py


def errors(diags) -> list[tuple[str, int, str]]:
    return sorted((d.code, d.span.start, d.message.split(":")[0]) for d in diags if d.is_error)


def test_the_states_kept_apart_are_bounded_and_the_moves_instances_few():
    fe, diags = front_end_text(program(8))
    assert fe.plan is not None and not errors(diags), errors(diags)
    # each move is walked from at most MAX_STATES states (without the bound, from up to 3^5 = 243)
    per_move: dict[int, int] = {}
    for inst in fe.plan.moves:
        per_move[id(inst.step)] = per_move.get(id(inst.step), 0) + 1
    assert max(per_move.values()) <= 64, max(per_move.values())


@pytest.mark.parametrize("fast_last", [False, True])
def test_the_verdicts_are_those_of_every_state_apart(monkeypatch, fast_last):
    """`move all in 20ms` after the selects is too fast from some of the 3^4 combinations: the
    error, its servo and move, as with every combination kept apart."""
    text = program(4, fast_last=fast_last)
    monkeypatch.setattr(plan_mod, "MAX_STATES", 10 ** 6)
    _, apart = front_end_text(text)
    monkeypatch.setattr(plan_mod, "MAX_STATES", 8)
    fe, merged = front_end_text(text)
    assert [(c, s) for c, s, _ in errors(merged)] == [(c, s) for c, s, _ in errors(apart)]
    assert bool(errors(merged)) == fast_last
    if fast_last:
        msgs = [d.message for d in merged if d.code == "infeasible-speed"]
        assert any("any of the 9 states" in m and "`s0` can be at N 40 in them" in m for m in msgs), msgs


@pytest.mark.parametrize("clock", ["", "target stc89c52rc clock 11.0592MHz\n",
                                   "target stc89c52rc clock 11.0592MHz mode 6T\n"])
def test_past_the_bound_the_firmware_verifies_at_the_period_it_reports(clock):
    """At the shortest period reported past the bound, every pulse is exact while bytes pick the
    branches; 1 us less is refused."""
    text = clock + program(8)
    fe, _ = front_end_text(text)
    p = fe.plan.min_period_us
    _, short = front_end_text(f"frame {p - 1}us\n" + text)
    assert [d.code for d in short if d.is_error] == ["period-too-short"]
    scenario = "".join(f"{40 + 70 * k}ms \"{'abc'[k * 7 % 3]}\"\n" for k in range(40))
    plan, trace, evs, report = run(f"frame {p}us\n" + text, scenario, 700)
    assert report.ok and report.max_error_cycles == 0, (report.summary(), [str(m) for m in report.mismatches[:4]])


HOSTED_HOST = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
input go = P3.3
input stop = P3.2
servo s0 = P1.0
servo s1 = P1.1
pose mid { s0: 90deg, s1: 90deg }
pose high { s0: 120deg, s1: 120deg }
home mid
sequence q0 {
  select {
    on "x" { move high in 300ms }
    on press stop { hold 200ms; host until release go }
    after 500ms { move mid }
  }
}
main {
  play q0
  host until press stop
}
"""


def test_a_sequence_with_host_that_the_host_plays_verifies(tmp_path):
    """`PL 0 SQ 0` plays q0, which has a `host` of its own: the walk of the host's plays does not
    walk q0 again from inside itself (it recursed without end: an internal error in `verify`)."""
    from servoc import cli
    src = tmp_path / "p.servo"
    src.write_text(HOSTED_HOST, encoding="utf-8")
    events = tmp_path / "e.events"
    events.write_text('0.1s "#0P1000S800#1P2000T300\\r"\n0.4s "PL 0 SQ 0\\r"\n0.7s "x"\n1.1s "PL 0 SQ 0\\r"\n'
                      '1.3s "QP 0\\r"\n1.6s stop active\n1.9s stop inactive\n', encoding="utf-8")
    fe, diags = front_end_text(HOSTED_HOST)
    assert fe.plan is not None and not errors(diags)
    assert plan_mod.verify_frames(fe.plan) >= 400
    assert cli.main(["verify", str(src), "--events", str(events)]) == 0


def _position(draw, st):
    kind = draw(st.integers(0, 2))
    if kind == 0:
        return None
    if kind == 1:
        return draw(st.integers(0, 6))
    lo = draw(st.integers(0, 6))
    return Reach(lo, draw(st.integers(lo, 6)), draw(st.booleans()), Span(draw(st.integers(0, 2)), 9),
                 Span(draw(st.integers(0, 2)), 9), draw(st.booleans()))


@settings(max_examples=3000, deadline=None, derandomize=True)
@given(st.data())
def test_join_is_the_hull_of_both_positions(data):
    """`steps.join`, with its shortcuts for a hull that already holds the other position: the
    least range holding both (unset if either may be), its ends credited as the side it comes from
    (the first on a tie), merged if either is, and a single N where that is all it can be."""
    a, b = _position(data.draw, st), _position(data.draw, st)
    got = join(a, b)
    if a == b and not isinstance(a, Reach):
        assert got == a
        return
    ra = None if a is None else a if isinstance(a, Reach) else Reach(a, a)
    rb = None if b is None else b if isinstance(b, Reach) else Reach(b, b)
    known = [r for r in (ra, rb) if r is not None]
    lo = min(known, key=lambda r: r.lo)         # min/max keep the first of equals: a
    hi = max(known, key=lambda r: r.hi)
    unset = a is None or b is None or any(r.unset for r in known)
    if lo.lo == hi.hi and not unset:
        assert got == lo.lo and type(got) is int
        return
    assert isinstance(got, Reach) and (got.lo, got.hi, got.unset) == (lo.lo, hi.hi, unset)
    assert (got.lo_at, got.hi_at) == (lo.lo_at, hi.hi_at)
    assert got.merged == any(r.merged for r in known)
