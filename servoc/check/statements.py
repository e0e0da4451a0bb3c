"""Pass 5, statements: the bodies of the sequences and of `main`, and what each sequence plays."""

from __future__ import annotations

from .. import model, nodes
from ..printer import format_quantity
from ..source import Span
from . import quantities
from .context import PORTS, Context
from .resolve import Resolve

Calls = list[tuple[str, Span]]


def statements(tree: nodes.Program, ctx: Context, res: Resolve) -> None:
    conv = _Statements(ctx, res)
    for name in ctx.declared("sequence"):
        decl: nodes.SequenceDecl = ctx.decls[name].node
        calls: Calls = []
        ctx.sequences.append(model.Sequence(name, conv.body(decl.body, calls), decl.span))
        ctx.plays[name] = calls
    if ctx.mains:
        ctx.main = conv.body(ctx.mains[0].body, [])
        ctx.main_span = ctx.mains[0].span
    for extra in ctx.mains[1:]:
        conv.body(extra.body, [])


class _Statements:
    def __init__(self, ctx: Context, res: Resolve) -> None:
        self.ctx = ctx
        self.res = res

    def body(self, body: tuple[nodes.Stmt, ...], calls: Calls) -> tuple[model.Stmt, ...]:
        """Block bodies nest only as deep as the parser allows, so this recursion stays shallow."""
        return tuple(st for st in (self.stmt(s, calls) for s in body) if st is not None)

    def stmt(self, stmt: nodes.Stmt, calls: Calls) -> model.Stmt | None:
        ctx = self.ctx
        if isinstance(stmt, nodes.MoveStmt):
            duration = None
            if stmt.duration is not None:
                duration = ctx.take(quantities.duration_us(stmt.duration, "`move ... in`"), stmt.duration.span)
            pose = self.pose_ref(stmt.pose)
            if pose is None or (stmt.duration is not None and duration is None):
                return None
            return model.Move(pose.name, pose.targets, duration, stmt.ease or "linear", stmt.span)
        if isinstance(stmt, nodes.HoldStmt):
            duration = ctx.take(quantities.duration_us(stmt.duration, "`hold`"), stmt.duration.span)
            return None if duration is None else model.Hold(duration, stmt.span)
        if isinstance(stmt, nodes.RepeatStmt):
            count = self.count(stmt.count)
            body = self.body(stmt.body, calls)
            return None if count is None else model.Repeat(count, body, stmt.span)
        if isinstance(stmt, nodes.LoopStmt):
            return model.Loop(self.body(stmt.body, calls), stmt.span)
        if isinstance(stmt, nodes.PlayStmt):
            name = stmt.name
            if ctx.lookup(name, "sequence", "a sequence",
                          {"pose": f"to go to a pose, write `move {name.text}`"}) is None:
                return None
            calls.append((name.text, stmt.span))
            return model.Play(name.text, stmt.span)
        raise TypeError(f"not a statement: {stmt!r}")

    def pose_ref(self, name: nodes.Name) -> model.Pose | None:
        ctx = self.ctx
        if name.text in PORTS and name.text not in ctx.decls:
            ctx.r.error("wrong-kind", f"`{name.text}` is a port, but a pose is needed here", name.span,
                        help=f"declare a pose such as `pose p {{ {name.text}: 90deg }}` and move to it")
            return None
        if ctx.lookup(name, "pose", "a pose", {"sequence": f"to run a sequence, write `play {name.text}`"}) is None:
            return None
        return self.res.poses.get(name.text, name)

    def count(self, q: nodes.Quantity) -> int | None:
        value = self.ctx.take(quantities.count(q), q.span)
        if value is None:
            return None
        if value.denominator != 1 or value < 1:
            self.ctx.r.error("bad-count", f"a repeat count must be a whole number of at least 1, not "
                             f"`{format_quantity(q)}`", q.span, help="to repeat forever, use `loop { ... }`")
            return None
        return int(value)
