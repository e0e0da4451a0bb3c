"""24 moving servos: which term of the frame budget bounds the shortest period, at three clocks.
(22.1184 MHz on two chips: the AT89C52, whose 256 bytes of RAM hold the build with each port's rise
among the falls of the port before but not the one with the ports at once; and the STC89C52RC,
whose XRAM takes the motion state for that build.)

    .venv/bin/python benchmarks/engine_terms.py           # over 150 frames
    .venv/bin/python benchmarks/engine_terms.py --quick   # over 60 frames

The program (`goal_source`): 24 servos on P0, P1 and P2, every other one slower (two speed
classes), moving between two poses that put every port's lines over the full range (N 0 and 250
in the same frame, the others 36 apart), an eased move and a linear one, in a loop. For each
clock, from one budget read from the code generated at the shortest period servoc reports
(`costs.Budget`; the program's own 20 ms gives its moves F of one byte, which that period does
not: `api._least_period`), side by side:

- the shortest period servoc reports (`Plan.min_period_us`) and the shortest from which the
  firmware, built with `frame` at each P (the budget bypassed), verifies exactly in ucsim at every
  P up to the reported one (`budget.holds_down_to`: every us; where the reported P is more than
  1 % above the pulses' term, every 8 us down to a failure, then every us above it);
  and, side by side at 12 MHz, the build servoc does not choose there, the ports pulsed one after
  another (rises as steps);
- the pulses' term: the sum of the ports' spans: each port's longest pulse and a step to the
  next port's rise; where the build has rises among falls (at 22.1184 MHz and 6T at least 7
  cycles from every fall, at 12 MHz beside one) each port after the first rises among the falls of
  the port before it, its span that port's longest pulse less C(0) and the handler's run that
  takes the rising port's edges (the last port's pulses whole);
- the CPU's term: everything the frame's cycles must hold whatever the order of the ports'
  pulses: the work between two frames (W), the ports' sorts, the edge handler's rise entries
  (with the writing of each port's items; with rises among falls the rise's edge and the
  handover, the items being written by the program after each sort) and its falls in the worst
  frame, each fall an entry of its own when it is SPLIT cycles or more from the one before.

With the ports at once (`codegen.can_merge`), the pulses' term is the longest pulse, the last
group's run of the handler and the part of frame_io's merging of the ports' lists that must come
before the next rise (Budget.tail, `costs.merged_late`), and the CPU's term counts the whole
merging with the sorts.

The pulses' term is what overlapping the ports' pulses removes; the CPU's term stays. Where it
is above a goal, no order of the pulses reaches that goal with this handler and this work.
"""

from __future__ import annotations

import argparse
import sys

from budget import BEFORE_KEY, build_unchecked, exact, exact_with_bytes, holds_below, plan_text
from servoc import api, costs

CLOCKS = (("12 MHz", ""), ("22.1184 MHz, AT89C52", "target at89c52 clock 22.1184MHz"),
          ("22.1184 MHz, STC89C52RC", "target stc89c52rc clock 22.1184MHz"),
          ("11.0592 MHz 6T, STC89C52RC", "target stc89c52rc clock 11.0592MHz mode 6T"),
          ("22.1184 MHz, STC89C52RC, serial 14400 (bytes back to back)", "target stc89c52rc clock 22.1184MHz\nserial 14400"))
# at 12 MHz, side by side, the build servoc does not choose there: the ports one after another
APART = ("12 MHz, ports one after another", "", {"stepping": True, "stagger": False})
STEP = 8        # where the reported P is over 1 % above the pulses' term: every STEP us down to a failure
LOW = (0, 250, 36, 72, 108, 144, 180, 216)      # each port's lines: N 0 and N 250 in one frame


