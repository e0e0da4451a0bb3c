"""Worst-case programs for the firmware's frame budget, and the search for the shortest exact P.

A stress program moves every servo on every frame (one-frame moves), so each
frame reads a new move record, computes DDA terms and steps every servo, with
nested repeats and a sequence ending together; with `runtime_f` a move
without duration is played from two different poses, so its F is found at
run time from the frames-needed tables.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from servoc import api, codegen, toolchain  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

PINS = [(p, b) for p in range(3) for b in range(8)]


def stress_source(ports: int, per_port: int, period: int, runtime_f: bool = False, depth: int | None = None) -> str:
    pins = [(p, b) for p in range(ports) for b in range(per_port)]
    lines = [f"frame {period}us"]
    speed = "" if runtime_f else " speed 0.001s/60deg"
    for i, (p, b) in enumerate(pins):
        lines.append(f"servo s{i} = P{p}.{b}{speed}")
    low = ", ".join(f"s{i}: {(7 * i) % 40}" for i in range(len(pins)))
    high = ", ".join(f"s{i}: {250 - (11 * i) % 40}" for i in range(len(pins)))
    far = ", ".join(f"s{i}: {240 + i % 10}" for i in range(len(pins)))
    lines += [f"pose lo {{ {low} }}", f"pose hi {{ {high} }}", f"pose far {{ {far} }}"]
    if runtime_f:
        # `move far` is entered from `lo` and from `hi`: its F is found at run time
        lines += ["sequence go { move far }", "main {", "  loop {",
                  "    move lo in 700ms", "    play go", "    move hi in 100ms", "    play go", "  }", "}"]
    elif depth is not None:
        # `depth` repeats all ending after the same frame, then all starting again
        body = [f"move hi in {period}us", f"move lo in {period}us"]
        for _ in range(depth):
            body = ["repeat 1 {"] + body + ["}"]
        lines += ["main {", "  loop {"] + body + ["  }", "}"]
    else:
        # every frame a new one-frame move: record, DDA terms and a step for every servo
        lines += ["sequence step {", "  repeat 2 { repeat 2 {", f"    move hi in {period}us",
                  f"    move lo in {period}us", "  } }", "}", "main {", "  loop {",
                  "    repeat 3 { play step }", "  }", "}"]
    return "\n".join(lines) + "\n"


def _plan(ports: int, per_port: int, period: int, runtime_f: bool, depth: int | None):
    text = stress_source(ports, per_port, period, runtime_f, depth)
    source = SourceFile("stress.servo", text)
    reporter = Reporter(source)
    tree = api.parse(source, reporter)
    program = api.check(tree, reporter)
    return source, api.plan(program, reporter)


def budget_period(ports: int, per_port: int, runtime_f: bool = False, depth: int | None = None,
                  period: int = 20000) -> int:
    """The shortest P servoc's frame budget allows for the stress program (planned at `period`)."""
    return _plan(ports, per_port, period, runtime_f, depth)[1].min_period_us


def exact_at(ports: int, per_port: int, period: int, runtime_f: bool = False, frames: int = 400,
             depth: int | None = None) -> bool:
    """Build the stress program at `period` (the budget bypassed) and verify it in ucsim."""
    source, plan = _plan(ports, per_port, period, runtime_f, depth)
    unit = codegen.generate(plan, source)
    assert bool(unit.fneed_pages) == runtime_f
    image = toolchain.assemble(unit.text, name="stress")
    return api.verify_hex(plan, image.hex_text, frames).ok


def shortest_exact_period(ports: int, per_port: int, runtime_f: bool = False, depth: int | None = None) -> int:
    """Binary search of the shortest P (us) at which the stress program verifies exactly."""
    lo = codegen.PORT_CYCLES * ports          # never enough: no time between frames
    hi = lo + 8000
    assert exact_at(ports, per_port, hi, runtime_f, depth=depth), "stress program fails even with a long frame"
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if exact_at(ports, per_port, mid, runtime_f, depth=depth):
            hi = mid
        else:
            lo = mid
    return hi


if __name__ == "__main__":
    for ports, per_port in [(1, 1), (1, 4), (1, 8), (2, 8), (3, 1), (3, 8)]:
        for rf in (False, True):
            p = shortest_exact_period(ports, per_port, rf)
            print(f"ports={ports} servos={ports * per_port:2d} runtime_f={rf!s:5}: shortest exact P = {p} us, "
                  f"between frames {p - codegen.PORT_CYCLES * ports} cycles", flush=True)
