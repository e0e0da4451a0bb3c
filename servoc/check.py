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
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from fractions import Fraction

from . import model, nodes, units, walk
from .diagnostics import Label, Reporter
from .lint.resources import report_too_deep
from .printer import format_number, format_quantity
from .source import Span

PORTS = {"P0": 0, "P1": 1, "P2": 2}
CHIPS = ("at89c52", "at89s52", "stc89c52")
CLOCK_HZ = 12_000_000
TIMING_HELP = "the firmware's timing is built for a 12 MHz 12-clock 8051 (AT89C52, AT89S52 or STC89C52)"
ANGLE_UNITS = ("deg",)
KNOWN_UNITS = ("deg", *units.TIME_UNITS_US, *units.FREQ_UNITS_HZ)
_PIN_RE = re.compile(r"([Pp])([0-9]+)\.([0-9]+)\Z")
_POSITION_NEED = "a position (an angle such as `90deg`, a pulse width such as `1500us`, or a raw N such as `122`)"
_DURATION_NEED = "a duration such as `300ms`"

# Deeper nesting of repeats and plays (sequences playing sequences) is reported as `too-deep` by the
# checker already, so that the later passes, which walk plays recursively, never see it.
MAX_LEVELS = 100

_KIND_WORD = {"servo": "a servo", "group": "a group", "pose": "a pose", "sequence": "a sequence"}


@dataclass
class _Decl:
    kind: str                   # servo, group, pose, sequence
    node: object
    name: nodes.Name


@dataclass
class _State:
    servos: dict[str, model.Servo] = field(default_factory=dict)
    servo_limits: dict[str, nodes.LimitOption] = field(default_factory=dict)
    groups: dict[str, model.Group | None] = field(default_factory=dict)
    poses: dict[str, model.Pose | None] = field(default_factory=dict)
    references: set[str] = field(default_factory=set)


def check(tree: nodes.Program, reporter: Reporter, path: str) -> model.Program | None:
    """Resolve and check a parsed program; None when an error was reported."""
    before = sum(1 for d in reporter.diagnostics if d.is_error)
    program = _Checker(reporter, path).run(tree)
    after = sum(1 for d in reporter.diagnostics if d.is_error)
    return program if after == before else None


def _line(reporter: Reporter, span: Span) -> int:
    return reporter.source.line_col(span.start)[0]


def _plural(k: int, word: str) -> str:
    return f"{k} {word}{'' if k == 1 else 's'}"


def _names(names: list[str]) -> str:
    quoted = [f"`{n}`" for n in names]
    if len(quoted) <= 1:
        return "".join(quoted)
    return ", ".join(quoted[:-1]) + " and " + quoted[-1]


