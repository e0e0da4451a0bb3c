"""Each port's span (`costs.fit_spans`) against a span of N 250 for every port, for the examples.

    .venv/bin/python benchmarks/spans.py

For each program in examples/ (and at 11.0592 MHz and 22.1184 MHz for those with a default
target), side by side from one budget read from its generated code: the shortest period servoc
reports, and the one the same code would get if every port's span held a pulse of N 250 (the
engine before per-port spans); then the program built with `frame` at the reported shortest
period runs in ucsim and `servoc verify` checks every pulse to the machine cycle.
"""

from __future__ import annotations

import dataclasses
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api, costs  # noqa: E402
from servoc.flow import port_tops  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

CLOCKS = ("", "target stc89c52rc clock 11.0592MHz", "target at89c52 clock 22.1184MHz")


def front(text: str, name: str):
    source = SourceFile(name, text)
    reporter = api.Reporter(source)
    return source, reporter, api.front_end(source, reporter)


def row(name: str, text: str) -> str | None:
    _, _, fe = front(text, name)
    if fe.plan is None or fe.plan.firmware_limit:
        return None
    unit = api.codegen.generate(fe.plan)
    target, budget = fe.plan.program.target, unit.budget
    full = target.us_at_least(costs.frame_cycles(target, dataclasses.replace(budget, spans=())))
    now = fe.plan.min_period_us
    at_min = re.sub(r"^frame .*$", "", text, flags=re.M)
    source, reporter, fe2 = front(f"frame {now}us\n" + at_min, name)
    fe2, firmware = api.build(source, reporter)
    if firmware is None:
        checked = "not built: " + "; ".join(d.code for d in reporter.diagnostics if d.is_error)
    else:
        report = api.verify(fe2.plan, firmware, 120)
        checked = "exact" if report.ok and report.max_error_cycles == 0 else f"FAILED: {report.summary()}"
    tops = ", ".join(f"P{p} {t}" for p, t in zip(fe.plan.ports, port_tops(fe.plan)))
    return (f"| {name} | {target.describe()} | {tops} | {full} | {now} | {now / full:.2f} | {checked} |")


def main() -> int:
    print("| program | target | highest N per port | shortest P, every span N 250 (us) "
          "| shortest P, spans fitted (us) | ratio | at that P in ucsim |")
    print("|---|---|---|---|---|---|---|")
    for path in sorted((ROOT / "examples").glob("*.servo")):
        text = path.read_text(encoding="utf-8")
        has_target = re.search(r"^target ", text, re.M) is not None
        for clock in CLOCKS if not has_target else ("",):
            line = row(path.name, (clock + "\n" + text) if clock else text)
            if line:
                print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
