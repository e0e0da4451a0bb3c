"""How long `servoc verify` takes for 60 s of a 24-servo program, and what watching the firmware
costs, measured side by side in one run:

    .venv/bin/python benchmarks/verify_time.py

Three runs of the same 60 s (12 MHz, serial 4800, a select in a loop answering a byte every
0.5 s): ucsim alone with the events (no probes, nothing checked), ucsim with verify's probes
(`api.simulate` with `api.probes`), and the whole check (`servoc verify --events`, as a user
runs it: simulation, observation, the plan of the run, every pulse and byte compared). The
ratios are against ucsim alone.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api, events  # noqa: E402
from servoc.cli import main as cli  # noqa: E402

SECONDS = 60


def program() -> str:
    pins = [(p, b) for p in (1, 2, 0) for b in range(8)]
    text = "serial 4800\n" + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p, b in pins)
    text += "pose lo { " + ", ".join(f"s{p}{b}: {20 + 9 * b}" for p, b in pins) + " }\n"
    text += "pose hi { " + ", ".join(f"s{p}{b}: {200 - 9 * b}" for p, b in pins) + " }\n"
    text += ('main {\n  move lo in 500ms\n  loop {\n    select {\n      on "h" { move hi in 450ms; send "H" }\n'
             '      on "l" { move lo in 450ms; send "L" }\n    }\n  }\n}\n')
    return text


def scenario() -> str:
    return "".join(f'{500 + 500 * k}ms "{"hl"[k % 2]}"\n' for k in range((SECONDS - 1) * 2))


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        prog, evfile = Path(tmp) / "p.servo", Path(tmp) / "p.events"
        prog.write_text(program())
        evfile.write_text(scenario())
        source, reporter = api.load_source(str(prog))
        fe, fw = api.build(source, reporter)
        plan = fe.plan
        evs = events.parse(scenario(), plan.program.inputs, True)
        stim = api.stimulus(plan, evs)
        cycles = plan.program.target.cycles(SECONDS * 1_000_000)
        timings = {}
        t = time.perf_counter()
        api.simulate(fw.hex_text, cycles, plan.program.target, stim)
        timings["ucsim alone"] = time.perf_counter() - t
        t = time.perf_counter()
        trace = api.simulate(fw.hex_text, cycles, plan.program.target, stim, api.probes(fw))
        timings["ucsim with the probes"] = time.perf_counter() - t
        frames = cycles // plan.program.target.cycles(plan.period_us) - 100
        t = time.perf_counter()
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            rc = cli(["verify", str(prog), "--events", str(evfile), "--frames", str(frames)])
        timings["servoc verify --events"] = time.perf_counter() - t
    looks = sum(len(v.looks) for v in trace.observation.visits)
    print(f"24 servos, 12 MHz, P = {plan.period_us} µs, {SECONDS} s simulated, {len(evs)} bytes from the host, "
          f"{len(trace.observation.visits)} selects reached, {looks} looks watched")
    print(f"verify: {out.getvalue().splitlines()[0]}")
    print("| run | seconds | ratio |")
    print("|---|---|---|")
    base = timings["ucsim alone"]
    for what, secs in timings.items():
        print(f"| {what} | {secs:.1f} | {secs / base:.2f} |")
    return rc


if __name__ == "__main__":
    sys.exit(main())
