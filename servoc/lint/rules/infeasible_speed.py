"""infeasible-speed: |delta| x t_DAV > F x P, the servo cannot get there in time."""

from __future__ import annotations

from ...diagnostics import Severity
from ...diagnostics import Label
from ...source import NO_SPAN
from ...plan import has_selects
from ...steps import branch_head, branch_text, Plan
from ...speed import t_dav_of, too_fast
from ...units import DAV_DEG, fmt_deg, fmt_ms
from .. import Report, rule
from ..common import context_text, whole_ms_for


@rule("infeasible-speed", Severity.ERROR)
def infeasible_speed(plan: Plan, report: Report) -> None:
    """|delta| x t_DAV > F x P: the servo cannot get there in time (`servoc.speed`, the rule the
    plot draws in red).

    In a program with selects, the message also says in which branch and from which state (the
    worst of the states the move can start in), with a label at the branch."""
    reacts = has_selects(plan)
    for excess, inst, ch in too_fast(plan).values():
        m = next(x for x in inst.motions if x.channel == ch)
        ch_ = plan.channels[ch]
        t_dav = t_dav_of(plan, ch)
        need = abs(m.delta) * t_dav
        asked = inst.frames * plan.period_us
        frames_min = plan.speed_tables[ch_.speed_class][abs(m.delta)]
        step = inst.step
        written = fmt_ms(step.duration_us) if step.duration_us is not None else fmt_ms(asked)
        context, secondary = "", ()
        if reacts:
            text = context_text(inst, report.reporter.source)
            context = f", {text}"
            span = branch_head(inst.branch) if inst.branch is not None else \
                inst.origin[2] if inst.origin[0] in ("move", "play") else None
            if span is not None:
                secondary = (Label(span, text if inst.branch is not None else "the state comes from here"),)
        fix = (f"use `in {whole_ms_for(frames_min, plan.period_us, need)}` or longer, or drop the duration "
               f"(`move {step.pose}`) to go as fast as the slowest servo allows")
        if m.cut != NO_SPAN and inst.origin[0] == "host":
            src = report.reporter.source
            context = (f", played by the host (`PL 0 SQ n`) from wherever `host` (line "
                       f"{src.line_col(inst.origin[1].start)[0]}) leaves `{ch_.name}`: N {m.n0} at the farthest")
            secondary = (Label(m.cut, f"`{ch_.name}` can be at N {m.n0} here"),)
            fix += ", or start the sequence with a move without a duration"
        elif m.cut != NO_SPAN:
            src = report.reporter.source
            line = src.line_col(m.cut.start)[0]
            stmt = src.text[m.cut.start:m.cut.end].split("\n")[0].strip()
            if m.merged:
                context += f"; `{ch_.name}` can be at N {m.n0} in them"
            elif inst.origin[0] == "cut":
                sel = f"line {src.line_col(inst.origin[1].start)[0]}"
                who = f"`until {inst.origin[2]}`" if inst.origin[2] is not None else f"an event of the select at {sel}"
                context = ("" if inst.branch is None else f", after `{branch_text(inst.branch)}`") + \
                    f", from where {who} cuts `{stmt}` (line {line}) short with `{ch_.name}` at N {m.n0}"
            else:
                context += f"; an event can cut `{stmt}` (line {line}) short where `{ch_.name}` is at N {m.n0}"
            secondary = secondary + (Label(m.cut, f"`{ch_.name}` can be at N {m.n0} here"),)
            fix += f", or move `{ch_.name}` somewhere nearer N {m.n1} first"
        report(
            f"servo `{ch_.name}` cannot move {abs(m.delta)} DAV ({fmt_deg(abs(m.delta) * DAV_DEG)}) "
            f"in {written} ({inst.frames} frame{'s' if inst.frames != 1 else ''} = {fmt_ms(asked)}){context}: "
            f"at its top speed it needs {fmt_ms(need)}",
            step.span, label=f"too fast for `{ch_.name}`", secondary=secondary,
            help=fix)
