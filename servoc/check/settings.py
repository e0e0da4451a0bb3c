"""Pass 2, settings: `frame`, `target`, `home`, `stagger` and `host`, once each; `frame` and `target`
before the sequences and `main`."""

from __future__ import annotations

import difflib
from fractions import Fraction

from .. import model, nodes
from ..diagnostics import Label
from ..printer import format_quantity
from ..source import Span
from ..syntax import not_a_declaration
from . import quantities
from ..target import CHIPS, DEFAULT_CHIP, chip as find_chip, DEFAULT_CLOCK_HZ, Target, closest, fmt_hz
from .context import Context

def settings(tree: nodes.Program, ctx: Context) -> None:
    r = ctx.r
    seen: dict[str, nodes.Item] = {}
    used_from: nodes.Item | None = None     # first sequence or main
    for item in tree.items:
        if isinstance(item, (nodes.SequenceDecl, nodes.MainDecl)) and used_from is None:
            used_from = item
        if isinstance(item, nodes.SettingDecl):
            if item.word.text not in SETTINGS:
                message, help_ = not_a_declaration(item.word.text)
                r.error("syntax-error", message, item.word.span, help=help_)
                continue
        elif not isinstance(item, (nodes.FrameDecl, nodes.TargetDecl)):
            continue
        word = item.word.text if isinstance(item, nodes.SettingDecl) else \
            "frame" if isinstance(item, nodes.FrameDecl) else "target"
        kw = Span(item.span.start, item.span.start + len(word))
        first = seen.get(word)
        if first is not None:
            r.error("duplicate-setting", f"`{word}` is set more than once", kw,
                    help=f"the first `{word}` is at line {ctx.line(first.span)}; keep only one",
                    secondary=[Label(Span(first.span.start, first.span.start + len(word)), "first set here")])
            continue
        if used_from is not None and word not in SETTINGS:
            what = "main" if isinstance(used_from, nodes.MainDecl) else f"sequence {used_from.name.text}"
            r.error("late-setting", f"`{word}` must come before the sequences and `main` that use it",
                    kw, help=f"move it above `{what}` (line {ctx.line(used_from.span)}), "
                             "e.g. to the top of the file")
        seen[word] = item
        if isinstance(item, nodes.SettingDecl) and word == "host":
            host(item, ctx)
        elif isinstance(item, nodes.SettingDecl):
            power_up(item, ctx)
        elif isinstance(item, nodes.FrameDecl):
            ctx.frame_span = item.span
            ctx.frame_us = frame(item, ctx)
        else:
            ctx.target = target(item, ctx)


# The settings written as a word and a value (`setting_decl`); they may come anywhere.
SETTINGS = ("home", "stagger", "host")


def host(item: nodes.SettingDecl, ctx: Context) -> None:
    """`host PROTOCOL`: one of model.HOSTS (its need of `serial` is the host pass's)."""
    ctx.host_decl = item
    value = item.value
    text = value.text if isinstance(value, nodes.Name) else format_quantity(value)
    if isinstance(value, nodes.Name) and value.text.lower() in model.HOSTS:
        ctx.host = value.text.lower()
        return
    known = ", ".join(f"`{h}`" for h in model.HOSTS)
    close = difflib.get_close_matches(text.lower(), model.HOSTS, n=1, cutoff=0.6)
    if isinstance(value, nodes.Quantity):
        help_ = f"the baud rate has a declaration of its own, `serial {text}`; write `host ssc32` for the protocol"
    else:
        help_ = ((f"did you mean `host {close[0]}`? " if close else "")
                 + "`host ssc32` lets Lynxmotion SSC-32 host software drive the servos")
    ctx.r.error("unsupported-host", f"unknown host protocol `{text}`: servoc speaks {known}", value.span,
                help=help_)


