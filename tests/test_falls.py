"""The handler's load for a port's falls (costs.port_load over flow.port_motions) against every
frame the firmware can put out: per move at any F, and per program over the frames `plan.expand`
gives. The ucsim side (a step costs its gap, an entry of its own ENTRY + EXIT) is checked by the
adversarial programs of tests/test_costs.py, which run at the minimum this bound gives."""

import itertools

import pytest
from hypothesis import given, settings, strategies as st

from conftest import front_end_text
from servoc import costs, target as target_mod
from servoc.flow import move_starts, port_motions
from servoc.plan import ease_table, expand, firmware_value
from servoc.steps import MoveStep, Reach, steps

T12 = target_mod.DEFAULT
SPLIT = costs.SPLIT


def widths(t):
    return [t.width_cycles(n) for n in range(256)]


def test_edges_load_counts_an_entry_per_cluster_and_the_steps_inside_it():
    w = widths(T12)                                 # 8 cycles per N at 12 MHz
    assert costs.edges_load(w, []) == 0
    assert costs.edges_load(w, [5, 5, 5]) == SPLIT - 1
    assert costs.edges_load(w, [0, 1, 3]) == SPLIT - 1 + 8 + 16
    near = (SPLIT - 1) // 8                         # the most N apart that is still a step
    assert costs.edges_load(w, [0, near]) == SPLIT - 1 + 8 * near             # a step: its gap
    assert costs.edges_load(w, [0, near + 1, 250]) == 3 * (SPLIT - 1)         # entries of their own
    assert costs.edges_load(w, list(range(0, 8 * (near + 1), near + 1))) == 8 * (SPLIT - 1)


def frames_of(lines, frames, ease):
    """Every frame's N of a move from lines' starts to their ends in `frames` frames."""
    table = ease_table(ease, frames)
    return [[firmware_value(a, b, k, frames, ease, table) for a, b in lines] for k in range(1, frames + 1)]


lines_st = st.lists(st.tuples(st.integers(0, 250), st.integers(0, 250)), min_size=1, max_size=8)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(lines_st, st.integers(1, 300), st.sampled_from(["linear", "in", "out", "in-out"]),
       st.sampled_from(["12", "11.0592 6T", "22.1184"]))
def test_the_bound_holds_for_every_frame_of_a_move_at_any_f(lines, frames, ease, clock):
    t = {"12": T12, "11.0592 6T": _target("target stc89c52rc clock 11.0592MHz mode 6T"),
         "22.1184": _target("target at89c52 clock 22.1184MHz")}[clock]
    bound = costs.port_load(t, frozenset({tuple(lines)})).falls
    w = widths(t)
    assert all(costs.edges_load(w, f) <= bound for f in frames_of(lines, frames, ease))
    assert bound <= SPLIT - 1 + min((SPLIT - 1) * (len(lines) - 1),
                                     max(w[v] for ab in lines for v in ab) - min(w[v] for ab in lines for v in ab))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 40)), min_size=1, max_size=8))
def test_the_bound_is_reached(lines):
    """Not a margin: some F has a frame at the bound (the sweep's worst u is some k / F)."""
    bound = costs.port_load(T12, frozenset({tuple(lines)})).falls
    w = widths(T12)
    assert max(costs.edges_load(w, f) for frames in range(1, 200) for f in frames_of(lines, frames, "linear")) == bound


def sort_values(lines, frame):
    """The N the sort sees: a line without a target (None) stays at 0."""
    it = iter(frame)
    return [0 if ab is None else next(it) for ab in lines]


lines_or_none_st = st.lists(st.one_of(st.none(), st.tuples(st.integers(0, 250), st.integers(0, 250))),
                            min_size=1, max_size=8).filter(any)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(lines_or_none_st, st.integers(1, 300), st.sampled_from(["linear", "in", "out", "in-out"]))
def test_the_swaps_bound_every_frame_of_a_move_at_any_f(lines, frames, ease):
    load = costs.port_load(T12, frozenset({tuple(lines)}))
    falling = [ab for ab in lines if ab is not None]
    assert all(costs.swaps(sort_values(lines, f)) <= load.swaps for f in frames_of(falling, frames, ease))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.one_of(st.none(), st.tuples(st.integers(0, 40), st.integers(0, 40))), min_size=1, max_size=8)
       .filter(any))
