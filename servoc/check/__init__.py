"""Checking: `nodes.Program` -> `model.Program`.

Input: the syntax tree from `servoc.syntax.parse`. Output: a `model.Program`
whose names are all resolved and whose units are gone (every position an
output N in 0..250, every time an exact Fraction of microseconds), or None
when any error was reported. The checker goes on after an error so that one
run reports as many mistakes as it can find.

Names may be used before their declaration (sequences can play sequences
declared later); the settings `frame` and `target` must come before the
sequences and `main`. A pose target is a servo, a group (all its servos,
flattened) or a port `P0`/`P1`/`P2` (every servo declared on it). A
position's output N is: the position's N, checked against the servo's
`limit`; then `reverse` (250 - N); then `trim` (+INT); it must end in 0..250.

The checker is a few passes over one `Context`, run in order: declarations
(the symbol table), settings (`frame`, `target`, `home`, `stagger`, `host`),
servos (pins, options), inputs (`input` pins, `serial` and its rate), host
(`host ssc32` needs `serial`; host channels), resolve (groups and poses),
statements (sequences and `main`, selects and their events) and calls
(recursion, nesting). Unit conversions are pure functions in `quantities`.
"""

from __future__ import annotations

from .. import model, nodes
from ..diagnostics import Reporter
from .calls import calls
from .context import Context
from .declarations import declarations
from .host import host
from .inputs import inputs
from .resolve import resolve
from .servos import servos
from .settings import settings
from .statements import statements


def check(tree: nodes.Program, reporter: Reporter, path: str) -> model.Program | None:
    """Resolve and check a parsed program; None when an error was reported."""
    before = sum(1 for d in reporter.diagnostics if d.is_error)
    ctx = Context(reporter, path)
    declarations(tree, ctx)
    settings(tree, ctx)
    servos(tree, ctx)
    inputs(tree, ctx)
    host(tree, ctx)
    res = resolve(tree, ctx)
    home = statements(tree, ctx, res)
    calls(tree, ctx)
    after = sum(1 for d in reporter.diagnostics if d.is_error)
    if after != before:
        return None
    return model.Program(
        path=path, servos=tuple(ctx.servos.values()),
        groups=tuple(g for n in ctx.declared("group") if (g := ctx.groups.get(n)) is not None),
        poses=tuple(p for n in ctx.declared("pose") if (p := ctx.poses.get(n)) is not None),
        sequences=tuple(ctx.sequences), main=ctx.main, frame_us=ctx.frame_us, target=ctx.target,
        references=frozenset(ctx.references), main_span=ctx.main_span,
        frame_span=ctx.frame_span, inputs=tuple(ctx.inputs.values()), serial=ctx.serial,
        home=home, stagger_us=ctx.stagger_us, home_span=ctx.home.span if ctx.home is not None else ctx.main_span,
        host=ctx.host, host_span=ctx.host_decl.span if ctx.host_decl is not None else ctx.main_span)