def power_up(item: nodes.SettingDecl, ctx: Context) -> None:
    """`home POSE` (resolved with the poses, later) and `stagger DUR`."""
    word, value = item.word.text, item.value
    if word == "home":
        if not isinstance(value, nodes.Name):
            ctx.r.error("wrong-kind", f"`home` names a pose, not `{format_quantity(value)}`", value.span,
                        help="declare the pose the robot is parked in, e.g. `pose rest { P1: 90deg }`, "
                             "and write `home rest`")
            return
        ctx.home = value
        return
    if isinstance(value, nodes.Name):
        ctx.r.error("bad-stagger", f"`stagger` is a time, not `{value.text}`", value.span,
                    help="write the time between two servos' first pulses, e.g. `stagger 100ms`")
        return
    duration = ctx.take(quantities.duration_us(value, "`stagger`", "a time such as `100ms`"), value.span)
    if duration is not None:
        ctx.stagger_us = duration
        ctx.stagger_span = item.span


def frame(item: nodes.FrameDecl, ctx: Context) -> Fraction | None:
    period = ctx.take(quantities.duration_us(item.period, "`frame`", "a frame period such as `6ms`"),
                      item.period.span)
    if period is None:
        return None
    if period <= 0 or period.denominator != 1:
        ctx.r.error("bad-frame", f"the frame period `{format_quantity(item.period)}` is not a positive whole "
                    "number of microseconds", item.period.span,
                    help="the firmware counts the frame in 1 µs machine cycles; e.g. `frame 6ms`")
        return None
    return period


def target(item: nodes.TargetDecl, ctx: Context) -> Target:
    """The chip, its crystal and its mode; errors name what is known and what works."""
    r = ctx.r
    errors = len(r.diagnostics)
    name = item.chip.text.lower()
    chip = find_chip(name)
    if chip is None:
        why = " (an 8051 without Timer2)" if name in ("at89c51", "at89s51", "at89c2051", "at89c4051", "stc89c51rc") else ""
        r.error("unsupported-target", f"unknown chip `{item.chip.text}`{why}", item.chip.span,
                help="servoc builds for 8052-class chips (Timer2, 256 B RAM): " + ", ".join(closest(name)))
        chip = CHIPS[DEFAULT_CHIP]
    clock = DEFAULT_CLOCK_HZ
    if item.clock is not None:
        q = item.clock
        hz = ctx.take(quantities.frequency_hz(q, "`clock`", "a clock frequency such as `12MHz`"), q.span)
        if hz is not None:
            if hz.denominator != 1:
                r.error("bad-clock", f"clock `{format_quantity(q)}` is not a whole number of hertz", q.span,
                        help="a crystal's frequency is given to the hertz: e.g. `clock 12MHz` or `clock 11.0592MHz`")
            elif not 0 < hz <= chip.max_hz:
                r.error("bad-clock", f"clock `{format_quantity(q)}` is outside what the {chip.display} is rated for",
                        q.span, help=f"the {chip.display} runs from a crystal of up to {fmt_hz(chip.max_hz)}; "
                                     "e.g. `clock 12MHz` or `clock 11.0592MHz`")
            else:
                clock = int(hz)
    six_t = False
    if item.mode is not None:
        word, value = item.mode
        if word.text != "mode":
            r.error("syntax-error", f"expected `mode` after the target, found `{word.text}`", word.span,
                    help="write `target CHIP clock FREQ mode 6T` (or `mode 12T`)")
        elif format_quantity(value).upper() not in ("12T", "6T"):
            r.error("unsupported-target", f"mode `{format_quantity(value)}` is not a machine-cycle mode", value.span,
                    help="`mode 12T` (12 clocks a machine cycle, every 8051) or `mode 6T` (6 clocks, STC89 chips)")
        elif format_quantity(value).upper() == "6T":
            if chip.six_t:
                six_t = True
            else:
                r.error("unsupported-target", f"the {chip.display} has no 6T mode", value.span,
                        help="6T (6 clocks a machine cycle) is a mode of the STC89 chips; drop `mode 6T`")
    result = Target(chip, clock, six_t)
    problem = result.timing_problem()
    if problem is not None and len(r.diagnostics) == errors:
        span = item.clock.span if item.clock is not None else item.span
        r.error("bad-clock", f"the clock is too slow: the firmware cannot be timed on the {result.describe()}",
                span, help=problem)
    return result
