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
3. Maestro timing: for each frame of `examples/import/wave.xml` and of a file whose
   channels have speeds, when the Maestro starts it and when its pulse reaches the
   frame's targets (at the channel's speed; at once for speed 0, where the servo then
   needs its own travel time), against when the firmware's pulses reach them (from
   the program's planned frames: what `servoc verify` checks in ucsim).
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


SPEEDS_XML = """<UscSettings version="1"><Channels ServosAvailable="6" ServoPeriod="156">
<Channel name="pan" mode="Servo" min="3968" max="8000" homemode="Goto" home="6000" speed="20" acceleration="0" />
<Channel name="tilt" mode="Servo" min="3968" max="8000" homemode="Goto" home="6000" speed="0" acceleration="0" />
</Channels><Sequences><Sequence name="look">
<Frame name="Frame 0" duration="1500">8000 7000</Frame>
<Frame name="Frame 1" duration="2200">4000 5000</Frame>
<Frame name="Frame 2" duration="1200">6000 6000 s 40 10</Frame>
<Frame name="Frame 3" duration="100">6000 8000</Frame>
<Frame name="Frame 4" duration="500">6000 6000</Frame>
</Sequence></Sequences></UscSettings>
"""


def maestro_timing(path: Path) -> list:
    """Per frame: (source, Maestro start ms, Maestro pulse at target ms, servo travel ms, servoc pulse at
    target ms), times from the start of `main`."""
    from servoc.imports.keyframes import ReadOptions
    from servoc.imports.write import DIV_US, t_dav_us
    from servoc.plan import expand
    from servoc.units import width_to_n
    fmt, kf = api.read_motion(str(path), None, ReadOptions())
    imported = api.import_motion(str(path))
    source = SourceFile(path.stem + ".servo", imported.text)
    fe = api.front_end(source, Reporter(source))
    plan, p = fe.plan, fe.plan.period_us
    names = [c.name for c in plan.channels]
    frames = [f.n for _, f in zip(range(plan.total_frames), expand(plan))]
    home = 1 if any(c.home_us is not None for c in kf.channels) else 0
    channel = {c.index: c for c in kf.channels}
    index = {c.index: names.index(n) for c in kf.channels for n in names if n == (c.name or f"ch{c.index}")}
    where = {c.index: (width_to_n(c.home_us) if c.home_us is not None else None) for c in kf.channels}
    servo = {s.name: s for s in fe.program.servos}
    limits = {c.index: servo[names[index[c.index]]].limit or (0, 250) for c in kf.channels if c.index in index}
    rows, begun = [], 0
    for track in kf.tracks:
        for key in track.keys:
            targets = {ch: width_to_n(w) for ch, w in key.targets.items() if ch in index}
            if not targets:
                continue
            start = begun + key.at_ms
            pulse, travel = start, 0.0
            for ch, n in targets.items():
                if where[ch] is None:
                    continue
                v = (key.speeds or {}).get(ch) if key.speeds is not None else channel[ch].speed_us_s
                delta = abs(n - where[ch])
                if v:
                    pulse = max(pulse, start + delta * DIV_US * 1000 / v)
                travel = max(travel, delta * float(t_dav_us(channel[ch])) / 1000)
            first = home + round(float(start) * 1000 / p)
            # the program's targets: the source's, clamped into the servo's limit (rounded inward)
            targets = {ch: min(max(n, limits[ch][0]), limits[ch][1]) for ch, n in targets.items()}
            got = next((i for i in range(first, len(frames))
                        if all(frames[i][index[ch]] == n for ch, n in targets.items())), None)
            rows.append((key.source, float(start), float(pulse), travel,
                         None if got is None else (got - home + 1) * p / 1000))
            where.update(targets)
        begun += track.length_ms
    return rows


def timing_table(rows: list) -> str:
    out = ["| frame | Maestro starts | Maestro's pulse there | servo's own travel | servoc's pulse there | servoc - Maestro |",
           "|---|---|---|---|---|---|"]
    for source, start, pulse, travel, got in rows:
        out.append(f"| {source} | {start:.0f} ms | {pulse:.0f} ms | {travel:.0f} ms | "
                   f"{'-' if got is None else f'{got:.0f} ms'} | {'-' if got is None else f'{got - pulse:+.0f} ms'} |")
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
    print("\n## Maestro timing\n")
    print("Times from the start of `main`. With speed 0 the Maestro's pulse jumps at the frame's start and the "
          "servo follows at its own speed; servoc's pulse moves at that speed, so it arrives with the servo. "
          "With a channel or frame speed both ramp at it.\n")
    print("### examples/import/wave.xml\n")
    print(timing_table(maestro_timing(ROOT / "examples" / "import" / "wave.xml")))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "speeds.xml"
        path.write_text(SPEEDS_XML)
        print("\n### channel speeds (pan 20 = 500 us/s, tilt 0), frame 2 with its own (40, 10), frame 3 too short\n")
        print(timing_table(maestro_timing(path)))


if __name__ == "__main__":
    main()
