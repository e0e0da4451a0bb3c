"""Run the benchmark suite: print one markdown table, write the results as JSON.

    .venv/bin/python benchmarks/run.py            # full run, about half an hour
    .venv/bin/python benchmarks/run.py --quick    # reduced run, about two minutes

See benchmarks/suite.py for what is reported, benchmarks/baselines.py and
benchmarks/budget.py for how it is measured.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import suite

BENCH_DIR = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="fewer search points and smaller programs (about two minutes)")
    ap.add_argument("--json", metavar="PATH",
                    help="where to write the results (default: benchmarks/results.json, "
                         "benchmarks/results_quick.json with --quick)")
    args = ap.parse_args(argv)
    out = args.json or str(BENCH_DIR / ("results_quick.json" if args.quick else "results.json"))

    def progress(text: str) -> None:
        print(f"[bench] {text}", file=sys.stderr, flush=True)

    results = suite.run_all(args.quick, progress)
    print(suite.table(results))
    print(f"\n{results['mode']} run: {results['seconds']} s; results in {out}")
    with open(out, "w", encoding="utf-8") as f:
        json.dump(results, f, indent=2)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
