"""What the passes share: the symbol table, the results so far, and how names are reported."""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from .. import model, nodes
from ..diagnostics import Label, Reporter
from ..source import Span
from ..target import DEFAULT as DEFAULT_TARGET, Target
from .quantities import Problem

PORTS = {"P0": 0, "P1": 1, "P2": 2}

KIND_WORD = {"servo": "a servo", "group": "a group", "pose": "a pose", "sequence": "a sequence",
             "input": "an input"}


@dataclass
class Decl:
    kind: str                   # servo, group, pose, sequence, input
    node: Any
    name: nodes.Name


@dataclass
class Context:
    """One run of the checker: filled in by the passes in order."""
    r: Reporter
    path: str
    decls: dict[str, Decl] = field(default_factory=dict)          # declarations pass
    mains: list[nodes.MainDecl] = field(default_factory=list)
    frame_us: Fraction | None = None                              # settings pass
    frame_span: Span = Span(0, 0)
    target: Target = DEFAULT_TARGET
    home: nodes.Name | None = None                                # `home POSE`, resolved after the poses
    stagger_us: Fraction | None = None
    stagger_span: Span = Span(0, 0)
    host_decl: nodes.SettingDecl | None = None                    # `host PROTOCOL` written (even an unknown one)
    host: str | None = None                                       # its protocol, when known ("ssc32")
    servos: dict[str, model.Servo] = field(default_factory=dict)  # servos pass, declaration order
    order: dict[str, int] = field(default_factory=dict)          # servo -> declaration index
    servo_limits: dict[str, nodes.LimitOption] = field(default_factory=dict)
    servo_channels: dict[str, nodes.ChannelOption] = field(default_factory=dict)   # a valid `channel K`
    bad_pins: set[str] = field(default_factory=set)               # servos whose pin was reported
    inputs: dict[str, model.Input] = field(default_factory=dict)  # inputs pass, declaration order
    serial: model.Serial | None = None
    serial_span: Span = Span(0, 0)
    has_serial: bool = False                                      # `serial` written (even at a bad rate)
    groups: dict[str, model.Group | None] = field(default_factory=dict)     # resolve pass
    poses: dict[str, model.Pose | None] = field(default_factory=dict)
    sequences: list[model.Sequence] = field(default_factory=list)          # statements pass
    plays: dict[str, list[tuple[str, Span]]] = field(default_factory=dict)  # sequence -> what it plays
    main: tuple[model.Stmt, ...] = ()
    main_span: Span = Span(0, 0)
    references: set[str] = field(default_factory=set)           # names used after their declaration

    def line(self, span: Span) -> int:
        return self.r.source.line_col(span.start)[0]

    def declared(self, kind: str) -> list[str]:
        return [n for n, d in self.decls.items() if d.kind == kind]

    def take(self, value: Any, span: Span) -> Any:
        """`value`, or None after reporting it as `bad-unit` when it is a quantities.Problem."""
        if isinstance(value, Problem):
            self.r.error("bad-unit", value.message, span, help=value.help)
            return None
        return value

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
        extra = f"`{name.text}` is declared at line {self.line(decl.name.span)}"
        self.r.error("wrong-kind", f"`{name.text}` is {KIND_WORD[found]}, but {wanted} is needed here",
                     name.span, help=help_ or extra, secondary=[Label(decl.name.span, "declared here")])

    def lookup(self, name: nodes.Name, kind: str, wanted: str, help_for: dict[str, str]) -> Decl | None:
        """The declaration `name` refers to, when it is `kind`; else None after an error
        (`help_for`: the help when it is another kind)."""
        decl = self.decls.get(name.text)
        if decl is None:
            self.unknown(name, kind, (kind,))
            return None
        if decl.kind != kind:
            self.wrong_kind(name, decl.kind, wanted, help_for.get(decl.kind, ""))
            return None
        self.references.add(name.text)
        return decl


def names(items: list[str]) -> str:
    """`a`, `b` and `c`."""
    quoted = [f"`{n}`" for n in items]
    if len(quoted) <= 1:
        return "".join(quoted)
    return ", ".join(quoted[:-1]) + " and " + quoted[-1]
