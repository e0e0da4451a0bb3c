"""`servoc lint` on 1 MB programs, next to lark's own parse of the same text.

    .venv/bin/python benchmarks/lint_scale.py

Three programs of about 1 MB each, all valid:
- `wide poses`: 24 servos and 4,300 poses of 19 entries, one used;
- `short poses`: 1 servo and 44,000 one-entry poses, one used;
- `long main`: the compile-time benchmark's program (24 servos, 50 poses) with
  48,000 moves in `main`.

For each: the wall time of the whole `servoc lint FILE` command (a fresh
process: start-up, parse, check, plan, lint, printing), the lines it prints,
and, in this process, lark parsing the same text with servoc's grammar and
lark's defaults (a parse tree, no positions): the floor for any front end
built on lark. Each time is the median of RUNS runs, all in one run of this
script, so the ratio compares like with like.

A second table shows what pausing Python's cyclic collector buys: in this
process, `api.front_end` (which pauses it) next to the same four stages called
one by one with the collector running, and the objects the collector tracks
once the front end is done.
"""

from __future__ import annotations

import random
import statistics
import gc
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lark import Lark

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api  # noqa: E402
from suite import moves_source  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.resources import grammar_text  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

RUNS = 3
SIZE = 1_000_000


def _servos(k: int) -> list[str]:
    return [f"servo s{i} = P{i // 8}.{i % 8}" for i in range(k)]


def wide_poses(rng: random.Random) -> str:
    lines = _servos(24)
    j = 0
    while sum(map(len, lines)) + len(lines) < SIZE:
        lines.append(f"pose p{j} {{ " + ", ".join(f"s{i}: {rng.randrange(180)}deg" for i in range(19)) + " }")
        j += 1
    return "\n".join(lines + ["main { move p0 in 1s }"]) + "\n"


def short_poses(rng: random.Random) -> str:
    lines = _servos(1)
    j = 0
    while sum(map(len, lines)) + len(lines) < SIZE:
        lines.append(f"pose pose_{j} {{ s0: {rng.randrange(180)}deg }}")
        j += 1
    return "\n".join(lines + ["main { move pose_0 in 1s }"]) + "\n"


def long_main(rng: random.Random) -> str:
    """The compile-time benchmark's program (suite.moves_source), with as many moves as fit 1 MB."""
    per_move = (len(moves_source(2000)) - len(moves_source(1000))) / 1000
    return moves_source(int((SIZE - len(moves_source(0))) / per_move), seed=rng.randrange(1000))


PROGRAMS = (("wide poses", wide_poses), ("short poses", short_poses), ("long main", long_main))


def lint_seconds(path: Path) -> tuple[float, int, int]:
    """Median wall time of `servoc lint PATH` in a fresh process, its exit status and lines printed."""
    times, rc, lines = [], 0, 0
    for _ in range(RUNS):
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "servoc", "lint", str(path)], capture_output=True,
                              text=True, cwd=ROOT, stdin=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
        rc, lines = done.returncode, len((done.stdout + done.stderr).splitlines())
    return statistics.median(times), rc, lines


def lark_seconds(parser: Lark, text: str) -> float:
    times = []
    for _ in range(RUNS):
        t0 = time.perf_counter()
        parser.parse(text)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _stages(source: SourceFile) -> None:
    """parse, check, plan and lint one by one: what `api.front_end` does, with the collector running."""
    reporter = Reporter(source)
    api.lint(api.plan(api.check(api.parse(source, reporter), reporter), reporter), reporter)


def collector_seconds(text: str) -> tuple[float, float, int]:
    """Median seconds of the front end with the collector paused (`api.front_end`) and running
    (the stages one by one), and the objects the collector tracks while its result is alive."""
    source = SourceFile("big.servo", text)
    paused, running = [], []
    for _ in range(RUNS):
        gc.collect()
        t0 = time.perf_counter()
        fe = api.front_end(source, Reporter(source))
        paused.append(time.perf_counter() - t0)
        tracked = len(gc.get_objects())
        del fe
        gc.collect()
        t0 = time.perf_counter()
        _stages(source)
        running.append(time.perf_counter() - t0)
    return statistics.median(paused), statistics.median(running), tracked


def measure() -> list[dict]:
    rng = random.Random(12)
    parser = Lark(grammar_text(), parser="lalr", lexer="contextual")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, make in PROGRAMS:
            text = make(rng)
            path = Path(tmp) / (name.replace(" ", "_") + ".servo")
            path.write_text(text, encoding="utf-8")
            secs, rc, printed = lint_seconds(path)
            floor = lark_seconds(parser, text)
            paused, running, tracked = collector_seconds(text)
            rows.append({"program": name, "bytes": len(text.encode()), "lines": text.count("\n"),
                         "tokens": sum(1 for _ in parser.lex(text)), "lint_exit": rc, "lint_printed_lines": printed,
                         "lint_s": round(secs, 3), "lark_parse_s": round(floor, 3),
                         "ratio": round(secs / floor, 2), "front_end_paused_s": round(paused, 3),
                         "front_end_running_s": round(running, 3), "tracked_objects": tracked})
    return rows


def main() -> int:
    rows = measure()
    print("| program | bytes | lines | tokens | `servoc lint` (s) | lines printed | lark parse alone (s) | ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['program']} | {r['bytes']:,} | {r['lines']:,} | {r['tokens']:,} | {r['lint_s']:.2f} "
              f"(exit {r['lint_exit']}) | {r['lint_printed_lines']} | {r['lark_parse_s']:.2f} | {r['ratio']:.2f} |")
    print()
    print("| program | front end, collector paused (s) | the same stages, collector running (s) | saved | "
          "objects tracked |")
    print("|---|---|---|---|---|")
    for r in rows:
        saved = 1 - r["front_end_paused_s"] / r["front_end_running_s"]
        print(f"| {r['program']} | {r['front_end_paused_s']:.2f} | {r['front_end_running_s']:.2f} | "
              f"{100 * saved:.0f} % | {r['tracked_objects']:,} |")
    return 0 if all(r["lint_exit"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
