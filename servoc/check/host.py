"""Pass 3c, host: `host ssc32` needs `serial`; with it, each servo's host channel is its own; without
it, a `channel` option does nothing (a warning). The statement `host` is the statements pass's."""

from __future__ import annotations

from .. import model, nodes
from ..diagnostics import Label
from ..source import Span
from .context import Context

SERIAL_HELP = ("declare the serial line and its rate, e.g. `serial 9600` (at 11.0592 MHz) or `serial 4800` "
               "(at 12 MHz)")
CHANNEL_RULE = "without `channel`, a servo's channel is its pin's: P1.b is b, P2.b is 8 + b, P0.b is 16 + b"


def host(tree: nodes.Program, ctx: Context) -> None:
    decl = ctx.host_decl
    if decl is None:
        unused(ctx)
        return
    if not ctx.has_serial:
        what = f"`host {ctx.host}`" if ctx.host is not None else "`host`"
        ctx.r.error("host-needs-serial", f"{what} talks with the host on the serial line, but the program "
                    "declares no `serial`", decl.span, help=SERIAL_HELP)
    if ctx.host is not None:
        conflicts(ctx)


def _where(name: str, ctx: Context) -> Span:
    """What gives servo `name` its channel: its `channel K`, else its pin."""
    opt = ctx.servo_channels.get(name)
    return opt.span if opt is not None else ctx.decls[name].node.pin.span


def conflicts(ctx: Context) -> None:
    """Two servos on one host channel: an error at the second, naming the first."""
    first: dict[int, str] = {}
    for name, servo in ctx.servos.items():
        if name in ctx.bad_pins and servo.channel_option is None:
            continue                    # its pin was reported; it has no channel to compare
        ch = model.host_channel(servo)
        other = first.get(ch)
        if other is None:
            first[ch] = name
            continue
        other_servo = ctx.servos[other]
        if servo.channel_option is None and other_servo.channel_option is None:
            continue                    # one pin: a pin-conflict, reported already
        how = f"`channel {ch}`" if servo.channel_option is not None else f"its pin {servo.pin}"
        other_how = (f"`channel {ch}`" if other_servo.channel_option is not None
                     else f"its pin {other_servo.pin}")
        ctx.r.error("channel-conflict", f"servo `{name}` is on host channel {ch}, which servo `{other}` already has",
                    _where(name, ctx),
                    help=f"`{other}` has channel {ch} from {other_how} (line {ctx.line(_where(other, ctx))}), "
                         f"`{name}` from {how}; give one of them another with `channel K` (0..31); {CHANNEL_RULE}",
                    secondary=[Label(_where(other, ctx), f"`{other}` is on channel {ch} here")])


def unused(ctx: Context) -> None:
    """`channel K` in a program without `host`: nothing reads it."""
    for name, opt in ctx.servo_channels.items():
        ctx.r.warning("channel-unused", f"`channel` of servo `{name}` has no effect: the program declares no "
                      "`host`", opt.span,
                      help="`channel K` numbers a servo for the host software of `host ssc32` (with "
                           "`serial BAUD`); declare it, or remove the `channel`")
