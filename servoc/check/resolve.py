"""Pass 4, resolve: groups (flattened to servos) and poses (`with` applied, positions to output N).

Groups may contain groups and poses may start from poses, declared in any order:
one `Resolver` per kind resolves each name once, on demand, and reports a cycle
once. It runs on an explicit stack, not Python's, so a chain of declarations
longer than the interpreter's recursion limit is fine.
"""

from __future__ import annotations

from typing import Any, Callable, Generator

from .. import model, nodes, units
from ..diagnostics import Label
from ..printer import format_quantity
from ..source import Span
from . import quantities
from .context import PORTS, Context, names

# A resolver's build step: a generator that yields the resolution of another name it needs
# (another build step) and is sent its value back; it returns the resolved object or None.
Build = Generator[Any, Any, Any]


def run(gen: Build) -> Any:
    """Run a build step and those it yields on an explicit stack; its return value."""
    stack, value = [gen], None
    while True:
        try:
            request = stack[-1].send(value)
        except StopIteration as done:
            stack.pop()
            if not stack:
                return done.value
            value = done.value
            continue
        stack.append(request)
        value = None


class Resolver:
    """Resolves the declarations of one kind by name, each once, cycles reported once.

    `build` is a function of the `Resolve` that owns the resolver, which is passed in at each
    call rather than kept: the two are no reference cycle, so reference counting frees them."""

    def __init__(self, ctx: Context, done: dict[str, Any], build: Callable[["Resolve", str, Any], Build],
                 cycle: str, cycle_help: str) -> None:
        self.ctx = ctx
        self.done = done            # name -> resolved, or None after an error
        self.build = build
        self.cycle = cycle          # e.g. "group `{}` contains itself"
        self.cycle_help = cycle_help
        self.visiting: list[str] = []

    def get(self, res: "Resolve", name: str, ref: nodes.Name | None = None) -> Any:
        return run(self.visit(res, name, ref))

    def visit(self, res: "Resolve", name: str, ref: nodes.Name | None) -> Build:
        if name in self.done:
            return self.done[name]
        if name in self.visiting:
            cycle = self.visiting[self.visiting.index(name):]
            owner = cycle[-1]
            others = [n for n in cycle if n != owner]
            msg = self.cycle.format(owner) + (f" through {names(others)}" if others else "")
            self.ctx.r.error("recursion", msg, ref.span if ref else Span(0, 0), help=self.cycle_help)
            for n in cycle:
                self.done[n] = None
            return None
        self.visiting.append(name)
        result = yield from self.build(res, name, self.ctx.decls[name].node)
        self.visiting.pop()
        if name in self.done:       # part of a cycle, already reported
            return None
        self.done[name] = result
        return result


