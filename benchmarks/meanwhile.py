"""Reacting while moving, measured: press latency in ucsim, and how the interruption check scales.

    .venv/bin/python benchmarks/meanwhile.py

1. Latency. `examples/sweep_until_pressed.servo` (P = 10 ms) is run in ucsim once
   without a press and then with one press at each of 24 times: eight phases of
   the frame (0, P/8, ... 7P/8 after a frame's first rise) at three places in the
   sweep (early in a move, mid-move, and in a move's last frame). For each press:
   the time from the press to the first rise of the `on press` branch
   (`verify.event_delays`), and to the first pulse whose width differs from the
   run without a press (the sweep stops where it is). Every run is verified.
2. Scaling. `servoc lint` (parse, check, plan, every lint rule) of a program whose
   meanwhile body is (a) a `repeat` of two moves, 100 to 100,000 frames, and (b)
   a flat list of distinct moves, 1,000 to 100,000 frames: the check takes one
   state per select and entry state (per servo the farthest position), so (a)
   stays flat and (b) grows with the program's text, not its frames; a brute
   force would test the branch's move from every frame.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import serial_line  # noqa: E402
from servoc import api, events, verify  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

SWEEP = ROOT / "examples" / "sweep_until_pressed.servo"
PHASES = 8


def build(text: str):
    fe, firmware, reporter = serial_line.build(text)
    assert firmware is not None, [d.message for d in reporter.diagnostics if d.is_error]
    return fe.plan, firmware


def pulses(plan, trace) -> list[tuple[int, tuple]]:
    """(rise cycle, width per servo or None) of each frame, from the pin edges (the servos share a
    port, so their lines rise together)."""
    widths: dict[int, dict[int, int]] = {}
    for k, s in enumerate(plan.program.servos):
        edges = trace.pin_edges(s.port, s.bit)
        for i, (c, level) in enumerate(edges[:-1]):
            if level == 1:
                widths.setdefault(c, {})[k] = edges[i + 1][0] - c
    n = len(plan.program.servos)
    return [(c, tuple(widths[c].get(k) for k in range(n))) for c in sorted(widths)]


def run(plan, firmware, scenario: str, frames: int):
    evs = events.parse(scenario, plan.program.inputs, plan.program.serial is not None)
    stim = api.stimulus(plan, evs)
    trace = api.simulate(firmware.hex_text, max(api.cycles_needed(plan, frames), stim.last() + 1),
                         plan.program.target, stim, api.probes(firmware))
    return evs, trace


def latency() -> list[str]:
    plan, firmware = build(SWEEP.read_text(encoding="utf-8"))
    target = plan.program.target
    us = float(target.cycle_us)
    frames = 600
    _, quiet = run(plan, firmware, "", frames)
    base = pulses(plan, quiet)
    t1 = verify.first_rise_us(plan, quiet)
    period = plan.period_us
    # frames from the first pulse: the sweep's first move starts after the start-up; a move of
    # 1.5 s is 150 frames: early (its 10th frame), mid (its 75th), last (its 150th)
    first_move = next(k for k in range(1, len(base)) if None not in base[k - 1][1] and base[k][1] != base[k - 1][1])
    places = {"early": first_move + 160, "mid": first_move + 225, "last frame": first_move + 299}
    rows = ["| where in the sweep | phase of the frame | press to branch's first rise | press to first changed pulse | verify |",
            "|---|---|---|---|---|"]
    branch_delays, change_delays = [], []
    for place, frame in places.items():
        for j in range(PHASES):
            at = t1 + frame * period + j * period / PHASES
            scenario = f"{at / 1e6:.6f}s button active\n{at / 1e6 + 0.2:.6f}s button inactive\n"
            evs, trace = run(plan, firmware, scenario, frames)
            report = api.check_events(plan, trace, frames, evs)
            found = [d for text, _, d in verify.event_delays(plan, trace, evs) if "press" in text]
            got = pulses(plan, trace)
            changed = next(c for (c, w), (_, w0) in zip(got, base) if w != w0)
            d_branch = found[0] if found else float("nan")
            d_change = changed * us - at
            branch_delays.append(d_branch)
            change_delays.append(d_change)
            rows.append(f"| {place} | {j}/{PHASES} P | {d_branch / 1000:.2f} ms | {d_change / 1000:.2f} ms | "
                        f"{'OK' if report.ok else 'FAILED'} |")
    rows.append("")
    rows.append(f"P = {period / 1000:g} ms. Press to the branch's first rise: {min(branch_delays) / 1000:.2f} to "
                f"{max(branch_delays) / 1000:.2f} ms ({min(branch_delays) / period:.2f} P to "
                f"{max(branch_delays) / period:.2f} P; the spec allows 2 P). Press to the first changed pulse: "
                f"{min(change_delays) / 1000:.2f} to {max(change_delays) / 1000:.2f} ms.")
    return rows


# 100,000 frames of distinct moves are some 20 KB of moves: a chip with 32 KB of code memory
HEAD = ("target stc89c58rd clock 12MHz\nframe 10ms\nservo pan = P2.0\nservo tilt = P2.1\ninput button = P3.2\n"
        "pose rest { pan: 122, tilt: 122 }\npose left { pan: 118, tilt: 120 }\npose right { pan: 126, tilt: 120 }\n")


def repeated(frames: int) -> str:
    return HEAD + (f"home rest\nmain {{\n  select {{\n    on button {{ move rest in 600ms }}\n    meanwhile {{\n"
                   f"      repeat {frames // 4} {{\n        move left in 20ms\n        move right in 20ms\n      }}\n"
                   f"    }}\n  }}\n}}\n")


def flat(frames: int) -> str:
    """Moves of 10 frames to poses a step or so apart: frames / 10 distinct moves."""
    count = frames // 10
    poses = "".join(f"pose q{i} {{ pan: {100 + i % 40}, tilt: {110 + i % 20} }}\n" for i in range(count))
    body = "".join(f"      move q{i} in 100ms\n" for i in range(count))
    return HEAD + poses + (f"home rest\nmain {{\n  select {{\n    on button {{ move rest in 600ms }}\n    meanwhile {{\n"
                           f"{body}    }}\n  }}\n}}\n")


def lint_seconds(text: str) -> tuple[float, bool]:
    source = SourceFile("bench.servo", text)
    reporter = Reporter(source)
    t0 = time.perf_counter()
    fe = api.front_end(source, reporter)
    if fe.plan is not None:
        api.lint(fe.plan, reporter)
    took = time.perf_counter() - t0
    return took, fe.plan is not None and not reporter.has_errors


def scaling() -> list[str]:
    lint_seconds(repeated(100))         # the grammar and the templates loaded once, not in the first row
    rows = ["| meanwhile body | frames | program bytes | lint | time / the smallest's | bytes / the smallest's |",
            "|---|---|---|---|---|---|"]
    for name, make, sizes in (("repeat of two moves", repeated, (100, 1_000, 10_000, 100_000)),
                              ("distinct moves", flat, (1_000, 10_000, 100_000))):
        first = None
        for frames in sizes:
            text = make(frames)
            took, ok = lint_seconds(text)
            assert ok, name
            first = first or (took, len(text))
            rows.append(f"| {name} | {frames:,} | {len(text):,} | {took * 1000:.1f} ms | {took / first[0]:.1f} | "
                        f"{len(text) / first[1]:.1f} |")
    return rows


def main() -> int:
    print("## Press latency (examples/sweep_until_pressed.servo in ucsim)\n")
    print("\n".join(latency()))
    print("\n## The interruption check's time\n")
    print("\n".join(scaling()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
