"""Pass 1, declarations: every name once, one `main`."""

from __future__ import annotations

from .. import nodes
from ..diagnostics import Label
from ..source import Span
from .context import KIND_WORD, PORTS, Context, Decl

_KIND = {nodes.ServoDecl: "servo", nodes.GroupDecl: "group", nodes.PoseDecl: "pose", nodes.SequenceDecl: "sequence",
         nodes.InputDecl: "input"}


def declarations(tree: nodes.Program, ctx: Context) -> None:
    r = ctx.r
    for item in tree.items:
        if isinstance(item, nodes.MainDecl):
            if ctx.mains:
                first = ctx.mains[0].keyword
                r.error("duplicate-main", "`main` is declared more than once", item.keyword,
                        help=f"the first `main` is at line {ctx.line(first)}; a program has exactly one",
                        secondary=[Label(first, "first declared here")])
            ctx.mains.append(item)
            continue
        if type(item) not in _KIND:
            continue            # settings: the next pass
        name, kind = item.name, _KIND[type(item)]
        if name.text in PORTS:
            r.error("duplicate-name", f"`{name.text}` is the name of a port and cannot name {KIND_WORD[kind]}",
                    name.span, help=f"in a pose, `{name.text}` means every servo on port {name.text}; "
                                    "choose another name")
            continue
        if name.text in ctx.decls:
            first = ctx.decls[name.text]
            r.error("duplicate-name", f"`{name.text}` is already declared", name.span,
                    help=f"{KIND_WORD[first.kind]} `{name.text}` is declared at line {ctx.line(first.name.span)}; "
                         "names must be unique", secondary=[Label(first.name.span, "first declared here")])
            continue
        ctx.decls[name.text] = Decl(kind, item, name)
    if not ctx.mains:
        r.error("missing-main", "the program has no `main`", Span(0, 0),
                help="add `main { ... }` with the statements to run")
