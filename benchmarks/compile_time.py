"""The time `servoc compile` takes: this tree's servoc against another revision's, side by side.

    .venv/bin/python benchmarks/compile_time.py --against REV [--rounds 5]

REV (any git revision of this repository) is checked out in a temporary worktree. For each
program (the examples with servos, and the 24-servo goal program of `engine_terms.py` at 12 MHz
and at 22.1184 MHz), each side builds it in a fresh process, the two sides one after the other in
every round (so both see the same load), with `api.build` (the front end, code generation with its
period search, the assembler and the linker). Printed: each program's best time on each side
and their ratio, and the total's, best of the rounds (5: between two identical trees the ratios stay within 3 %); and whether both sides give the same HEX
(a speed-up that changes the firmware is not one).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from engine_terms import goal_source
from revision import CHILD_HEAD, ROOT, child, worktree

EXAMPLES = ("biped", "pan_tilt", "hexapod", "hexapod_serial", "serial_arm", "ssc32_arm", "greeter",
            "sweep_until_pressed", "stc_board")

# run with the side's servoc (revision.CHILD_HEAD): builds the file, prints the seconds the build
# took and a digest of its HEX
_CHILD = CHILD_HEAD + """
import hashlib, time
from servoc import api
source, reporter = api.load_source(sys.argv[2])
start = time.perf_counter()
fe, fw = api.build(source, reporter)
took = time.perf_counter() - start
print(json.dumps({"seconds": took, "hex": None if fw is None else hashlib.sha256(fw.hex_text.encode()).hexdigest()}))
"""


def programs(tmp: Path) -> list[Path]:
    """The programs timed: the examples named in EXAMPLES, and the goal program written to `tmp`."""
    out = [ROOT / "examples" / f"{name}.servo" for name in EXAMPLES]
    for name, target in (("goal_12MHz", ""), ("goal_22MHz", "target at89c52 clock 22.1184MHz")):
        path = tmp / f"{name}.servo"
        path.write_text(goal_source(target), encoding="utf-8")
        out.append(path)
    return out


def build(tree: Path, program: Path) -> dict:
    return json.loads(child(_CHILD, tree, str(program)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--against", required=True, help="the git revision to compare with")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp_name, worktree(args.against) as other:
        sides = {"this tree": ROOT, args.against: other}
        best: dict[tuple[str, str], float] = {}
        digests: dict[tuple[str, str], str | None] = {}
        timed = programs(Path(tmp_name))
        for _ in range(args.rounds):
            for program in timed:
                for side, tree in sides.items():
                    got = build(tree, program)
                    key = (side, program.stem)
                    best[key] = min(best.get(key, got["seconds"]), got["seconds"])
                    digests[key] = got["hex"]
    names = [p.stem for p in timed]
    print(f"| program | {args.against} (s) | this tree (s) | ratio | same HEX |")
    print("|---|---|---|---|---|")
    for name in names:
        a, b = best[(args.against, name)], best[("this tree", name)]
        same = digests[(args.against, name)] == digests[("this tree", name)]
        print(f"| {name} | {a:.3f} | {b:.3f} | {b / a:.2f} | {'yes' if same else 'NO'} |")
    total_a = sum(best[(args.against, n)] for n in names)
    total_b = sum(best[("this tree", n)] for n in names)
    print(f"| total | {total_a:.3f} | {total_b:.3f} | {total_b / total_a:.2f} | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
