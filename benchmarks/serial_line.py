"""The serial line, measured in ucsim: receive rates that hold, event latency, added cycles.

    .venv/bin/python benchmarks/serial_line.py

1. Rates. For 12 MHz and 11.0592 MHz and a few sizes (servos on each of three
   ports, lines spread so that each falls in an edge-handler entry of its own),
   the fastest standard rate `servoc compile` accepts; that firmware then gets
   bursts of 4 bytes back to back at 8 phases of the frame, and every byte must
   be answered (verify: pulses exact, bytes sent in order).
2. Latency. A 3-servo program at 4800 baud gets 16 bytes at phases spread over
   the frame; for each, the time from its stop bit to the first rise of the
   branch it starts (`verify.event_delays`).
3. Sustained rate. A loop of a select and one-frame moves (every command answered
   with a byte) gets one command every frame, and then faster, for 100 commands:
   how many are answered, and the longest run of frames without a new command.
4. Added cycles. The same 24-servo hexapod with and without `serial 4800`: the
   shortest period each holds (from the generated code), and the serial
   handler's load in one frame.
"""

from __future__ import annotations

import re
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from servoc import api, costs, events, verify  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402
from servoc.target import STANDARD_BAUDS  # noqa: E402


def build(text: str):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.servo"
        path.write_text(text, encoding="utf-8")
        source = SourceFile(str(path), text)
        reporter = Reporter(source)
        fe, firmware = api.build(source, reporter)
    return fe, firmware, reporter


def program(clock: str, baud: int, per_port: int) -> str:
    servos = [f"s{p}{b}" for p in range(3) for b in range(per_port)]
    text = f"target stc89c52 clock {clock}\nserial {baud}\n"
    text += "".join(f"servo {s} = P{s[1]}.{s[2]} speed 0.05s/60deg\n" for s in servos)
    text += "pose lo { " + ", ".join(f"{s}: {20 + 14 * int(s[2])}" for s in servos) + " }\n"
    text += "pose hi { " + ", ".join(f"{s}: {250 - 14 * int(s[2])}" for s in servos) + " }\n"
    text += ('main {\n  move lo\n  loop {\n    select {\n      on "h" { move hi in 150ms; send "H" }\n'
             '      on "l" { move lo in 150ms; send "L" }\n    }\n  }\n}\n')
    return text


def run(fe, firmware, scenario: str, frames: int):
    plan = fe.plan
    evs = events.parse(scenario, plan.program.inputs, True)
    stim = api.stimulus(plan, evs)
    cycles = max(api.cycles_needed(plan, frames), stim.last() + 1)
    trace = api.simulate(firmware.hex_text, cycles, plan.program.target, stim, api.probes(firmware))
    return plan, trace, evs, api.check_events(plan, trace, frames, evs)


def rates() -> list[str]:
    rows = ["| clock | servos | fastest rate accepted | refused above it | 8 bursts of 4 bytes |",
            "|---|---|---|---|---|"]
    for clock in ("12MHz", "11.0592MHz"):
        for per_port in (2, 5, 8):
            accepted, refused = None, None
            for baud in sorted(STANDARD_BAUDS, reverse=True):
                fe, firmware, reporter = build(program(clock, baud, per_port))
                codes = {d.code for d in reporter.diagnostics if d.is_error}
                if firmware is not None:
                    accepted = (baud, fe, firmware)
                    break
                if "serial-too-fast" in codes:
                    refused = baud
            if accepted is None:
                rows.append(f"| {clock} | 3 x {per_port} | none | | |")
                continue
            baud, fe, firmware = accepted
            lines = [f'{60 + 800 * k + 0.53 * k:.3f}ms "h" "l" "h" "l"' for k in range(8)]
            plan, trace, evs, report = run(fe, firmware, "\n".join(lines) + "\n",
                                           int(7_000_000 / fe.plan.period_us))
            answered = "".join(chr(b) for _, b in trace.sent)
            ok = report.ok and answered == "HLHL" * 8
            if not ok:
                print(answered, [str(m) for m in report.mismatches[:3]], file=sys.stderr)
            rows.append(f"| {clock} | 3 x {per_port} | {baud} | {refused or '-'} | "
                        f"{'no byte lost' if ok else 'FAILED'} ({len(answered)} answers) |")
    return rows