class _Checker:
    def __init__(self, reporter: Reporter, path: str) -> None:
        self.r = reporter
        self.path = path
        self.decls: dict[str, _Decl] = {}
        self.order: dict[str, int] = {}          # servo name -> declaration index
        self.st = _State()
        self.visiting_groups: list[str] = []
        self.visiting_poses: list[str] = []
        self.bad_pins: set[str] = set()         # servos whose pin was reported

    # ---- helpers ----------------------------------------------------------

    def line(self, span: Span) -> int:
        return _line(self.r, span)

    def did_you_mean(self, text: str, kinds: tuple[str, ...], extra: tuple[str, ...] = ()) -> str:
        pool = [n for n, d in self.decls.items() if d.kind in kinds] + list(extra)
        close = difflib.get_close_matches(text, pool, n=1, cutoff=0.6)
        if not close:
            everything = list(self.decls) + list(PORTS)
            close = difflib.get_close_matches(text, everything, n=1, cutoff=0.75)
        return f"did you mean `{close[0]}`?" if close else ""

    def unknown(self, name: nodes.Name, what: str, kinds: tuple[str, ...], extra: tuple[str, ...] = ()) -> None:
        help_ = self.did_you_mean(name.text, kinds, extra)
        if not help_ and re.fullmatch(r"[Pp][0-9]+", name.text):
            help_ = "the ports are P0, P1 and P2"
        self.r.error("unknown-name", f"unknown {what} `{name.text}`", name.span, help=help_)

    def wrong_kind(self, name: nodes.Name, found: str, wanted: str, help_: str = "") -> None:
        decl = self.decls[name.text]
        extra = f"; `{name.text}` is declared at line {self.line(decl.name.span)}" if decl else ""
        self.r.error("wrong-kind", f"`{name.text}` is {_KIND_WORD[found]}, but {wanted} is needed here",
                     name.span, help=help_ or extra.lstrip("; "), secondary=[Label(decl.name.span, "declared here")])

    def unit_error(self, q: nodes.Quantity, need: str, context: str = "") -> None:
        text = format_quantity(q)
        unit = q.unit
        where = f" in {context}" if context else ""
        if unit in ANGLE_UNITS:
            msg = f"`{text}` is an angle where {need} is needed{where}"
        elif unit in units.TIME_UNITS_US:
            msg = f"`{text}` is a duration where {need} is needed{where}"
        elif unit in units.FREQ_UNITS_HZ:
            msg = f"`{text}` is a frequency where {need} is needed{where}"
        elif unit == "":
            msg = f"`{text}` has no unit where {need} is needed{where}"
        else:
            close = difflib.get_close_matches(unit, KNOWN_UNITS, n=1, cutoff=0.5)
            lower = [u for u in KNOWN_UNITS if u.lower() == unit.lower()]
            hint = f"did you mean `{format_number(q.value)}{(lower or close)[0]}`?" if (lower or close) else ""
            self.r.error("bad-unit", f"unknown unit `{unit}` in `{text}`; {need} is needed{where}", q.span,
                         help=hint or "the units are deg, us, ms, s, Hz, kHz and MHz")
            return
        help_ = ""
        example = "" if "position" in need else next(
            (u for word, u in (("duration", "ms"), ("period", "ms"), ("angle", "deg"), ("clock", "MHz"))
             if word in need), "")
        if unit == "" and example:
            help_ = f"write the unit right after the number, e.g. `{format_number(q.value)}{example}`"
        elif example == "ms":
            help_ = "durations are written in `us`, `ms` or `s`, e.g. `300ms`"
        elif example == "deg":
            help_ = "angles are written in `deg`, e.g. `60deg`"
        elif example == "MHz":
            help_ = "the clock is written `12MHz`"
        elif "count" in need:
            help_ = "a count is a bare whole number, e.g. `repeat 3`"
        elif "position" in need:
            help_ = "positions are angles (`90deg`), pulse widths (`1500us`) or raw N (`122`)"
        self.r.error("bad-unit", msg, q.span, help=help_)

    # ---- conversions ------------------------------------------------------

    def duration(self, q: nodes.Quantity, context: str, need: str = _DURATION_NEED) -> Fraction | None:
        if q.unit in units.TIME_UNITS_US:
            return q.value * units.TIME_UNITS_US[q.unit]
        self.unit_error(q, need, context)
        return None

    def position(self, q: nodes.Quantity, context: str = "") -> model.Position | None:
        if q.unit == "":
            if q.value.denominator != 1:
                self.r.error("bad-unit", f"`{format_quantity(q)}` has no unit, and a bare number is a raw N, "
                             "which must be whole", q.span,
                             help="write an angle (`90deg`) or a pulse width (`1500us`) for positions between steps")
                return None
            return model.Position(q.value, "n", int(q.value), q.span)
        if q.unit == "deg":
            return model.Position(q.value, "deg", units.deg_to_n(q.value), q.span)
        if q.unit in units.TIME_UNITS_US:
            width = q.value * units.TIME_UNITS_US[q.unit]
            n = units.width_to_n(width)
            return model.Position(width, "us", n, q.span)
        self.unit_error(q, _POSITION_NEED, context)
        return None

    # ---- declarations -----------------------------------------------------

    def run(self, tree: nodes.Program) -> model.Program:
        r = self.r
        frame_us: Fraction | None = None
        frame_span = Span(0, 0)
        target, clock_hz = "at89c52", CLOCK_HZ
        frame_seen: nodes.FrameDecl | None = None
        target_seen: nodes.TargetDecl | None = None
        mains: list[nodes.MainDecl] = []
        used_from: nodes.Item | None = None     # first sequence or main

        for item in tree.items:
            if isinstance(item, (nodes.SequenceDecl, nodes.MainDecl)) and used_from is None:
                used_from = item
            if isinstance(item, nodes.MainDecl):
                if mains:
                    r.error("duplicate-main", "`main` is declared more than once", item.keyword,
                            help=f"the first `main` is at line {self.line(mains[0].keyword)}; a program has exactly one",
                            secondary=[Label(mains[0].keyword, "first declared here")])
                mains.append(item)
                continue
            if isinstance(item, (nodes.FrameDecl, nodes.TargetDecl)):
                word = "frame" if isinstance(item, nodes.FrameDecl) else "target"
                first = frame_seen if word == "frame" else target_seen
                kw = Span(item.span.start, item.span.start + len(word))
                if first is not None:
                    r.error("duplicate-setting", f"`{word}` is set more than once", kw,
                            help=f"the first `{word}` is at line {self.line(first.span)}; keep only one",
                            secondary=[Label(Span(first.span.start, first.span.start + len(word)), "first set here")])
                    continue
                if used_from is not None:
                    what = "main" if isinstance(used_from, nodes.MainDecl) else f"sequence {used_from.name.text}"
                    r.error("late-setting", f"`{word}` must come before the sequences and `main` that use it",
                            kw, help=f"move it above `{what}` (line {self.line(used_from.span)}), "
                                     "e.g. to the top of the file")
                if isinstance(item, nodes.FrameDecl):
                    frame_seen = item
                    frame_span = item.span
                    frame_us = self.frame(item)
                else:
                    target_seen = item
                    target, clock_hz = self.target(item)
                continue
            name = item.name
            kind = {nodes.ServoDecl: "servo", nodes.GroupDecl: "group", nodes.PoseDecl: "pose",
                    nodes.SequenceDecl: "sequence"}[type(item)]
            if name.text in PORTS:
                r.error("duplicate-name", f"`{name.text}` is the name of a port and cannot name {_KIND_WORD[kind]}",
                        name.span, help=f"in a pose, `{name.text}` means every servo on port {name.text}; "
                                        "choose another name")
                continue
            if name.text in self.decls:
                first = self.decls[name.text]
                r.error("duplicate-name", f"`{name.text}` is already declared", name.span,
                        help=f"{_KIND_WORD[first.kind]} `{name.text}` is declared at line {self.line(first.name.span)}; "
                             "names must be unique", secondary=[Label(first.name.span, "first declared here")])
                continue
            self.decls[name.text] = _Decl(kind, item, name)

        if not mains:
            r.error("missing-main", "the program has no `main`", Span(0, 0),
                    help="add `main { ... }` with the statements to run")

        servos = self.servos()
        groups = [g for n, d in self.decls.items() if d.kind == "group" if (g := self.group(n)) is not None]
        poses = [p for n, d in self.decls.items() if d.kind == "pose" if (p := self.pose(n)) is not None]
        plays: dict[str, list[tuple[str, Span]]] = {}
        sequences = []
        for n, d in self.decls.items():
            if d.kind == "sequence":
                calls: list[tuple[str, Span]] = []
                sequences.append(model.Sequence(n, self.stmts(d.node.body, calls), d.node.span))
                plays[n] = calls
        cyclic = self.recursion(plays)
        main: tuple = ()
        main_span = Span(0, 0)
        if mains:
            main = self.stmts(mains[0].body, [])
            main_span = mains[0].span
        for extra in mains[1:]:
            self.stmts(extra.body, [])
        if not cyclic:
            self.deep_nesting(main, sequences, main_span)

        return model.Program(
            path=self.path, servos=tuple(servos), groups=tuple(groups), poses=tuple(poses),
            sequences=tuple(sequences), main=main, frame_us=frame_us, target=target, clock_hz=clock_hz,
            references=frozenset(self.st.references), main_span=main_span, frame_span=frame_span)

    def frame(self, item: nodes.FrameDecl) -> Fraction | None:
        period = self.duration(item.period, "`frame`", "a frame period such as `6ms`")
        if period is None:
            return None
        if period <= 0 or period.denominator != 1:
            self.r.error("bad-frame", f"the frame period `{format_quantity(item.period)}` is not a positive whole "
                         "number of microseconds", item.period.span,
                         help="the firmware counts the frame in 1 µs machine cycles; e.g. `frame 6ms`")
            return None
        return period

    def target(self, item: nodes.TargetDecl) -> tuple[str, int]:
        chip = item.chip.text.lower()
        if chip not in CHIPS:
            self.r.error("unsupported-target", f"target `{item.chip.text}` is not supported", item.chip.span,
                         help=TIMING_HELP)
        clock_hz = CLOCK_HZ
        if item.clock is not None:
            q = item.clock
            if q.unit not in units.FREQ_UNITS_HZ:
                self.unit_error(q, "a clock frequency such as `12MHz`", "`clock`")
            else:
                hz = q.value * units.FREQ_UNITS_HZ[q.unit]
                if hz != CLOCK_HZ:
                    self.r.error("unsupported-target", f"clock `{format_quantity(q)}` is not supported; "
                                 "only 12MHz is", q.span, help=TIMING_HELP)
        return (chip if chip in CHIPS else item.chip.text), clock_hz

    def servos(self) -> list[model.Servo]:
        out: list[model.Servo] = []
        pins: dict[tuple[int, int], nodes.ServoDecl] = {}
        for name, d in self.decls.items():
            if d.kind != "servo":
                continue
            decl: nodes.ServoDecl = d.node
            port, bit = self.pin(decl.pin)
            if port is None:
                self.bad_pins.add(name)
            else:
                other = pins.get((port, bit))
                if other is not None:
                    self.r.error("pin-conflict", f"`{name}` and `{other.name.text}` are both on P{port}.{bit}",
                                 decl.pin.span, help=f"one servo per pin: `{other.name.text}` took P{port}.{bit} "
                                                     f"at line {self.line(other.span)}",
                                 secondary=[Label(other.pin.span, f"`{other.name.text}` is on P{port}.{bit} here")])
                else:
                    pins[(port, bit)] = decl
            servo = self.servo_options(decl, port or 0, bit or 0)
            self.order[name] = len(out)
            out.append(servo)
            self.st.servos[name] = servo
        return out

    def pin(self, pin: nodes.Pin) -> tuple[int | None, int | None]:
        m = _PIN_RE.match(pin.text)
        if m is None:
            self.r.error("bad-pin", f"`{pin.text}` is not a pin", pin.span, help="pins are P0.0 to P2.7")
            return None, None
        port, bit = int(m.group(2)), int(m.group(3))
        if m.group(1) == "p":
            self.r.error("bad-pin", f"pins are written with a capital `P`: `P{m.group(2)}.{m.group(3)}`, "
                         f"not `{pin.text}`", pin.span)
            return None, None
        if not (0 <= port <= 2 and 0 <= bit <= 7):
            self.r.error("bad-pin", f"`{pin.text}` is not a servo pin", pin.span,
                         help="the 24 servo channels are P0.0 to P2.7 (ports 0 to 2, bits 0 to 7)")
            return None, None
        return port, bit

    def servo_options(self, decl: nodes.ServoDecl, port: int, bit: int) -> model.Servo:
        seen: dict[type, nodes.ServoOption] = {}
        t_dav = units.DEFAULT_T_DAV_US
        trim = 0
        limit: tuple[int, int] | None = None
        reverse = False
        for opt in decl.options:
            word = {nodes.SpeedOption: "speed", nodes.TrimOption: "trim", nodes.LimitOption: "limit",
                    nodes.ReverseOption: "reverse"}[type(opt)]
            if type(opt) in seen:
                self.r.error("duplicate-option", f"`{word}` is given more than once for servo `{decl.name.text}`",
                             Span(opt.span.start, opt.span.start + len(word)),
                             help="give each option once; the first `{}` is at line {}, column {}".format(
                                 word, *self.r.source.line_col(seen[type(opt)].span.start)),
                             secondary=[Label(Span(seen[type(opt)].span.start, seen[type(opt)].span.start + len(word)),
                                              "first given here")])
                continue
            seen[type(opt)] = opt
            if isinstance(opt, nodes.SpeedOption):
                t = self.speed(opt)
                if t is not None:
                    t_dav = t
            elif isinstance(opt, nodes.TrimOption):
                q = opt.value
                if q.unit != "" or q.value.denominator != 1:
                    self.r.error("bad-unit", f"trim is a whole number of N steps, not `{format_quantity(q)}`",
                                 q.span, help="one N step is 8 µs (0.74°); e.g. `trim -2`")
                else:
                    trim = int(q.value)
            elif isinstance(opt, nodes.LimitOption):
                limit = self.limit(opt)
                if limit is not None:
                    self.st.servo_limits[decl.name.text] = opt
            else:
                reverse = True
        return model.Servo(decl.name.text, port, bit, t_dav, trim, limit, reverse, decl.span)

    def speed(self, opt: nodes.SpeedOption) -> Fraction | None:
        need = "a time over an angle, as in `speed 0.25s/60deg`"
        d = opt.duration
        a = opt.angle
        ok = True
        if d.unit not in units.TIME_UNITS_US:
            self.unit_error(d, "a duration", "`speed` (" + need + ")")
            ok = False
        if a.unit not in ANGLE_UNITS:
            self.unit_error(a, "an angle", "`speed` (" + need + ")")
            ok = False
        if not ok:
            return None
        dur = d.value * units.TIME_UNITS_US[d.unit]
        if dur <= 0 or a.value <= 0:
            zero = d if dur <= 0 else a
            self.r.error("bad-speed", f"the speed `{format_quantity(d)}/{format_quantity(a)}` must be positive",
                         zero.span, help="a servo's speed is the time it takes to turn an angle, e.g. `0.2s/60deg`")
            return None
        return units.t_dav_from_speed(dur, a.value)

    def limit(self, opt: nodes.LimitOption) -> tuple[int, int] | None:
        lo = self.position(opt.low, "`limit`")
        hi = self.position(opt.high, "`limit`")
        if lo is None or hi is None:
            return None
        bad = False
        for p, q in ((lo, opt.low), (hi, opt.high)):
            if not 0 <= p.n <= units.N_MAX:
                self.r.error("bad-limit", f"the limit bound `{format_quantity(q)}` is N {p.n}, outside 0..250",
                             q.span, help="limits lie within 0deg..185deg (500us..2500us, N 0..250)")
                bad = True
        if bad:
            return None
        if lo.n > hi.n:
            self.r.error("bad-limit", f"the limit `{format_quantity(opt.low)}..{format_quantity(opt.high)}` "
                         f"runs backwards (N {lo.n}..{hi.n})", opt.span,
                         help=f"write the low bound first: `limit {format_quantity(opt.high)}..{format_quantity(opt.low)}`")
            return None
        return lo.n, hi.n

    # ---- groups and targets -----------------------------------------------

    def servos_of(self, name: nodes.Name, in_pose: bool) -> list[str] | None:
        """The servos a target name stands for, in declaration order; None on error."""
        text = name.text
        if text in PORTS:
            port = PORTS[text]
            found = [s.name for s in self.st.servos.values() if s.port == port and s.name not in self.bad_pins]
            if not found and in_pose:
                self.r.warning("empty-port", f"no servo is declared on port {text}, so this sets nothing", name.span,
                               help=f"declare a servo on {text} (e.g. `servo s = {text}.0`) or remove this entry")
            if in_pose:
                self.st.references.update(found)
            return found
        decl = self.decls.get(text)
        what = "servo, group or port"          # ports are allowed in poses and in groups
        if decl is None:
            self.unknown(name, what, ("servo", "group"), tuple(PORTS))
            return None
        if decl.kind == "servo":
            if in_pose:
                self.st.references.add(text)
            return [text]
        if decl.kind == "group":
            self.st.references.add(text)
            group = self.group(text, name)
            if group is None:
                return None
            if in_pose:
                self.st.references.update(group.servos)
            return list(group.servos)
        self.wrong_kind(name, decl.kind, "a " + what)
        return None

    @staticmethod
    def _resolve(gen):
        """Run a resolver generator and those it yields, on an explicit stack instead of Python's:
        a chain of groups or `with` poses may be longer than the interpreter's recursion limit."""
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

    def group(self, text: str, ref: nodes.Name | None = None) -> model.Group | None:
        return self._resolve(self._group(text, ref))

    def _group(self, text: str, ref: nodes.Name | None):
        if text in self.st.groups:
            return self.st.groups[text]
        if text in self.visiting_groups:
            cycle = self.visiting_groups[self.visiting_groups.index(text):]
            owner = cycle[-1]
            others = [g for g in cycle if g != owner]
            msg = f"group `{owner}` contains itself" + (f" through {_names(others)}" if others else "")
            self.r.error("recursion", msg, ref.span if ref else Span(0, 0),
                         help="a group may contain other groups, but not itself")
            for g in cycle:
                self.st.groups[g] = None
            return None
        decl: nodes.GroupDecl = self.decls[text].node
        self.visiting_groups.append(text)
        members: set[str] = set()
        ok = True
        written: set[str] = set()
        for member in decl.members:
            if member.text in written:
                self.r.warning("duplicate-member", f"`{member.text}` is listed twice in group `{text}`", member.span,
                               help=f"remove the second `{member.text}`; a group holds each servo once")
            written.add(member.text)
            member_decl = self.decls.get(member.text)
            if (member_decl is not None and member_decl.kind == "group" and member.text not in self.st.groups
                    and member.text not in self.visiting_groups):
                yield self._group(member.text, member)      # resolved here; servos_of then finds it done
            found = self.servos_of(member, in_pose=False)
            if found is None:
                ok = False
            else:
                members.update(found)
        self.visiting_groups.pop()
        if text in self.st.groups:      # part of a cycle, already reported
            return None
        group = model.Group(text, tuple(sorted(members, key=self.order.__getitem__)), decl.span) if ok else None
        self.st.groups[text] = group
        return group

    # ---- poses ------------------------------------------------------------

    def pose(self, text: str, ref: nodes.Name | None = None) -> model.Pose | None:
        return self._resolve(self._pose(text, ref))

    def _pose(self, text: str, ref: nodes.Name | None):
        if text in self.st.poses:
            return self.st.poses[text]
        if text in self.visiting_poses:
            cycle = self.visiting_poses[self.visiting_poses.index(text):]
            owner = cycle[-1]
            others = [p for p in cycle if p != owner]
            msg = f"pose `{owner}` is based on itself" + (f" through {_names(others)}" if others else "")
            self.r.error("recursion", msg, ref.span if ref else Span(0, 0),
                         help="a pose can start from another pose, but not from itself")
            for p in cycle:
                self.st.poses[p] = None
            return None
        decl: nodes.PoseDecl = self.decls[text].node
        self.visiting_poses.append(text)
        result = yield from self.pose_body(text, decl)
        self.visiting_poses.pop()
        if text in self.st.poses:       # part of a cycle, already reported
            return None
        self.st.poses[text] = result
        return result

    def pose_body(self, text: str, decl: nodes.PoseDecl):
        ok = True
        targets: dict[str, model.Target] = {}
        if decl.base is not None:
            base_decl = self.decls.get(decl.base.text)
            if base_decl is None:
                self.unknown(decl.base, "pose", ("pose",))
                ok = False
            elif base_decl.kind != "pose":
                self.wrong_kind(decl.base, base_decl.kind, "a pose to start from")
                ok = False
            else:
                self.st.references.add(decl.base.text)
                base = yield self._pose(decl.base.text, decl.base)
                if base is None:
                    ok = False
                else:
                    targets = {t.servo: t for t in base.targets}
        set_by: dict[str, nodes.Entry] = {}
        for entry in decl.entries:
            servos = self.servos_of(entry.target, in_pose=True)
            position = self.position(entry.position, "a pose")
            if servos is None or position is None:
                ok = False
                continue
            for s in servos:
                first = set_by.get(s)
                if first is not None:
                    how = "" if first.target.text == s else f" (through `{first.target.text}`)"
                    self.r.error("duplicate-target", f"pose `{text}` sets servo `{s}` twice",
                                 entry.span, help=f"it is first set{how} at line {self.line(first.span)}; "
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
        ordered = tuple(targets[s] for s in sorted(targets, key=self.order.__getitem__))
        return model.Pose(text, ordered, decl.span)

    def output(self, name: str, position: model.Position, entry: nodes.Entry) -> int | None:
        servo = self.st.servos[name]
        written = format_quantity(entry.position)
        n = position.n
        if servo.limit is not None:
            lo, hi = servo.limit
            if not lo <= n <= hi:
                lim = self.st.servo_limits[name]
                self.r.error("limit-violation",
                             f"`{written}` (N {n}) is outside the limit of servo `{name}`: "
                             f"{format_quantity(lim.low)}..{format_quantity(lim.high)} (N {lo}..{hi})",
                             entry.span, help=f"use a position within the limit, or widen the limit "
                                              f"(set at line {self.line(lim.span)})")
                return None
        steps = [f"`{written}` is N {n}"]
        if servo.reverse:
            steps.append(f"reversed: 250 - {n} = {units.N_MAX - n}")
            n = units.N_MAX - n
        if servo.trim:
            steps.append(f"trim {servo.trim:+d}: {n + servo.trim}")
            n += servo.trim
        if not 0 <= n <= units.N_MAX:
            self.r.error("out-of-range", f"servo `{name}` would be sent N {n}, outside 0..250",
                         entry.span, help="; ".join(steps) + "; N must stay within 0..250 (500us..2500us)")
            return None
        return n

    # ---- sequences and statements -----------------------------------------

    def stmts(self, body: tuple[nodes.Stmt, ...], calls: list[tuple[str, Span]]) -> tuple[model.Stmt, ...]:
        out: list[model.Stmt] = []
        for stmt in body:
            res = self.stmt(stmt, calls)
            if res is not None:
                out.append(res)
        return tuple(out)

    def stmt(self, stmt: nodes.Stmt, calls: list[tuple[str, Span]]) -> model.Stmt | None:
        if isinstance(stmt, nodes.MoveStmt):
            duration = None
            if stmt.duration is not None:
                duration = self.duration(stmt.duration, "`move ... in`")
            pose = self.pose_ref(stmt.pose)
            if pose is None or (stmt.duration is not None and duration is None):
                return None
            return model.Move(pose.name, pose.targets, duration, stmt.ease or "linear", stmt.span)
        if isinstance(stmt, nodes.HoldStmt):
            duration = self.duration(stmt.duration, "`hold`")
            return None if duration is None else model.Hold(duration, stmt.span)
        if isinstance(stmt, nodes.RepeatStmt):
            count = self.count(stmt.count)
            body = self.stmts(stmt.body, calls)
            return None if count is None else model.Repeat(count, body, stmt.span)
        if isinstance(stmt, nodes.LoopStmt):
            return model.Loop(self.stmts(stmt.body, calls), stmt.span)
        if isinstance(stmt, nodes.PlayStmt):
            name = stmt.name
            decl = self.decls.get(name.text)
            if decl is None:
                self.unknown(name, "sequence", ("sequence",))
                return None
            if decl.kind != "sequence":
                help_ = f"to go to a pose, write `move {name.text}`" if decl.kind == "pose" else ""
                self.wrong_kind(name, decl.kind, "a sequence", help_)
                return None
            self.st.references.add(name.text)
            calls.append((name.text, stmt.span))
            return model.Play(name.text, stmt.span)
        raise TypeError(f"not a statement: {stmt!r}")

    def pose_ref(self, name: nodes.Name) -> model.Pose | None:
        decl = self.decls.get(name.text)
        if decl is None:
            if name.text in PORTS:
                self.r.error("wrong-kind", f"`{name.text}` is a port, but a pose is needed here", name.span,
                             help=f"declare a pose such as `pose p {{ {name.text}: 90deg }}` and move to it")
            else:
                self.unknown(name, "pose", ("pose",))
            return None
        if decl.kind != "pose":
            help_ = f"to run a sequence, write `play {name.text}`" if decl.kind == "sequence" else ""
            self.wrong_kind(name, decl.kind, "a pose", help_)
            return None
        self.st.references.add(name.text)
        return self.pose(name.text, name)

    def count(self, q: nodes.Quantity) -> int | None:
        if q.unit != "":
            self.unit_error(q, "a repeat count such as `3`", "`repeat`")
            return None
        if q.value.denominator != 1 or q.value < 1:
            self.r.error("bad-count", f"a repeat count must be a whole number of at least 1, not "
                         f"`{format_quantity(q)}`", q.span, help="to repeat forever, use `loop { ... }`")
            return None
        return int(q.value)

    def deep_nesting(self, main: tuple, sequences: list[model.Sequence], main_span: Span) -> None:
        """Report `too-deep` here, as lint would, when sequences playing sequences nest repeats and
        plays more than MAX_LEVELS deep: the later passes walk plays with Python recursion."""
        body_of = {q.name: q.body for q in sequences}.__getitem__
        depth = walk.nesting(main, body_of)
        if depth > MAX_LEVELS:
            report_too_deep(self.r, depth, main, body_of, main_span)

    def recursion(self, plays: dict[str, list[tuple[str, Span]]]) -> bool:
        """Report each cycle of `play` between sequences once; True when there is one."""
        index: dict[str, int] = {}
        low: dict[str, int] = {}
        stack: list[str] = []
        on_stack: set[str] = set()
        sccs: list[list[str]] = []

        # Tarjan's algorithm, iterative.
        for root in plays:
            if root in index:
                continue
            work = [(root, 0)]
            while work:
                v, i = work.pop()
                if i == 0:
                    index[v] = low[v] = len(index)
                    stack.append(v)
                    on_stack.add(v)
                callees = [c for c, _ in plays.get(v, [])]
                recurse = False
                while i < len(callees):
                    w = callees[i]
                    i += 1
                    if w not in index:
                        work.append((v, i))
                        work.append((w, 0))
                        recurse = True
                        break
                    if w in on_stack:
                        low[v] = min(low[v], index[w])
                if recurse:
                    continue
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    sccs.append(comp)
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[v])

        order = {n: i for i, n in enumerate(plays)}
        cyclic = False
        for comp in sorted(sccs, key=lambda c: min(order[n] for n in c)):
            members = set(comp)
            start = min(comp, key=order.__getitem__)
            if len(comp) == 1 and start not in [c for c, _ in plays[start]]:
                continue
            cyclic = True
            path = self.cycle_path(start, members, plays)
            first_span = next(span for c, span in plays[start] if c == (path[1] if len(path) > 1 else start))
            others = path[1:]
            msg = f"sequence `{start}` plays itself" + (f" through {_names(others)}" if others else "")
            chain = " -> ".join([*path, start])
            self.r.error("recursion", msg, first_span,
                         help=f"{chain}; sequences may play other sequences, but never in a cycle")
        return cyclic

    @staticmethod
    def cycle_path(start: str, members: set[str], plays: dict[str, list[tuple[str, Span]]]) -> list[str]:
        """The shortest path start -> ... -> start within one strongly connected component."""
        if start in [c for c, _ in plays[start]]:
            return [start]
        prev: dict[str, str] = {}
        queue = [start]
        seen = {start}
        while queue:
            v = queue.pop(0)
            for w, _ in plays.get(v, []):
                if w == start:
                    path = [v]
                    while path[-1] != start:
                        path.append(prev[path[-1]])
                    return list(reversed(path))
                if w in members and w not in seen:
                    seen.add(w)
                    prev[w] = v
                    queue.append(w)
        return [start]