def test_the_swaps_bound_is_reached(lines):
    load = costs.port_load(T12, frozenset({tuple(lines)}))
    falling = [ab for ab in lines if ab is not None]
    assert max(costs.swaps(sort_values(lines, f)) for frames in range(1, 200)
               for f in frames_of(falling, frames, "linear")) == load.swaps


def test_swaps_count_the_comparators_that_exchange():
    assert costs.swaps([1, 2, 3, 4, 5, 6, 7, 8]) == 0
    assert max(costs.swaps(p) for p in itertools.permutations(range(8))) == len(costs.SORTING_NETWORKS[8])
    assert costs.swaps([8, 7, 6, 5, 4, 3, 2, 1]) < len(costs.SORTING_NETWORKS[8])   # reversed is not the worst
    assert costs.swaps([5, 5, 5]) == 0                                   # equal N stay
    assert costs.swaps([2, 1]) == 1


def test_a_move_after_an_interruption_gets_its_hull():
    """A servo that can be anywhere in lo..hi: the hull of every position, each gap at most SPLIT - 1."""
    w = widths(T12)
    near = ((Reach(10, 12), 20), (15, 15))
    assert costs.port_load(T12, frozenset({near})).falls == SPLIT - 1 + w[20] - w[10]
    wide = ((Reach(0, 250), 20), (15, 15), (100, 100))
    assert costs.port_load(T12, frozenset({wide})).falls == 3 * (SPLIT - 1)
    assert costs.port_load(T12, frozenset({wide})).swaps == len(costs.SORTING_NETWORKS[3])   # any order


def test_clustered_lines_cost_less_than_an_entry_each():
    w = widths(T12)
    tight = tuple((100 + i, 120 + i) for i in range(8))
    assert costs.port_load(T12, frozenset({tight})).falls == SPLIT - 1 + w[107] - w[100]
    assert costs.port_load(T12, frozenset({tight})).falls < 8 * (SPLIT - 1)


def _target(line):
    fe, diags = front_end_text(line + "\nservo s = P1.0\npose a { s: 1 }\nmain { move a }\n")
    return fe.plan.program.target


PROGRAMS = {
    "three ports, a meanwhile cut": "input b = P3.2\n" + "".join(f"servo s{i} = P{i // 4}.{i % 4}\n" for i in range(12))
    + "pose a { " + ", ".join(f"s{i}: {9 * i}" for i in range(12)) + " }\n"
    + "pose z { " + ", ".join(f"s{i}: {250 - 13 * i}" for i in range(12)) + " }\n"
    + "pose m { s0: 120, s5: 40, s11: 200 }\n"
    + "main { move a in 200ms; loop { select { on press b { move m in 300ms ease in-out } meanwhile { loop { "
    + "move z in 400ms; move a in 300ms ease in } } } } }\n",
    "home, stagger, holds": "servo x = P1.0\nservo y = P1.1\nservo z = P1.5\npose rest { x: 10, y: 200, z: 100 }\n"
    + "home rest\nstagger 40ms\npose p { x: 100, z: 110 }\npose q { y: 30 }\n"
    + "main { repeat 3 { move p in 150ms; hold 40ms; move q in 90ms ease out; move p in 100ms } }\n",
}


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_every_frame_of_a_program_is_within_the_bound(name):
    fe, diags = front_end_text(PROGRAMS[name])
    plan = fe.plan
    assert plan is not None, diags
    t = plan.program.target
    w = widths(t)
    motions = port_motions(plan)
    bounds = {p: costs.port_load(t, motions[p]) for p in plan.ports}
    worst = dict.fromkeys(plan.ports, 0)
    swapped = dict.fromkeys(plan.ports, 0)
    distinct = dict.fromkeys(plan.ports, 0)
    for i, frame in zip(range(3000), expand(plan)):
        for p in plan.ports:
            vals = [n for c, n in zip(plan.channels, frame.n) if c.port == p]
            worst[p] = max(worst[p], costs.edges_load(w, [n for n in vals if n is not None]))
            swapped[p] = max(swapped[p], costs.swaps([n or 0 for n in vals]))
            distinct[p] = max(distinct[p], len({n for n in vals if n is not None}))
    assert all(worst[p] <= bounds[p].falls for p in plan.ports), (worst, bounds)
    assert all(swapped[p] <= bounds[p].swaps for p in plan.ports), (swapped, bounds)
    assert all(distinct[p] <= bounds[p].distinct for p in plan.ports), (distinct, bounds)
    assert any(worst[p] > SPLIT - 1 for p in plan.ports)        # the programs do put out clusters


