"""Walking statement trees: one set of traversals for the syntax tree, the model and the plan.

The three trees have the same shape: a `repeat` and a `loop` hold a `body` (a tuple
of statements), a `select` holds `branches` each with a `body` (its `on`s and its
`after`, in the order written), a `play` names a sequence, and the other statements
(move, hold, send, and `wait` in the syntax tree) are leaves. The functions here see
a statement only through `kind`, `blocks`, `children` and `callee`, so a new
statement needs teaching here once, not in every pass.

Nothing here uses Python recursion: chains of sequences playing sequences can be
far longer than the interpreter's recursion limit. Sequences are found through
`body_of(name) -> body`; the fold memoizes them by name, so a sequence played many
times is walked once. Plays must not form a cycle (the checker reports those first).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Iterable, Iterator

BodyOf = Callable[[str], tuple]

# The statement classes of the three trees, by name: nodes.*Stmt, model.*, plan.*Step.
_KINDS = {f"{word}{suffix}": word.lower()
          for word in ("Move", "Hold", "Repeat", "Loop", "Play", "Select", "Send", "Wait", "Until", "Host")
          for suffix in ("Stmt", "", "Step")}


def kind(st: Any) -> str:
    """'move', 'hold', 'repeat', 'loop', 'play', 'select', 'send', 'host', or 'wait' and 'until'
    (syntax tree only)."""
    try:
        return _KINDS[type(st).__name__]
    except KeyError:
        raise TypeError(f"not a statement: {st!r}") from None


def blocks(st: Any) -> tuple[tuple, ...]:
    """The bodies directly inside `st`: a repeat's or a loop's one body, a select's branch bodies in
    the order written and then its meanwhile body (if it has one); an `until`'s statement as a
    body of one; () for the others."""
    k = kind(st)
    if k == "select":
        extra = getattr(st, "meanwhile", None)
        return tuple(b.body for b in st.branches) + (() if extra is None else (extra,))
    if k == "until":
        return ((st.stmt,),)
    if k == "host":             # the plan's: a play of each sequence the host can start
        plays = getattr(st, "plays", ())
        return (plays,) if plays else ()
    return (st.body,) if k in ("repeat", "loop") else ()


def children(st: Any) -> tuple:
    """The statements directly inside `st`: its blocks one after another; () for a leaf."""
    return tuple(x for body in blocks(st) for x in body)


def callee(st: Any) -> str | None:
    """The name of the sequence a `play` plays (None for the other statements)."""
    if kind(st) != "play":
        return None
    name = getattr(st, "sequence", None)
    return name if name is not None else st.name.text


def bodies(roots: Iterable[tuple]) -> Iterator[tuple]:
    """Every statement list under the given bodies: each root, then its nested bodies, depth first."""
    for root in roots:
        work = [root]
        while work:
            body = work.pop()
            yield body
            work.extend(reversed([b for st in body for b in blocks(st)]))


def statements(roots: Iterable[tuple]) -> Iterator[Any]:
    """Every statement under the given bodies, body by body (as `bodies` lists them)."""
    for body in bodies(roots):
        yield from body


def reachable(root: tuple, body_of: BodyOf) -> set[str]:
    """The names of every sequence `root` can play, directly or through other sequences."""
    named: set[str] = set()
    work = [root]
    while work:
        for st in work.pop():
            name = callee(st)
            if name is not None and name not in named:
                named.add(name)
                work.append(body_of(name))
            elif name is None:
                work.extend(blocks(st))
    return named


def fold(body: tuple, body_of: BodyOf, start: Any, step: Callable[[Any, Any, Any], Any],
         memo: dict | None = None) -> Any:
    """Reduce `body` to one value, inside out: `step(acc, st, inner)` for each statement in
    order, from `start`, where `inner` is the folded value of the statement's own body (a
    repeat or a loop), the tuple of the folded values of its branches (a select, in the order
    written), the value of the sequence it plays, or None for a leaf. `memo` holds the
    values of sequences by name, and of the blocks folded (by id, beside the block itself, so
    that the id stays its own): pass the same dict to calls with the same `step` on the same
    tree to share them, so that folding each statement of a nested tree in turn stays linear."""
    memo = {} if memo is None else memo
    # Each frame: [statements, index of the next one, accumulator, the sequence they are the body
    # of, the values of the blocks of the statement at the index folded so far, whether it is a
    # block (its value kept in `memo`)].
    stack: list[list] = [[body, 0, start, None, [], False]]
    done = False                      # a frame just finished: its value is `value`
    value: Any = None
    while True:
        frame = stack[-1]
        sts, i, acc, _, got, _ = frame
        if not done and i < len(sts) and callee(sts[i]) is None:
            bl = blocks(sts[i])         # the blocks already folded, from `memo`
            while len(got) < len(bl):
                hit = memo.get(id(bl[len(got)]))
                if hit is None or hit[0] is not bl[len(got)]:
                    break
                got.append(hit[1])
            if bl and len(got) == len(bl):
                done, value = True, got.pop()
        if done:
            done = False
            st = sts[i]
            if callee(st) is None:
                got.append(value)
                bl = blocks(st)
                if len(got) < len(bl):
                    stack.append([bl[len(got)], 0, start, None, [], True])
                    continue
                value = tuple(got) if kind(st) == "select" else got[0]
                frame[4] = []
            frame[2] = step(acc, st, value)
            frame[1] = i + 1
        elif i < len(sts):
            st = sts[i]
            name = callee(st)
            if name is not None and name not in memo:
                if any(f[3] == name for f in stack):
                    raise ValueError(f"sequence `{name}` plays itself")
                stack.append([body_of(name), 0, start, name, [], False])
                continue
            bl = blocks(st) if name is None else ()
            if bl:
                stack.append([bl[len(got)], 0, start, None, [], True])
                continue
            inner = None if name is None else memo[name]
            frame[2] = step(acc, st, () if kind(st) == "select" else inner)
            frame[1] = i + 1
        else:
            stack.pop()
            if frame[3] is not None:
                memo[frame[3]] = acc
            elif frame[5]:
                memo[id(sts)] = (sts, acc)
            if not stack:
                return acc
            done, value = True, acc


def select_frame(st: Any) -> int:
    """Bytes a select keeps on the stack from where it is reached until a branch starts (while it
    waits and while its meanwhile body runs): its `after` count (2) and, for each input an edge
    event of it watches, the sample before (1)."""
    edges = {b.event.input for b in st.branches
             if getattr(b, "event", None) is not None and getattr(b.event, "edge", None) is not None}
    return (2 if getattr(st, "after", None) is not None else 0) + len(edges)


def _deepest(acc: int, st: Any, inner: Any) -> int:
    if inner is None:
        return acc
    if kind(st) == "select":    # its frame (2 bytes a level) under its meanwhile body, gone in its branches
        frame = (select_frame(st) + 1) // 2
        watched = inner[-1] if getattr(st, "meanwhile", None) is not None else 0
        return max(acc, max(inner, default=0), frame + watched)
    return max(acc, inner + (kind(st) not in ("loop", "host")))


def nesting(body: tuple, body_of: BodyOf, memo: dict | None = None) -> int:
    """The deepest stack, in levels of 2 bytes, of `repeat`s and `play`s around any statement (a
    `loop` costs nothing; a `select`'s frame, `select_frame` rounded up to levels, counts while it
    waits and under its meanwhile body)."""
    return fold(body, body_of, 0, _deepest, memo)


def first_too_deep(body: tuple, body_of: BodyOf, limit: int, trail: list | None = None) -> Any:
    """The first `repeat` or `play`, in program order, at level limit + 1, or the `select` whose
    frame, kept while it waits and while its meanwhile body runs, reaches it (a `host` statement's
    blocks are the plays of the sequences it can start); None if there is none. `trail`, if given,
    gets the statements the search went into on the way, outermost first."""
    memo: dict = {}
    used = 0
    trail = [] if trail is None else trail
    while True:
        for st in body:
            k = kind(st)
            if k in ("repeat", "play"):
                if used + 1 > limit:
                    return st
                inner = children(st) if k == "repeat" else body_of(callee(st))
                if used + 1 + nesting(inner, body_of, memo) > limit:
                    body, used = inner, used + 1
                    trail.append(st)
                    break
            elif k in ("loop", "select", "host"):
                under = [(b, used) for b in blocks(st)]
                if k == "select" and used + (select_frame(st) + 1) // 2 > limit:
                    return st           # its counters, kept while it waits (and its meanwhile body runs)
                if k == "select" and getattr(st, "meanwhile", None) is not None:
                    under[-1] = (under[-1][0], used + (select_frame(st) + 1) // 2)
                deep = next(((b, u) for b, u in under if u + nesting(b, body_of, memo) > limit), None)
                if deep is not None:
                    body, used = deep
                    trail.append(st)
                    break
        else:
            return None


def too_deep_text(depth: int, stack: int, limit: int, st: Any, trail: list = ()) -> tuple[str, str]:
    """`too-deep`'s message and label: the program nests `depth` levels, a `stack` of that many bytes
    has room for `limit`, and `st` (first_too_deep's statement, or None) is the one past it, the
    search having gone into `trail` (first_too_deep's): when that passed a `host` statement, the
    message says which sequence its `PL` plays on the way there."""
    word = kind(st) if st is not None else "repeat"
    subject = (("this `select`'s counters, kept while its meanwhile body runs, reach"
                if getattr(st, "meanwhile", None) is not None else "this `select`'s counters, kept while it waits, reach")
               if word == "select" else f"this `{word}` is")
    hosts = [i for i, t in enumerate(trail) if kind(t) == "host"]
    played = next((callee(t) for t in trail[hosts[-1] + 1:] if kind(t) == "play"), None) if hosts else None
    via = f" (`host`'s `PL` plays `{played}` on the way)" if played is not None else ""
    return (f"repeats, plays and waiting selects nest {depth} level{'s' if depth != 1 else ''} deep, but the "
            f"firmware's {stack}-byte stack has room for "
            f"{'no level' if limit <= 0 else f'{limit} level' + ('s' if limit != 1 else '')} (2 bytes each); "
            f"{subject} level {limit + 1}{via}", f"level {limit + 1}")


def rebuild(body: tuple, change: Callable[[Any], Any]) -> tuple:
    """A copy of `body` with `change(st)` in place of each statement, applied inside out
    (a repeat, loop or select is given to `change` with its bodies already rebuilt)."""
    # Each frame: (old statements, rebuilt so far, rebuilt blocks of the next old statement).
    stack: list[tuple[tuple, list, list]] = [(body, [], [])]
    done: tuple | None = None         # the body just rebuilt, for the block in its parent
    while True:
        old, out, got = stack[-1]
        i = len(out)
        if done is not None:
            got.append(done)
            done = None
            bl = blocks(old[i])
            if len(got) < len(bl):
                stack.append((bl[len(got)], [], []))
                continue
            out.append(change(_with_blocks(old[i], tuple(got))))
            got.clear()
        elif i < len(old):
            bl = blocks(old[i])
            if bl:
                stack.append((bl[0], [], []))
            else:
                out.append(change(old[i]))
        else:
            stack.pop()
            if not stack:
                return tuple(out)
            done = tuple(out)


def _with_blocks(st: Any, new: tuple[tuple, ...]) -> Any:
    """`st` with its blocks replaced by `new` (as `blocks` lists them)."""
    if kind(st) == "select":
        changed = dataclasses.replace(st, branches=tuple(dataclasses.replace(b, body=nb)
                                                         for b, nb in zip(st.branches, new)))
        if getattr(st, "meanwhile", None) is not None:
            changed = dataclasses.replace(changed, meanwhile=new[-1])
        return changed
    if kind(st) == "until":
        return dataclasses.replace(st, stmt=new[0][0])
    if kind(st) == "host":
        return dataclasses.replace(st, plays=new[0])
    return dataclasses.replace(st, body=new[0])