def goal_source(target: str, period_us: int | None = None) -> str:
    lines = [target] if target else []
    lines.append(f"frame {period_us}us" if period_us else "frame 20ms")
    for i in range(24):
        slow = " speed 0.3s/60deg" if i % 2 else ""
        lines.append(f"servo s{i} = P{i // 8}.{i % 8}{slow}")
    a = ", ".join(f"s{i}: {LOW[i % 8]}" for i in range(24))
    b = ", ".join(f"s{i}: {250 - LOW[i % 8]}" for i in range(24))
    lines += [f"pose a {{ {a} }}", f"pose b {{ {b} }}", "main {", "  loop {",
              "    move a in 1200ms ease in-out", "    move b in 1200ms", "  }", "}"]
    return "\n".join(lines) + "\n"


def terms(target_line: str, build: dict | None = None) -> dict:
    """The terms of the build servoc chooses, built at the shortest period it reports (`build`
    given: of that build, codegen.generate's, at the program's own 20 ms)."""
    _, plan = plan_text(goal_source(target_line), "goal")
    if build is None:       # the code at the reported P (its records' F can differ from 20 ms's)
        _, plan = plan_text(goal_source(target_line, plan.min_period_us), "goal")
    unit = api.codegen.generate(plan, **(build or {}))
    target, budget = plan.program.target, unit.budget
    us = lambda cycles: round(cycles * target.cycle_us)     # noqa: E731
    rises = sum(budget.rises)
    cpu = budget.work + sum(budget.sorts) + budget.merge + costs.frame_load(budget)
    pulses = (target.width_cycles(max(budget.tops)) + budget.tail + costs.merged_late(target, budget)
              if budget.merged else sum(budget.spans))
    return {"reported_us": unit.min_period_us if build else plan.min_period_us, "pulses_us": us(pulses),
            "cpu_us": us(cpu), "cpu_cycles": cpu, "work": budget.work, "sorts": sum(budget.sorts) + budget.merge,
            "rises": rises, "falls": costs.frame_falls(budget), "build": "at once" if budget.merged else
            "overlapping" if budget.stagger else "one after another"}


def exact_period(target_line: str, reported: int, frames: int, build: dict | None = None, step: int = 1) -> int:
    """The shortest P from which every P up to the reported one verifies exactly (`holds_down_to`:
    every `step` us down to a failure, then every us above it)."""
    def ok(p: int) -> bool:
        plan, fw = build_unchecked(goal_source(target_line, p), "goal", build)
        if plan.program.serial is None:
            return exact(plan, fw, frames)
        return exact_with_bytes(plan, fw, max(frames, sum(m.frames for m in plan.moves) + 2), back_to_back=True)
    return holds_below(ok, reported, step)


def goal_rows(frames: int = 60, progress=None) -> list[dict]:
    """Each clock's row (and the ports one after another at 12 MHz): the terms of its build, and
    the shortest P from which every P up to the reported one verifies exactly in ucsim (to STEP us
    where the reported P is more than 1 % above the pulses' term), over `frames` frames."""
    say = progress or (lambda s: None)
    rows = []
    for name, line, build in [(name, line, None) for name, line in CLOCKS] + [APART]:
        say(f"shortest exact P, the goal program, {name}")
        t = terms(line, build)
        step = STEP if t["reported_us"] > 1.01 * t["pulses_us"] else 1
        p = exact_period(line, t["reported_us"], frames, build, step)
        rows.append({"clock": name, **t, "shortest_exact_p_us": p, "resolution_us": step,
                     "difference_us": t["reported_us"] - p, BEFORE_KEY: (goal_source(line), True)})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="verify over 60 frames, not 150")
    args = ap.parse_args(argv)
    print("| clock | ports pulse | reported P (us) | exact P in ucsim (us) | pulses' term (us) | CPU's term (us) "
          "| W | sorts (and merging) | rise entries | falls (cycles) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for t in goal_rows(60 if args.quick else 150):
        step, p = t["resolution_us"], t["shortest_exact_p_us"]
        p = f"{p} (to {step} us)" if step > 1 else p
        print(f"| {t['clock']} | {t['build']} | {t['reported_us']} | {p} | {t['pulses_us']} | {t['cpu_us']} ({t['cpu_cycles']} cycles) "
              f"| {t['work']} | {t['sorts']} | {t['rises']} | {t['falls']} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
