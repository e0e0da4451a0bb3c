"""servoc import, measured: frames in, moves out, the largest deviation, and the time per format.

    .venv/bin/python benchmarks/import_scale.py

1. The examples in `examples/import/` (one file per format): source frames, moves
   written, the largest deviation in N at a source frame, and the time to import.
2. A 10,000-frame animation in each format, made here: three servos on smooth
   curves (sines of different periods, a slow triangle sweep and still stretches), as a
   Maestro sequence of 10,000 frames of 33 ms, a Blender JSON at 30 fps, a
   Bottango export whose curves last 10,000 frames of the firmware, and a CSV of
   10,000 rows. The time is `api.import_motion` (read, fit, write the text); the
   lint of the written program is timed apart.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

FRAMES = 10_000
FPS = 30


def curves(k: int, fps: int = FPS) -> tuple:
    t = k / fps
    return (round(1500 + 400 * math.sin(2 * math.pi * t / 8)),
            round(1500 + 250 * math.sin(2 * math.pi * t / 3 + 1)),
            1900 if (k // 600) % 2 else round(1100 + 800 * abs((k % 600) / 300 - 1)))


def maestro(path: Path) -> None:
    channels = "\n".join(f'    <Channel name="s{i}" mode="Servo" min="3968" max="8000" homemode="Off" home="0" '
                         f'speed="0" acceleration="0" neutral="6000" range="1905" />' for i in range(3))
    frames = "\n".join(f'      <Frame name="Frame {k}" duration="33">{" ".join(str(4 * v) for v in curves(k))}</Frame>'
                       for k in range(FRAMES))
    path.write_text(f'<UscSettings version="1">\n  <Channels ServosAvailable="6" ServoPeriod="156">\n{channels}\n'
                    f'  </Channels>\n  <Sequences>\n    <Sequence name="long">\n{frames}\n    </Sequence>\n'
                    f'  </Sequences>\n</UscSettings>\n')


def blender(path: Path) -> None:
    positions = [{str(i): v for i, v in enumerate(curves(k))} for k in range(FRAMES)]
    path.write_text(json.dumps({"description": "benchmark", "fps": FPS, "frames": FRAMES, "seconds": FRAMES // FPS,
                                "bones": 3, "file": "bench.blend", "scene": "Scene", "positions": positions}))


def bottango(path: Path) -> None:
    # three servos, 1000..2000 us; each curve 400 ms between alternating ends, eased by its control points
    period_ms = 5.3
    total = int(FRAMES * period_ms)
    lines = [f"rSVPin,{p},1000,2000,3000,1500\\n" for p in (0, 1, 2)]
    cmds = []
    for pin, length in ((0, 400), (1, 700), (2, 1300)):
        y = 4096
        for start in range(0, total, length):
            end_y = 1000 if y > 4096 else 7000
            cmds.append(f"sC,{pin},{start},{length},{y},{length // 3},0,{end_y},{-(length // 3)},0\\n")
            y = end_y
    chunks = [cmds[i:i + 40] for i in range(0, len(cmds), 40)]
    body = "\n".join(f'const char ANIM_0_DATA{i}[] PROGMEM = "{"".join(c)}";' for i, c in enumerate(chunks))
    path.write_text(f'// Animation Index Key:\n// 0: long\nconst char SETUP_DATA_0[] PROGMEM = "{"".join(lines)}";\n'
                    f'// animation 0, "long"\n{body}\n')


def csv(path: Path) -> None:
    rows = ["time_ms,a,b,c"] + [f"{round(1000 * k / FPS, 3)},{','.join(map(str, curves(k)))}" for k in range(FRAMES)]
    path.write_text("\n".join(rows) + "\n")


def measure(path: Path, extra: dict | None = None) -> dict:
    from servoc.imports.keyframes import ReadOptions
    started = time.perf_counter()
    imported = api.import_motion(str(path), None, {}, ReadOptions(**(extra or {})))
    took = time.perf_counter() - started
    source = SourceFile(path.stem + ".servo", imported.text)
    reporter = Reporter(source)
    started = time.perf_counter()
    api.front_end(source, reporter)
    lint = time.perf_counter() - started
    return {"format": api.read_motion(str(path))[0], "file": path.name, "frames_in": imported.frames_in,
            "moves_out": imported.moves_out, "deviation": imported.deviation, "import_s": took, "lint_s": lint,
            "errors": sum(d.is_error for d in reporter.diagnostics)}


def table(rows: list) -> str:
    out = ["| format | file | frames in | moves out | frames per move | largest deviation | import | lint | errors |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['format']} | {r['file']} | {r['frames_in']:,} | {r['moves_out']:,} | "
                   f"{r['frames_in'] / max(1, r['moves_out']):.1f} | {r['deviation']} N | {r['import_s'] * 1000:.0f} ms | "
                   f"{r['lint_s'] * 1000:.0f} ms | {r['errors']} |")
    return "\n".join(out)


def main() -> None:
    examples = sorted(p for p in (ROOT / "examples" / "import").iterdir() if p.suffix in (".csv", ".xml", ".json", ".cpp"))
    print("## The examples\n")
    print(table([measure(p) for p in examples]))
    print(f"\n## {FRAMES:,}-frame animations\n")
    with tempfile.TemporaryDirectory() as tmp:
        rows = []
        for make, name in ((maestro, "long.xml"), (blender, "long.json"), (bottango, "long.cpp"), (csv, "long.csv")):
            path = Path(tmp) / name
            make(path)
            rows.append(measure(path))
        print(table(rows))
    print("\nlint: parse, check, plan and every lint rule of the written program; errors: what it reports "
          "(speed errors are the source's, written for the user to fix).")


if __name__ == "__main__":
    main()