def test_a_ports_most_distinct_n_in_one_frame():
    """frame_io's `distinct` pairs (the lines with a target, one pair per N): the most over the
    frames of a port's moves, every line with a target where a move can start anywhere."""
    assert costs.port_load(T12, frozenset({((10, 10), (10, 50), (50, 50))})).distinct == 3    # on the way
    assert costs.port_load(T12, frozenset({((10, 50), (10, 50), None)})).distinct == 1      # together
    assert costs.port_load(T12, frozenset({((10, 50), (10, 50), None), ((40, 40), (60, 60), (80, 90))})).distinct == 3
    assert costs.port_load(T12, frozenset({((Reach(0, 250), 20), (Reach(0, 250), 20), None)})).distinct == 2
    together = [((k % 40, 250 - k % 30),) * 8 for k in range(60)]     # eight lines as one, each move
    assert all(costs.port_load(T12, frozenset({p})).distinct == 1 for p in together)
    assert sum(8 * (b - a) for (a, b), *_ in together) > costs.SWEEP_BUDGET
    assert costs.port_load(T12, frozenset(together)).distinct == 8  # past the sweep budget: every line


def test_past_the_sweep_budget_the_rest_get_their_hull():
    """Programs with more motion than SWEEP_BUDGET breakpoints: the paths left get the hull bound,
    never less than their own worst frame."""
    paths = [tuple((i * 3 + k % 9, 250 - i * 5 - k % 11) for i in range(8)) for k in range(60)]
    assert sum(abs(b - a) for p in paths for a, b in p) > costs.SWEEP_BUDGET
    alone = max(costs.port_load(T12, frozenset({p})).falls for p in paths)
    together = costs.port_load(T12, frozenset(paths)).falls
    assert alone <= together <= 8 * (SPLIT - 1)


STARTS = {
    "run-time F, eased": "servo x = P1.0\nservo y = P1.1\nservo z = P1.5\npose a { x: 10, y: 200, z: 100 }\n"
    + "pose b { x: 100, z: 110 }\npose c { y: 30, x: 40 }\nsequence go { move b }\n"
    + "main { move a in 100ms; repeat 2 { play go; hold 40ms; move c in 90ms ease out; play go; move a in 300ms } }\n",
    "home, stagger": "servo x = P1.0\nservo y = P1.1\nservo z = P1.5\npose rest { x: 10, y: 200, z: 100 }\n"
    + "home rest\nstagger 40ms\npose p { x: 100, z: 110 }\npose q { y: 30 }\n"
    + "main { repeat 2 { move p in 150ms; move q in 90ms ease in } }\n",
}


@pytest.mark.parametrize("name", sorted(STARTS))
def test_every_move_start_is_among_the_pairs(name):
    """Each frame a move statement makes after a frame of another statement is that move's first
    frame: the pair (the frame before, it) is one move_starts gives, with the move's kind."""
    fe, diags = front_end_text(STARTS[name])
    plan = fe.plan
    assert plan is not None, diags
    starts = move_starts(plan)
    port = plan.ports[0]
    pairs = {(b, f) for b, f, *_ in starts[port]}
    moves = {st.span for st in steps(plan) if isinstance(st, MoveStep)}
    frames = [f for _, f in zip(range(2000), expand(plan))]
    seen = 0
    for a, b in zip([None] + frames, frames):
        if b.span in moves and (a is None or a.span != b.span):
            before = a.n if a is not None else (None,) * len(plan.channels)
            assert (before, b.n) in pairs, (before, b.n)
            seen += 1
    assert seen >= 5
    if "eased" in name:     # the kinds: `move b` with its F found at run time, `move c` eased
        assert {(e, r) for _, _, e, r, _ in starts[port]} >= {(False, True), (True, False)}
    else:                   # the power-up switches the servos on one at a time, each a frame of its own
        partial = [b for b, _ in pairs if None in b and any(v is not None for v in b)]
        assert len(partial) == 2, pairs


def test_a_move_that_can_start_after_an_interruption_has_no_pairs():
    fe, diags = front_end_text(PROGRAMS["three ports, a meanwhile cut"])
    assert None in move_starts(fe.plan).values()
