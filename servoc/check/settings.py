"""Pass 2, settings: `frame` and `target`, once each, before the sequences and `main`."""

from __future__ import annotations

from fractions import Fraction

from .. import nodes
from ..diagnostics import Label
from ..printer import format_quantity
from ..source import Span
from . import quantities
from .context import CHIPS, CLOCK_HZ, Context

TIMING_HELP = "the firmware's timing is built for a 12 MHz 12-clock 8051 (AT89C52, AT89S52 or STC89C52)"


def settings(tree: nodes.Program, ctx: Context) -> None:
    r = ctx.r
    seen: dict[str, nodes.Item] = {}
    used_from: nodes.Item | None = None     # first sequence or main
    for item in tree.items:
        if isinstance(item, (nodes.SequenceDecl, nodes.MainDecl)) and used_from is None:
            used_from = item
        if not isinstance(item, (nodes.FrameDecl, nodes.TargetDecl)):
            continue
        word = "frame" if isinstance(item, nodes.FrameDecl) else "target"
        kw = Span(item.span.start, item.span.start + len(word))
        first = seen.get(word)
        if first is not None:
            r.error("duplicate-setting", f"`{word}` is set more than once", kw,
                    help=f"the first `{word}` is at line {ctx.line(first.span)}; keep only one",
                    secondary=[Label(Span(first.span.start, first.span.start + len(word)), "first set here")])
            continue
        if used_from is not None:
            what = "main" if isinstance(used_from, nodes.MainDecl) else f"sequence {used_from.name.text}"
            r.error("late-setting", f"`{word}` must come before the sequences and `main` that use it",
                    kw, help=f"move it above `{what}` (line {ctx.line(used_from.span)}), "
                             "e.g. to the top of the file")
        seen[word] = item
        if isinstance(item, nodes.FrameDecl):
            ctx.frame_span = item.span
            ctx.frame_us = frame(item, ctx)
        else:
            ctx.target, ctx.clock_hz = target(item, ctx)


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


def target(item: nodes.TargetDecl, ctx: Context) -> tuple[str, int]:
    chip = item.chip.text.lower()
    if chip not in CHIPS:
        ctx.r.error("unsupported-target", f"target `{item.chip.text}` is not supported", item.chip.span,
                    help=TIMING_HELP)
    if item.clock is not None:
        q = item.clock
        hz = ctx.take(quantities.frequency_hz(q, "`clock`", "a clock frequency such as `12MHz`"), q.span)
        if hz is not None and hz != CLOCK_HZ:
            ctx.r.error("unsupported-target", f"clock `{format_quantity(q)}` is not supported; "
                        "only 12MHz is", q.span, help=TIMING_HELP)
    return (chip if chip in CHIPS else item.chip.text), CLOCK_HZ
