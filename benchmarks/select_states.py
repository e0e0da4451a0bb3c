"""Selects one after another, each setting its own servo: lint with the planner's bound on the
states it keeps apart (`plan.MAX_STATES`, 64) and without it, side by side.

    .venv/bin/python benchmarks/select_states.py      # about a minute

`program(k, settle=False)`: six servos, a `move` of all, then a loop of k selects of three
branches, each moving one servo to one of three positions (servo k mod 6), the positions coming
round the loop. Without the bound the planner walks every combination of positions through every
later statement and round the loop (3^min(k,6) states); with it, past 64 states it keeps their
hull. For each k, in this process: the front end's time (parse, check, plan, lint; the least of
three runs) and the shortest period it reports, each way, and the ratio.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api, plan as plan_mod  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

SERVOS = 6


def program(selects: int, fast_last: bool = False, settle: bool = True) -> str:
    """k selects in a loop; `settle`: the loop's pass ends with the move of all (`fast_last`: in 20 ms,
    too fast from some of the combinations), else the positions come round the loop as they are."""
    lines = ["serial 4800"] + [f"servo s{i} = P1.{i} speed 0.05s/60deg" for i in range(SERVOS)]
    for i in range(SERVOS):
        lines += [f"pose p{i}_{v} {{ s{i}: {40 + 60 * v} }}" for v in range(3)]
    lines.append("pose all { " + ", ".join(f"s{i}: 100" for i in range(SERVOS)) + " }")
    lines += ["main {", "  move all in 1s", "  loop {"]
    for j in range(selects):
        i = j % SERVOS
        lines.append(f'    select {{ on "a" {{ move p{i}_0 in 300ms }} on "b" {{ move p{i}_1 in 300ms }} '
                     f'on "c" {{ move p{i}_2 in 300ms }} }}')
    if settle:
        lines.append(f"    move all in {'20ms' if fast_last else '1s'}")
    lines += ["  }", "}"]
    return "\n".join(lines) + "\n"


def lint(text: str, bound: int, runs: int = 3) -> tuple[float, int]:
    """(seconds, the least of `runs`; reported shortest period in µs) of the front end with the
    bound at `bound`."""
    saved = plan_mod.MAX_STATES
    plan_mod.MAX_STATES = bound
    try:
        best = None
        for _ in range(runs):
            source = SourceFile("states.servo", text)
            t0 = time.perf_counter()
            fe = api.front_end(source, Reporter(source))
            seconds = time.perf_counter() - t0
            best = seconds if best is None else min(best, seconds)
        return best, fe.plan.min_period_us
    finally:
        plan_mod.MAX_STATES = saved


def main() -> int:
    print("| selects | states apart | lint, bound 64 (s) | lint, no bound (s) | ratio | shortest P, bound 64 (µs) "
          "| shortest P, no bound (µs) |")
    print("|---|---|---|---|---|---|---|")
    for k in (3, 4, 5, 6, 8):
        bounded, p_bounded = lint(program(k, settle=False), plan_mod.MAX_STATES)
        apart, p_apart = lint(program(k, settle=False), 10 ** 9)
        print(f"| {k} | {3 ** min(k, SERVOS)} | {bounded:.2f} | {apart:.2f} | {apart / bounded:.0f}x "
              f"| {p_bounded} | {p_apart} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