ARM = """\
serial 4800
servo arm = P1.0 speed 0.05s/60deg
servo leg = P1.1 speed 0.05s/60deg
servo tail = P2.3 speed 0.05s/60deg
pose home { arm: 20, leg: 20, tail: 20 }
pose a { arm: 230, leg: 40, tail: 120 }
main {
  move home
  loop {
    select {
      on "a" { move a in 200ms; move home in 200ms }
    }
  }
}
"""


def latency() -> list[str]:
    fe, firmware, _ = build(ARM)
    period = fe.plan.period_us
    times = [300_000 + k * 500_000 + (k * period) // 16 for k in range(16)]
    scenario = "".join(f'{t}us "a"\n' for t in times)
    plan, trace, evs, report = run(fe, firmware, scenario, int((times[-1] + 1_000_000) / period))
    delays = [d for _, _, d in verify.event_delays(plan, trace, evs) if d]
    return [f"- verify: {report.summary()}",
            f"- {len(delays)} bytes, stop bit to the branch's first rise: min {min(delays) / 1000:.2f} ms, "
            f"max {max(delays) / 1000:.2f} ms, mean {sum(delays) / len(delays) / 1000:.2f} ms "
            f"(P = {period / 1000:.2f} ms: {min(delays) / period:.2f} P to {max(delays) / period:.2f} P)"]


SUSTAINED = """\
serial 4800
frame 6ms
servo arm = P1.0
pose lo { arm: 20 }
pose hi { arm: 22 }
main {
  move lo
  loop {
    select {
      on "a" { move hi in 6ms; send "A" }
      on "b" { move lo in 6ms; send "B" }
    }
  }
}
"""


def sustained() -> list[str]:
    fe, firmware, _ = build(SUSTAINED)
    period = fe.plan.period_us
    byte_us = 10 * 1_000_000 / 4800
    out = []
    for every in (period, period * 0.75, byte_us):
        sent = "ab" * 50
        scenario = "".join(f'{round(100_000 + k * every)}us "{c}"\n' for k, c in enumerate(sent))
        frames = int((100_000 + 100 * every) / period) + 40
        plan, trace, evs, report = run(fe, firmware, scenario, frames)
        answered = "".join(chr(b) for _, b in trace.sent)
        whole = "all, in order" if answered == sent.upper() else "the rest lost when the 4-byte queue was full"
        out.append(f"- a command every {every / 1000:.3f} ms ({period / every:.2f} a frame, P = {period / 1000:.1f} ms): "
                   f"{len(answered)} of {len(sent)} answered ({whole}); verify {'OK' if report.ok else 'FAILED'}")
    return out


def added() -> list[str]:
    text = (ROOT / "examples/hexapod_serial.servo").read_text(encoding="utf-8")
    plain = re.sub(r';? *send "."', "", text.replace("serial 4800\n", ""))          # the same program with buttons
    plain = "\n".join(line for line in plain.splitlines() if "on other" not in line)
    plain = re.sub(r'(on|until) "(.)"', r"\1 \2", plain)
    plain = "input w = P3.2\ninput s = P3.3\ninput l = P3.4\n" + plain
    out = []
    units = {}
    for name, src in (("inputs", plain), ("serial 4800", text)):
        fe, firmware, reporter = build(src)
        assert firmware is not None, [d.message for d in reporter.diagnostics]
        units[name] = firmware.unit
        out.append(f"- hexapod with {name}: shortest P {firmware.unit.min_period_us} us, work between frames "
                   f"{firmware.unit.budget.work} cycles")
    b = units["serial 4800"].budget
    p = units["serial 4800"].target.cycles(units["serial 4800"].min_period_us)
    out.append(f"- serial handler: head {b.serial_head} cycles, longest run {b.serial_run} cycles; its load in "
               f"one frame of {p} cycles at most {costs.serial_load(units['serial 4800'].target, b, p)} cycles "
               f"({costs.serial_load(units['serial 4800'].target, b, p) * 100 / p:.1f} %); longest wait for it "
               f"{costs.serial_latency(units['serial 4800'].target, b)} cycles, a byte every {b.byte_cycles}")
    return out


def main() -> int:
    start = time.time()
    print("## Receive rates (no byte lost)\n")
    print("\n".join(rates()))
    print("\n## Latency from a byte to its branch\n")
    print("\n".join(latency()))
    print("\n## Sustained command rate\n")
    print("\n".join(sustained()))
    print("\n## Added cycles\n")
    print("\n".join(added()))
    print(f"\n{time.time() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
