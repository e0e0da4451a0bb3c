"""Pass 3b, inputs and serial: `input` pins (not a servo's, not another input's, not RXD/TXD with
`serial`) and levels; `serial` once, at a rate Timer1 makes within 2 % at the target's clock."""

from __future__ import annotations


from .. import model, nodes
from ..diagnostics import Label
from ..printer import format_quantity
from ..source import Span
from ..target import BAUD_TOLERANCE, crystal_for, fmt_hz, timer1_baud, working_bauds
from . import servos
from .context import Context

SERIAL_PINS = {(3, 0): "RXD", (3, 1): "TXD"}
NEAREST = 2         # working rates an unmakeable rate's error names


def inputs(tree: nodes.Program, ctx: Context) -> None:
    serial(tree, ctx)
    taken: dict[tuple[int, int], str] = {}          # pin -> what is on it, for messages
    spans: dict[tuple[int, int], Span] = {}
    for name, s in ctx.servos.items():
        if name not in ctx.bad_pins:
            taken[(s.port, s.bit)] = f"servo `{name}`"
            spans[(s.port, s.bit)] = ctx.decls[name].node.pin.span
    if ctx.has_serial:
        for where, what in SERIAL_PINS.items():
            taken.setdefault(where, f"`serial` ({what})")
            spans.setdefault(where, ctx.serial_span)
    for name in ctx.declared("input"):
        decl: nodes.InputDecl = ctx.decls[name].node
        active_high = level(decl, ctx)
        port, bit = pin(decl.pin, ctx)
        if port is None:
            continue
        other = taken.get((port, bit))
        if other is not None:
            what = SERIAL_PINS.get((port, bit)) if other.startswith("`serial`") else None
            help_ = (f"with `serial`, P3.0 (RXD) and P3.1 (TXD) are the serial line's; "
                     "P3.2 to P3.7 are free for inputs" if what else
                     f"an input needs a pin of its own; {other} is declared at line {ctx.line(spans[(port, bit)])}")
            ctx.r.error("pin-conflict", f"input `{name}` is on P{port}.{bit}, the pin of {other}", decl.pin.span,
                        help=help_, secondary=[Label(spans[(port, bit)], f"{other} is on P{port}.{bit} here")])
            continue
        taken[(port, bit)] = f"input `{name}`"
        spans[(port, bit)] = decl.pin.span
        ctx.inputs[name] = model.Input(name, port, bit, active_high, decl.span)


def level(decl: nodes.InputDecl, ctx: Context) -> bool:
    """True for `high`; `low` (the default) is False."""
    if decl.level is None or decl.level.text == "low":
        return False
    if decl.level.text == "high":
        return True
    ctx.r.error("syntax-error", f"expected `low` or `high` after the pin, found `{decl.level.text}`",
                decl.level.span, help="`low` (the default): active when the pin is pulled to ground; "
                                      "`high`: active when it reads 1")
    return False


INPUT_PINS = (3, "inputs are on P0.0 to P3.7", "a pin of the 8051",
              "inputs are on P0.0 to P3.7 (ports 0 to 3, bits 0 to 7); P3.2 to P3.7 are the usual choice")


def pin(p: nodes.Pin, ctx: Context) -> tuple[int | None, int | None]:
    return servos.pin(p, ctx, INPUT_PINS)


def serial(tree: nodes.Program, ctx: Context) -> None:
    """`serial BAUD` once; the rate Timer1 makes at the target's clock."""
    first: nodes.SerialDecl | None = None
    for item in tree.items:
        if not isinstance(item, nodes.SerialDecl):
            continue
        kw = Span(item.span.start, item.span.start + len("serial"))
        if first is not None:
            ctx.r.error("duplicate-setting", "`serial` is declared more than once", kw,
                        help=f"the first `serial` is at line {ctx.line(first.span)}; keep only one",
                        secondary=[Label(Span(first.span.start, first.span.start + len("serial")),
                                         "first declared here")])
            continue
        first = item
        ctx.serial_span = item.span
        ctx.serial = rate(item, ctx)
        ctx.has_serial = True


def rate(item: nodes.SerialDecl, ctx: Context) -> model.Serial | None:
    q = item.baud
    target = ctx.target
    works = working_bauds(target)
    if q.unit not in ("", "baud") or q.value.denominator != 1 or q.value <= 0:
        ctx.r.error("bad-baud", f"`{format_quantity(q)}` is not a baud rate", q.span,
                    help="write the rate as a whole number of bits per second, e.g. `serial "
                         f"{works[-1] if works else 9600}`")
        return None
    baud = int(q.value)
    th1, smod, actual = timer1_baud(target, baud)
    off = abs(actual - baud) / baud
    if off <= BAUD_TOLERANCE:
        return model.Serial(baud, th1, smod, actual, item.span)
    where = fmt_hz(target.clock_hz) + (" in 6T mode" if target.six_t else "")
    near = sorted(works, key=lambda b: (abs(b - baud) / min(b, baud), b))[:NEAREST]
    message = (f"{baud} baud: Timer1 cannot make it within 2 % at {where} (the nearest it makes is "
               f"{float(actual):.0f} baud, {float(off) * 100:.1f} % off)")
    message += ("; nearest rates that work at " + where + ": " + ", ".join(map(str, near))) if near else \
        f"; no standard rate works at {where}"
    crystal = crystal_for(target, baud)
    if crystal is not None:
        exact = timer1_baud(type(target)(target.chip, crystal, target.six_t), baud)[2] == baud
        help_ = (f"a {fmt_hz(crystal)} crystal makes {baud} {'exactly' if exact else 'within 2 %'} "
                 f"(`target {target.chip.name} clock {fmt_hz(crystal).replace(' ', '')}"
                 f"{' mode 6T' if target.six_t else ''}`)")
        if near:
            help_ += f", or use `serial {near[0]}`"
    else:
        help_ = f"use `serial {near[0]}`" if near else "choose another crystal with `target ... clock`"
    ctx.r.error("bad-baud", message, q.span, help=help_)
    return None
