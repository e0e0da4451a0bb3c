"""Pass 3, servos: pins (one servo per pin) and options (speed, trim, limit, reverse, channel)."""

from __future__ import annotations

import re
from fractions import Fraction

from .. import model, nodes, units
from ..diagnostics import Label
from ..printer import format_quantity
from ..source import Span
from . import quantities
from .context import Context

_PIN_RE = re.compile(r"([Pp])([0-9]+)\.([0-9]+)\Z")
_OPTION_WORD = {nodes.SpeedOption: "speed", nodes.TrimOption: "trim", nodes.LimitOption: "limit",
                nodes.ReverseOption: "reverse", nodes.ChannelOption: "channel"}


def servos(tree: nodes.Program, ctx: Context) -> None:
    pins: dict[tuple[int, int], nodes.ServoDecl] = {}
    for name in ctx.declared("servo"):
        decl: nodes.ServoDecl = ctx.decls[name].node
        port, bit = pin(decl.pin, ctx)
        if port is None:
            ctx.bad_pins.add(name)
        else:
            other = pins.get((port, bit))
            if other is not None:
                ctx.r.error("pin-conflict", f"`{name}` and `{other.name.text}` are both on P{port}.{bit}",
                            decl.pin.span, help=f"one servo per pin: `{other.name.text}` took P{port}.{bit} "
                                                f"at line {ctx.line(other.span)}",
                            secondary=[Label(other.pin.span, f"`{other.name.text}` is on P{port}.{bit} here")])
            else:
                pins[(port, bit)] = decl
        ctx.order[name] = len(ctx.servos)
        ctx.servos[name] = options(decl, port or 0, bit or 0, ctx)


SERVO_PINS = (2, "pins are P0.0 to P2.7", "a servo pin",
              "the 24 servo channels are P0.0 to P2.7 (ports 0 to 2, bits 0 to 7)")


def pin(p: nodes.Pin, ctx: Context, kind: tuple[int, str, str, str] = SERVO_PINS) -> tuple[int | None, int | None]:
    """The port and bit of a pin; `kind`: the last port allowed, the help for text that is no pin,
    what a pin out of range is not, and the help for it."""
    last_port, not_pin_help, what, range_help = kind
    m = _PIN_RE.match(p.text)
    if m is None:
        ctx.r.error("bad-pin", f"`{p.text}` is not a pin", p.span, help=not_pin_help)
        return None, None
    port, bit = int(m.group(2)), int(m.group(3))
    if m.group(1) == "p":
        ctx.r.error("bad-pin", f"pins are written with a capital `P`: `P{m.group(2)}.{m.group(3)}`, "
                    f"not `{p.text}`", p.span)
        return None, None
    if not (0 <= port <= last_port and 0 <= bit <= 7):
        ctx.r.error("bad-pin", f"`{p.text}` is not {what}", p.span, help=range_help)
        return None, None
    return port, bit


def options(decl: nodes.ServoDecl, port: int, bit: int, ctx: Context) -> model.Servo:
    seen: dict[type, nodes.ServoOption] = {}
    t_dav = units.DEFAULT_T_DAV_US
    trim = 0
    limit_n: tuple[int, int] | None = None
    reverse = False
    channel: int | None = None
    for opt in decl.options:
        word = _OPTION_WORD[type(opt)]
        if type(opt) in seen:
            first = seen[type(opt)].span.start
            ctx.r.error("duplicate-option", f"`{word}` is given more than once for servo `{decl.name.text}`",
                        Span(opt.span.start, opt.span.start + len(word)),
                        help="give each option once; the first `{}` is at line {}, column {}".format(
                            word, *ctx.r.source.line_col(first)),
                        secondary=[Label(Span(first, first + len(word)), "first given here")])
            continue
        seen[type(opt)] = opt
        if isinstance(opt, nodes.SpeedOption):
            t = speed(opt, ctx)
            if t is not None:
                t_dav = t
        elif isinstance(opt, nodes.TrimOption):
            value = ctx.take(quantities.trim(opt.value), opt.value.span)
            if value is not None:
                trim = value
        elif isinstance(opt, nodes.LimitOption):
            limit_n = limit(opt, ctx)
            if limit_n is not None:
                ctx.servo_limits[decl.name.text] = opt
        elif isinstance(opt, nodes.ChannelOption):
            channel = host_channel(opt, ctx)
            if channel is not None:
                ctx.servo_channels[decl.name.text] = opt
        else:
            reverse = True
    return model.Servo(decl.name.text, port, bit, t_dav, trim, limit_n, reverse, decl.span, channel)


def host_channel(opt: nodes.ChannelOption, ctx: Context) -> int | None:
    """`channel K`: a whole number 0..31."""
    q = opt.channel
    value = ctx.take(quantities.channel(q), q.span)
    if value is None:
        return None
    if value.denominator != 1 or not 0 <= value <= model.MAX_HOST_CHANNEL:
        ctx.r.error("out-of-range", f"channel `{format_quantity(q)}` is not a whole number 0..{model.MAX_HOST_CHANNEL}",
                    q.span, help="the host protocol's channels are 0 to 31; without `channel`, a servo's channel "
                                 "is its pin's: P1.b is b, P2.b is 8 + b, P0.b is 16 + b")
        return None
    return int(value)


def speed(opt: nodes.SpeedOption, ctx: Context) -> Fraction | None:
    need = "`speed` (a time over an angle, as in `speed 0.25s/60deg`)"
    d, a = opt.duration, opt.angle
    dur = ctx.take(quantities.duration_us(d, need, "a duration"), d.span)
    angle = ctx.take(quantities.angle_deg(a, need, "an angle"), a.span)
    if dur is None or angle is None:
        return None
    if dur <= 0 or angle <= 0:
        zero = d if dur <= 0 else a
        ctx.r.error("bad-speed", f"the speed `{format_quantity(d)}/{format_quantity(a)}` must be positive",
                    zero.span, help="a servo's speed is the time it takes to turn an angle, e.g. `0.2s/60deg`")
        return None
    return units.t_dav_from_speed(dur, angle)


def limit(opt: nodes.LimitOption, ctx: Context) -> tuple[int, int] | None:
    lo = ctx.take(quantities.position(opt.low, "`limit`"), opt.low.span)
    hi = ctx.take(quantities.position(opt.high, "`limit`"), opt.high.span)
    if lo is None or hi is None:
        return None
    bad = False
    for p, q in ((lo, opt.low), (hi, opt.high)):
        if not 0 <= p.n <= units.N_MAX:
            ctx.r.error("bad-limit", f"the limit bound `{format_quantity(q)}` is N {p.n}, outside 0..250",
                        q.span, help="limits lie within 0deg..185deg (500us..2500us, N 0..250)")
            bad = True
    if bad:
        return None
    if lo.n > hi.n:
        ctx.r.error("bad-limit", f"the limit `{format_quantity(opt.low)}..{format_quantity(opt.high)}` "
                    f"runs backwards (N {lo.n}..{hi.n})", opt.span,
                    help=f"write the low bound first: `limit {format_quantity(opt.high)}..{format_quantity(opt.low)}`")
        return None
    return lo.n, hi.n
