"""Pass 6, calls: sequences that play themselves, and plays nested deeper than the later passes walk."""

from __future__ import annotations

from .. import nodes, walk
from ..lint.rules.too_deep import report_too_deep
from .context import Context, names
from .graph import cycles

# Deeper nesting of repeats and plays (sequences playing sequences) is reported as `too-deep` by the
# checker already, so that the later passes, which walk plays recursively, never see it.
MAX_LEVELS = 100


def calls(tree: nodes.Program, ctx: Context) -> None:
    if not recursion(ctx):
        body_of = {q.name: q.body for q in ctx.sequences}.__getitem__
        depth = walk.nesting(ctx.main, body_of)
        if depth > MAX_LEVELS:
            report_too_deep(ctx.r, depth, ctx.main, body_of, ctx.main_span)


def recursion(ctx: Context) -> bool:
    """Report each cycle of `play` between sequences once; True when there is one."""
    graph = {name: [c for c, _ in calls] for name, calls in ctx.plays.items()}
    found = cycles(graph)
    for path in found:
        start = path[0]
        first_span = next(span for c, span in ctx.plays[start] if c == (path[1] if len(path) > 1 else start))
        others = path[1:]
        msg = f"sequence `{start}` plays itself" + (f" through {names(others)}" if others else "")
        chain = " -> ".join([*path, start])
        ctx.r.error("recursion", msg, first_span,
                    help=f"{chain}; sequences may play other sequences, but never in a cycle")
    return bool(found)
