"""Pass 5, statements: the bodies of the sequences and of `main`, and what each sequence plays.

A `select` needs at least one `on`, at most one `after` and one `meanwhile`, both after every `on`
(in either order), and at most one `on other`; `wait EVENT` becomes `select { on EVENT { } }` and
`STATEMENT until EVENT` `select { on EVENT { } meanwhile { STATEMENT } }`. An event is a declared input or a byte (a one-character ASCII string or
a whole number 0..255), and a byte needs `serial`; so does `send`. The statement `host` needs the
`host ssc32` declaration."""

from __future__ import annotations

from .. import model, nodes
from ..diagnostics import Label
from ..printer import format_event, format_quantity
from ..source import Span
from . import quantities
from .context import PORTS, Context
from .resolve import Resolve

Calls = list[tuple[str, Span]]


def statements(tree: nodes.Program, ctx: Context, res: Resolve) -> model.Pose | None:
    """Convert the bodies; returns the `home` pose (None: none, or an error reported)."""
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
    return conv.pose_ref(ctx.home) if ctx.home is not None else None


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
        if isinstance(stmt, nodes.SelectStmt):
            return self.select(stmt, calls)
        if isinstance(stmt, nodes.WaitStmt):
            event = self.event(stmt.event, "wait")
            return None if event is None else model.Select((model.On(event, (), stmt.span),), True, stmt.span)
        if isinstance(stmt, nodes.UntilStmt):
            inner = self.stmt(stmt.stmt, calls)
            event = self.event(stmt.event, "until")
            if inner is None or event is None:
                return None
            return model.Select((model.On(event, (), stmt.event.span),), False, stmt.span, (inner,), True)
        if isinstance(stmt, nodes.SendStmt):
            byte = self.byte(stmt.byte, "send")
            if byte is None:
                return None
            self.need_serial(stmt.span, "`send` transmits on the serial line")
            return model.Send(byte, format_event(stmt.byte), stmt.span)
        if isinstance(stmt, nodes.HostStmt):
            if ctx.host_decl is None:
                ctx.r.error("host-undeclared", "`host` obeys host software, but the program declares no host "
                            "protocol", stmt.span,
                            help="add `host ssc32` (with `serial BAUD`) at the top of the file: SSC-32 host "
                                 "software then drives the servos while `host` runs")
                return None
            return model.Host(stmt.span)
        raise TypeError(f"not a statement: {stmt!r}")

    def select(self, stmt: nodes.SelectStmt, calls: Calls) -> model.Select | None:
        ctx = self.ctx
        ok = True
        keyword = Span(stmt.span.start, stmt.span.start + len("select"))
        afters = [b for b in stmt.branches if isinstance(b, nodes.AfterBranch)]
        whiles = [b for b in stmt.branches if isinstance(b, nodes.MeanwhileBranch)]
        if not any(isinstance(b, nodes.OnBranch) for b in stmt.branches):
            ctx.r.error("bad-select", "this `select` has no `on` branch: there is nothing to wait for", keyword,
                        help="add `on EVENT { ... }` (an input's name or a byte such as `\"w\"`); "
                             "to wait a fixed time, use `hold`")
            ok = False
        for extra in afters[1:]:
            ctx.r.error("bad-select", "a `select` has at most one `after`", _kw(extra, "after"),
                        help=f"the first `after` is at line {ctx.line(afters[0].span)}; keep one",
                        secondary=[Label(_kw(afters[0], "after"), "first `after` here")])
            ok = False
        for extra in whiles[1:]:
            ctx.r.error("bad-select", "a `select` has at most one `meanwhile`", _kw(extra, "meanwhile"),
                        help=f"the first `meanwhile` is at line {ctx.line(whiles[0].span)}; put everything "
                             "the select runs while it waits in that one",
                        secondary=[Label(_kw(whiles[0], "meanwhile"), "first `meanwhile` here")])
            ok = False
        ends = [b for b in stmt.branches if not isinstance(b, nodes.OnBranch)]
        late_on = next((b for b in stmt.branches[stmt.branches.index(ends[0]):] if isinstance(b, nodes.OnBranch)),
                       None) if ends else None
        if late_on is not None and len(afters) <= 1 and len(whiles) <= 1:
            word = "after" if isinstance(ends[0], nodes.AfterBranch) else "meanwhile"
            message = ("`after` must be the last branch of a `select`" if not whiles else
                       f"`{word}` must come after every `on` of a `select`")
            ctx.r.error("bad-select", message, _kw(ends[0], word),
                        help=f"move the `{word}` branch below every `on` (the `on`s are tried in the order written)")
            ok = False
        branches: list[model.On | model.After] = []
        meanwhile = None
        for b in stmt.branches:
            body = self.body(b.body, calls)
            if isinstance(b, nodes.MeanwhileBranch):
                meanwhile = body if meanwhile is None else meanwhile
            elif isinstance(b, nodes.OnBranch):
                event = self.event(b.event, "on")
                if event is None:
                    ok = False
                else:
                    branches.append(model.On(event, body, b.span))
            else:
                duration = ctx.take(quantities.duration_us(b.duration, "`after`"), b.duration.span)
                if duration is None:
                    ok = False
                else:
                    branches.append(model.After(duration, body, b.span))
        if ok:
            ok = self.other_once(branches)
        return model.Select(tuple(branches), False, stmt.span, meanwhile) if ok else None

    def other_once(self, branches: list) -> bool:
        """At most one `on other`; an `on` of a byte written after it is still its own."""
        others = [b for b in branches if isinstance(b, model.On) and b.event.other]
        for extra in others[1:]:
            self.ctx.r.error("bad-select", "a `select` has at most one `on other`", extra.event.span,
                             help=f"the first `on other` is at line {self.ctx.line(others[0].span)}; keep one",
                             secondary=[Label(others[0].event.span, "first `on other` here")])
        return len(others) <= 1

    def event(self, ev: nodes.Event, word: str) -> model.Event | None:
        """An input, an edge of one, a byte or `other`, after `on`, `wait` or `until`."""
        if isinstance(ev, nodes.OtherEvent):
            if word != "on":
                self.ctx.r.error("bad-event", f"`{word} other` is not an event: `other` is a branch of a `select`",
                                 ev.span, help="write `select { on other { ... } }`: `on other` takes any byte "
                                               "no other `on` of the select names")
                return None
            self.need_serial(ev.span, "`on other` takes a byte received on the serial line")
            return model.Event(None, None, "other", ev.span, None, True)
        if isinstance(ev, nodes.EdgeEvent):
            if ev.literal and ev.word.text in model.EDGES:
                self.ctx.r.error("bad-event", f"`{ev.word.text}` and `{'release' if ev.word.text == 'press' else 'press'}` "
                                 f"apply to inputs; `{ev.input.text}` is a byte", ev.span,
                                 help=f"a byte is `{word} {ev.input.text}`; `{word} {ev.word.text} NAME` waits for an "
                                      "input's change")
                return None
            if ev.word.text not in model.EDGES:
                self.ctx.r.error("bad-event", f"expected `press` or `release` before `{ev.input.text}`, found "
                                 f"`{ev.word.text}`", ev.word.span,
                                 help=f"`{word} press {ev.input.text}`: the input has become active; "
                                      f"`{word} release {ev.input.text}`: it has become inactive")
                return None
            inner = self.event(ev.input, word)
            if inner is None:
                return None
            if inner.input is None:
                self.ctx.r.error("bad-event", f"`{ev.word.text}` is an input's change, not a byte's", ev.span,
                                 help=f"write `{word} {format_event(ev.input)}` for a byte; `{ev.word.text}` "
                                      "takes an input's name")
                return None
            return model.Event(inner.input, None, f"{ev.word.text} {inner.input}", ev.span, ev.word.text)
        if isinstance(ev, nodes.Name):
            if self.ctx.lookup(ev, "input", "an input or a byte",
                               {k: f"an event is an input (`input {ev.text} = P3.2`) or a byte such as `\"w\"`"
                                for k in ("servo", "group", "pose", "sequence")}) is None:
                return None
            return model.Event(ev.text, None, ev.text, ev.span)
        byte = self.byte(ev, word)
        if byte is None:
            return None
        self.need_serial(ev.span, f"a byte after `{word}` is received on the serial line")
        return model.Event(None, byte, format_event(ev), ev.span)

    def byte(self, ev: nodes.Event, word: str) -> int | None:
        """A one-character ASCII string or a whole number 0..255, else None after `bad-byte`."""
        r = self.ctx.r
        if isinstance(ev, nodes.Name):
            kind = self.ctx.decls[ev.text].kind if ev.text in self.ctx.decls else None
            what = f"the {kind} `{ev.text}`" if kind else f"the name `{ev.text}`"
            r.error("bad-byte", f"`{word}` transmits a byte, not {what}", ev.span,
                    help=f"write the byte as one character in quotes or as a number: `{word} \"{ev.text[0]}\"`")
            return None
        if isinstance(ev, nodes.StringLit):
            if len(ev.text) != 1 or ord(ev.text) > 127:
                what = "empty" if not ev.text else (f"{len(ev.text)} characters long" if len(ev.text) != 1
                                                    else "not an ASCII character")
                r.error("bad-byte", f"the string `\"{ev.text}\"` is {what}: a byte is one ASCII character",
                        ev.span, help="write one character, such as `\"w\"`, or the byte's number 0..255 "
                                      "(`10` for a newline, `34` for `\"`)")
                return None
            return ord(ev.text)
        if isinstance(ev, (nodes.EdgeEvent, nodes.OtherEvent)):
            r.error("bad-byte", f"`{word}` transmits one byte, not `{format_event(ev)}`", ev.span,
                    help=f"write the byte as one character in quotes or as a number 0..255: `{word} \"k\"`")
            return None
        if ev.unit != "" or ev.value.denominator != 1 or not 0 <= ev.value <= 255:
            r.error("bad-byte", f"`{format_quantity(ev)}` is not a byte: a byte is a whole number 0..255",
                    ev.span, help="write a number 0..255 without a unit, or one character in quotes, `\"w\"`")
            return None
        return int(ev.value)

    def need_serial(self, span: Span, why: str) -> None:
        if not self.ctx.has_serial:
            self.ctx.r.error("no-serial", f"{why}, but the program declares no `serial`", span,
                             help="declare the serial line and its rate, e.g. `serial 4800` (at 12 MHz) "
                                  "or `serial 9600` (at 11.0592 MHz)")

    def pose_ref(self, name: nodes.Name) -> model.Pose | None:
        ctx = self.ctx
        if name.text in PORTS and name.text not in ctx.decls:
            ctx.r.error("wrong-kind", f"`{name.text}` is a port, but a pose is needed here", name.span,
                        help=f"declare a pose such as `pose p {{ {name.text}: 90deg }}` and move to it")
            return None
        if ctx.lookup(name, "pose", "a pose", {"sequence": f"to run a sequence, write `play {name.text}`"}) is None:
            return None
        return self.res.poses.get(self.res, name.text, name)

    def count(self, q: nodes.Quantity) -> int | None:
        value = self.ctx.take(quantities.count(q), q.span)
        if value is None:
            return None
        if value.denominator != 1 or value < 1:
            self.ctx.r.error("bad-count", f"a repeat count must be a whole number of at least 1, not "
                             f"`{format_quantity(q)}`", q.span, help="to repeat forever, use `loop { ... }`")
            return None
        return int(value)


def _kw(node, word: str) -> Span:
    return Span(node.span.start, node.span.start + len(word))