class Resolve:
    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        self.groups = Resolver(ctx, ctx.groups, Resolve.group, "group `{}` contains itself",
                               "a group may contain other groups, but not itself")
        self.poses = Resolver(ctx, ctx.poses, Resolve.pose, "pose `{}` is based on itself",
                              "a pose can start from another pose, but not from itself")

    def servos_of(self, name: nodes.Name, in_pose: bool) -> list[str] | None:
        """The servos a target name stands for, in declaration order; None on error."""
        ctx, text = self.ctx, name.text
        if text in PORTS:
            port = PORTS[text]
            found = [s.name for s in ctx.servos.values() if s.port == port and s.name not in ctx.bad_pins]
            if not found and in_pose:
                ctx.r.warning("empty-port", f"no servo is declared on port {text}, so this sets nothing",
                              name.span, help=f"declare a servo on {text} (e.g. `servo s = {text}.0`) "
                                              "or remove this entry")
            if in_pose:
                ctx.references.update(found)
            return found
        decl = ctx.decls.get(text)
        what = "servo, group or port"          # ports are allowed in poses and in groups
        if decl is None:
            ctx.unknown(name, what, ("servo", "group"), tuple(PORTS))
            return None
        if decl.kind == "servo":
            if in_pose:
                ctx.references.add(text)
            return [text]
        if decl.kind == "group":
            ctx.references.add(text)
            group = self.groups.get(self, text, name)
            if group is None:
                return None
            if in_pose:
                ctx.references.update(group.servos)
            return list(group.servos)
        ctx.wrong_kind(name, decl.kind, "a " + what)
        return None

    def group(self, text: str, decl: nodes.GroupDecl) -> Build:
        ctx = self.ctx
        members: set[str] = set()
        ok = True
        written: set[str] = set()
        for member in decl.members:
            if member.text in written:
                ctx.r.warning("duplicate-member", f"`{member.text}` is listed twice in group `{text}`", member.span,
                              help=f"remove the second `{member.text}`; a group holds each servo once")
            written.add(member.text)
            member_decl = ctx.decls.get(member.text)
            if member_decl is not None and member_decl.kind == "group":
                yield self.groups.visit(self, member.text, member)    # resolved here; servos_of then finds it done
            found = self.servos_of(member, in_pose=False)
            if found is None:
                ok = False
            else:
                members.update(found)
        if not ok:
            return None
        return model.Group(text, tuple(sorted(members, key=ctx.order.__getitem__)), decl.span)

    def pose(self, text: str, decl: nodes.PoseDecl) -> Build:
        ctx = self.ctx
        ok = True
        targets: dict[str, model.Target] = {}
        if decl.base is not None:
            if ctx.lookup(decl.base, "pose", "a pose to start from", {}) is None:
                ok = False
            else:
                base = yield self.poses.visit(self, decl.base.text, decl.base)
                if base is None:
                    ok = False
                else:
                    targets = {t.servo: t for t in base.targets}
        set_by: dict[str, nodes.Entry] = {}
        for entry in decl.entries:
            servos = self.servos_of(entry.target, in_pose=True)
            position = ctx.take(quantities.position(entry.position, "a pose"), entry.position.span)
            if servos is None or position is None:
                ok = False
                continue
            for s in servos:
                first = set_by.get(s)
                if first is not None:
                    how = "" if first.target.text == s else f" (through `{first.target.text}`)"
                    ctx.r.error("duplicate-target", f"pose `{text}` sets servo `{s}` twice",
                                entry.span, help=f"it is first set{how} at line {ctx.line(first.span)}; "
                                                 "each servo may appear once in a pose",
                                secondary=[Label(first.span, "first set here")])
                    ok = False
                    continue
                set_by[s] = entry
                n = self.output(s, position, entry)
                if n is None:
                    ok = False
                    continue
                targets[s] = model.Target(s, n, position, entry.span)
        if not ok:
            return None
        ordered = tuple(targets[s] for s in sorted(targets, key=ctx.order.__getitem__))
        return model.Pose(text, ordered, decl.span)

    def output(self, name: str, position: model.Position, entry: nodes.Entry) -> int | None:
        """The N sent to servo `name` for `position`: limit checked, then reverse, then trim."""
        ctx = self.ctx
        servo = ctx.servos[name]
        n = position.n
        if servo.limit is not None:
            lo, hi = servo.limit
            if not lo <= n <= hi:
                lim = ctx.servo_limits[name]
                ctx.r.error("limit-violation",
                            f"`{format_quantity(entry.position)}` (N {n}) is outside the limit of servo `{name}`: "
                            f"{format_quantity(lim.low)}..{format_quantity(lim.high)} (N {lo}..{hi})",
                            entry.span, help=f"use a position within the limit, or widen the limit "
                                             f"(set at line {ctx.line(lim.span)})")
                return None
        written = n
        if servo.reverse:
            n = units.N_MAX - n
        n += servo.trim
        if not 0 <= n <= units.N_MAX:
            steps = [f"`{format_quantity(entry.position)}` is N {written}"]
            if servo.reverse:
                steps.append(f"reversed: 250 - {written} = {units.N_MAX - written}")
            if servo.trim:
                steps.append(f"trim {servo.trim:+d}: {n}")
            ctx.r.error("out-of-range", f"servo `{name}` would be sent N {n}, outside 0..250",
                        entry.span, help="; ".join(steps) + "; N must stay within 0..250 (500us..2500us)")
            return None
        return n


def resolve(tree: nodes.Program, ctx: Context) -> Resolve:
    """Every group, then every pose, in declaration order."""
    res = Resolve(ctx)
    for name in ctx.declared("group"):
        res.groups.get(res, name)
    for name in ctx.declared("pose"):
        res.poses.get(res, name)
    return res
