"""servoc.walk: one set of traversals for the syntax tree, the model and the plan."""

from __future__ import annotations

import sys
from fractions import Fraction

import pytest

from servoc import model, nodes, walk
from servoc.steps import HoldStep, LoopStep, PlayStep, RepeatStep
from servoc.source import Span

H = model.Hold(1000)


def rep(*body, count=2):
    return model.Repeat(count, tuple(body))


def test_kind_children_and_callee_on_all_three_trees():
    name = nodes.Name("s", Span(0, 1))
    sp = Span(0, 0)
    for st, k, kids, called in [
        (nodes.PlayStmt(name, sp), "play", (), "s"),
        (nodes.LoopStmt((), sp), "loop", (), None),
        (model.Play("s"), "play", (), "s"),
        (model.Repeat(2, (H,)), "repeat", (H,), None),
        (PlayStep("s"), "play", (), "s"),
        (LoopStep((HoldStep(1, 1000),)), "loop", (HoldStep(1, 1000),), None),
        (RepeatStep(3, ()), "repeat", (), None),
        (H, "hold", (), None),
    ]:
        assert (walk.kind(st), walk.children(st), walk.callee(st)) == (k, kids, called)
    with pytest.raises(TypeError):
        walk.kind(object())


def test_nesting_counts_repeats_and_plays_not_loops():
    seqs = {"a": (rep(H),), "b": (model.Play("a"), model.Loop((model.Play("a"),)))}
    assert walk.nesting((H,), seqs.__getitem__) == 0
    assert walk.nesting((model.Loop((H,)),), seqs.__getitem__) == 0
    assert walk.nesting((rep(rep(H)), H), seqs.__getitem__) == 2
    assert walk.nesting((model.Play("b"),), seqs.__getitem__) == 3


def test_first_too_deep_in_program_order():
    inner = rep(H)
    late = rep(rep(H))
    main = (inner, model.Loop((late,)))
    assert walk.first_too_deep(main, {}.__getitem__, 1) is late.body[0]
    assert walk.first_too_deep(main, {}.__getitem__, 2) is None


def test_chains_longer_than_the_recursion_limit():
    n = sys.getrecursionlimit() * 3
    seqs = {f"s{i}": (model.Play(f"s{i + 1}"),) for i in range(n)}
    seqs[f"s{n}"] = (H,)
    body_of = seqs.__getitem__
    assert walk.nesting((model.Play("s0"),), body_of) == n + 1
    at = walk.first_too_deep((model.Play("s0"),), body_of, 12)
    assert at is seqs["s11"][0]
    assert walk.reachable((model.Play("s0"),), body_of) == set(seqs)


def test_fold_memoizes_sequences_and_refuses_cycles():
    calls = []
    seqs = {"a": (H, H), "b": (model.Play("a"),) * 3}

    def count(acc, st, inner):
        calls.append(st)
        return acc + (inner if inner is not None else 1)
    assert walk.fold((model.Play("b"), model.Play("a")), seqs.__getitem__, 0, count) == 8
    assert len(calls) == 2 + 3 + 2       # a's body once, b's body once, main
    with pytest.raises(ValueError):
        walk.nesting((model.Play("x"),), {"x": (model.Play("x"),)}.__getitem__)


def _shape(acc, st, inner):
    """A fold step that keeps the whole shape it folds (so two folds agree only if they saw the
    same tree the same way)."""
    return acc + ((walk.kind(st), inner),)


def _tree(depth: int, seed: int) -> tuple:
    """A statement list of repeats, loops, selects (branches and a meanwhile body), holds and plays."""
    if depth == 0:
        return (H, model.Play("a")) if seed % 3 == 0 else (H,)
    inner = _tree(depth - 1, seed * 7 + 3)
    ev = model.Event(None, 120, '"x"')
    kinds = [rep(*inner), model.Loop(inner),
             model.Select((model.On(ev, inner), model.After(Fraction(1), (H,) + inner)), meanwhile=inner)]
    return (kinds[seed % 3], H) + ((kinds[(seed + 1) % 3],) if seed % 2 else ())


def test_folding_each_statement_of_a_nested_tree_in_turn_stays_linear_and_agrees():
    """With one memo, folding every statement of a tree in turn (as code generation does) folds
    each block once; every value is the one a fold without a memo gives."""
    seqs = {"a": (H, rep(H))}
    for seed in range(6):
        tree = _tree(5, seed)
        memo: dict = {}
        for st in walk.statements((tree,)):
            assert walk.fold((st,), seqs.__getitem__, (), _shape, memo) == walk.fold((st,), seqs.__getitem__, (), _shape)
    calls = []

    def count(acc, st, inner):
        calls.append(st)
        return acc + 1 + (inner or 0)
    deep = (H,)
    for _ in range(300):
        deep = (rep(*deep),)
    memo = {}
    sts = list(walk.statements((deep,)))
    values = [walk.fold((st,), seqs.__getitem__, 0, count, memo) for st in sts]
    assert values[0] == 301 and values[-1] == 1
    assert len(calls) == 2 * 301 - 1      # each statement's step once, and once more as the root of its own fold


def test_bodies_and_statements_in_order():
    a, b = model.Hold(1), model.Hold(2)
    r = rep(a, model.Loop((b,)))
    main = (r, H)
    assert list(walk.bodies([main])) == [main, r.body, r.body[1].body]
    assert list(walk.statements([main, (a,)])) == [r, H, a, r.body[1], b, a]


def test_rebuild_changes_leaves_inside_out():
    main = (rep(model.Hold(1), model.Loop((model.Hold(2),))), model.Hold(3))
    out = walk.rebuild(main, lambda st: model.Hold(st.duration_us * 10) if isinstance(st, model.Hold) else st)
    assert out == (rep(model.Hold(10), model.Loop((model.Hold(20),))), model.Hold(30))
    assert walk.rebuild((), lambda st: st) == ()


def test_first_too_deep_names_a_waiting_select_whose_counters_go_past_the_limit():
    """A select with `after` keeps its counter (2 bytes, a level) while it waits, meanwhile body or
    not: inside a repeat at limit 1 it is the statement past the limit, and the message says so."""
    from fractions import Fraction
    sel = model.Select((model.On(model.Event("b", None, "b"), (H,)), model.After(Fraction(100_000), ())))
    main = (rep(sel),)
    assert walk.nesting(main, {}.__getitem__) == 2
    assert walk.first_too_deep(main, {}.__getitem__, 1) is sel
    assert walk.first_too_deep(main, {}.__getitem__, 2) is None
    assert "kept while it waits, reach level 2" in walk.too_deep_text(2, 30, 1, sel)[0]
