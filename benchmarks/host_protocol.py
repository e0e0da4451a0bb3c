"""The SSC-32 host protocol (`host ssc32`), measured in ucsim: latency, sustained rate, periods.

    .venv/bin/python benchmarks/host_protocol.py

1. Latency. examples/ssc32_arm.servo (4 servos, 9600 baud, 11.0592 MHz), also while a `PL`
   line's sequence plays (the line ends it), one port of 8 servos, and 24 servos on three ports
   of an STC89C58RD+ get a one-servo group line at 16 phases spread over a frame; for each, the time from its CR's stop bit to the rise of the
   move's first frame, in frames P (the contract: at most 2 P).
2. Sustained rate. The same firmwares get group lines with S and T back to back, for the seconds
   asked (default 10 s of simulated time): the arm lines of its 4 servos, then lines of 24
   channels (those without a servo are read and ignored), the 8 servos lines of 24 channels, and
   24 servos on three ports (an STC89C58RD+) lines naming all 24;
   every byte must be read by the parser, none dropped, and `servoc verify` must find every
   pulse and reply exact. Then the arm gets one-channel lines (8 bytes) back to back, next to
   the same firmware patched to stop the reading at a group line's end, as servoc did before; and
   24 servos get one-channel lines (8 or 9 bytes, a third of a frame's bytes) back to back, next to
   the same firmware patched to stop before every line end after a group line (no joining), as
   servoc did before; and lines that set 2 of the 24 servos each, next to the firmware patched to
   wait before every entry of a servo after a group line, as servoc did before; lines that set
   the same 2 or 3 of the 24 servos each, next to the firmware built without holds; and the arm
   at `frame 20ms` (its state in internal RAM, a frame brings 19 bytes) with lines that set the
   same 2 servos, next to it built without holds; and 24 servos with group lines each followed by
   a `QP` or `Q` line, next to the firmware built without holds (which stops before each).
3. Periods. The shortest period servoc reports with `host` for 1 to 8 servos on one port at
   9600 baud and 11.0592 MHz, at 4800 baud and 12 MHz, and at 9600 baud and 22.1184 MHz, next to
   the same servos without `host` (moved by bytes between their home and N 250, as far as a host
   can move them); and what `servoc lint` says where a configuration is refused.
4. Capacity. The most servos `main { host }` carries on one, two and three ports at 9600 baud
   and 11.0592 MHz, per chip (an STC89 keeps the host's per-servo state in its XRAM), and the
   shortest period there.
"""

from __future__ import annotations

import dataclasses
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from serial_line import build, run as serial_run  # noqa: E402  (benchmarks/serial_line.py)
from servoc import api  # noqa: E402

ARM = ROOT / "examples" / "ssc32_arm.servo"
# the most servos `host` carries at 9600 baud and 11.0592 MHz: one port of 8 (channels 0-7)
EIGHT = ("target stc89c52rc clock 11.0592MHz\nserial 9600\nhost ssc32\ninput stop = P3.2\n"
         + "".join(f"servo s{i} = P1.{i}\n" for i in range(8))
         + "pose rest { " + ", ".join(f"s{i}: {60 + 15 * i}" for i in range(8)) + " }\nhome rest\n"
         + "main {\n  host until press stop\n}\n")

# the spec's 24 servos at 9600 baud and 11.0592 MHz: an STC89C58RD+, whose XRAM holds the host's
# per-servo state and the motion state (channels 0-23: P1, P2, P0)
TWENTY_FOUR = ("target stc89c58rd clock 11.0592MHz\nserial 9600\nhost ssc32\n"
               + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p in (1, 2, 0) for b in range(8))
               + "pose rest { " + ", ".join(f"s{p}{b}: {60 + 5 * b + 20 * p}" for p in (1, 2, 0) for b in range(8))
               + " }\nhome rest\nmain {\n  host\n}\n")


def run(fe, firmware, scenario: str, frames: int):
    """(trace, report) of a run driven by `scenario` (serial_line.run)."""
    _, trace, _, report = serial_run(fe, firmware, scenario, frames)
    return trace, report


def one_byte_a_frame(firmware, reporter):
    """The firmware with the reading while a sequence `PL` started plays cut to one byte a frame,
    as servoc built it before it read the host's rate there (the side-by-side row)."""
    head, loop = firmware.unit.text.split("\nplay_read:")
    passes = loop.split("MOV     R7, #", 1)[1].split()[0]
    text = head + "\nplay_read:" + loop.replace(f"MOV     R7, #{passes}", "MOV     R7, #1", 1)
    return api.assemble(dataclasses.replace(firmware.unit, text=text), reporter)


def latency(text: str, what: str, before: str = "", start_us: int = 200_000, patch=None) -> list[str]:
    """`before`: events that come first (a `PL` line: the group line then ends the sequence it
    plays); `patch`: a change to the firmware (`one_byte_a_frame`)."""
    fe, firmware, reporter = build(text)
    if patch is not None:
        firmware = patch(firmware, reporter)
    plan = fe.plan
    target = plan.program.target
    period = target.cycles(plan.period_us)
    bit = 96                                # 9600 baud at 11.0592 MHz: 96 machine cycles a bit
    lines = []
    delays = []
    for k in range(16):
        at_us = start_us + k * plan.period_us / 16
        line = b"#0P2500\r"
        trace, report = run(fe, firmware, before + f'{at_us / 1e6:.6f}s "#0P2500\\r"\n', 120)
        stop = target.cycles(round(at_us)) + 10 * bit * len(line)      # the CR's stop bit ends
        edges = trace.pin_edges(1, 0)
        rises = [c for c, lvl in edges if lvl == 1]
        widths = [b - a for (a, up), (b, _) in zip(edges, edges[1:]) if up == 1]
        first = next(r for r, w in zip(rises, widths) if w != widths[0])
        delays.append((first - stop) / period)
        assert report.ok or patch is not None, report      # (verify fails the patched firmware: it reads late)
    lines.append(f"latency, {what}, CR's stop bit to the move's first rise ({len(delays)} phases, P = {plan.period_us} us): "
                 f"min {min(delays):.2f} P, max {max(delays):.2f} P (the contract: at most 2 P)")
    return lines


def _group(n: int, channels: int, servos: tuple[int, ...]) -> str:
    """Group line n: the servos' channels with S, and with channels=24 every other channel 0-23 too
    (no servo there: the parser reads and ignores them), then T."""
    widths = {c: 1000 + (37 + 5 * k) * (n % 20) if k % 2 == 0 else 1800 - (29 + 3 * k) * (n % 20)
              for k, c in enumerate(servos)}
    chans = range(24) if channels == 24 else sorted(widths)
    return "".join(f"#{c}P{widths.get(c, 1500 + c)}" + (f"S{700 + 13 * (n % 50)}" if c in widths else "")
                   for c in chans) + "T90"


def _stream(fe, firmware, lines: list[str], seconds: float):
    """`lines` (each with its CR) sent back to back from 0.2 s, run `seconds` and 1.5 s more:
    (report, bytes sent, bytes the parser read, bytes lost to a full receive queue)."""
    text = "".join(lines).replace("\r", "\\r")
    trace, report = run(fe, firmware, f'0.2s "{text}"\n', int((seconds + 1.5) * 1e6 / fe.plan.period_us))
    read = sum(len(got) for h in trace.observation.hosts for _, _, got in h.frames)
    lost = sum(1 for r in trace.observation.received if not r.queued)
    return report, sum(len(line) for line in lines), read, lost


def sustained(seconds: float, channels: int, program: str, servos: tuple[int, ...]) -> list[str]:
    fe, firmware, _ = build(program)
    lines: list[str] = []
    while sum(map(len, lines)) * 10 / 9600 < seconds:      # group lines back to back
        lines.append(_group(len(lines), channels, servos) + "\r")
    report, sent, read, dropped = _stream(fe, firmware, lines, seconds)
    n = len(lines)
    return [f"sustained: {n} group lines of {channels} channels, {len(servos)} of them servos, with S and T ({sent} bytes, "
            f"back to back at 9600 baud, {sent * 10 / 9600:.1f} s): {read} bytes read by the parser, {dropped} "
            f"dropped; verify {'OK' if report.ok else 'FAILED'} over {report.frames} frames ({report.pulses} "
            f"pulses, {report.bytes_sent} bytes sent)"]


def _patched(firmware, reporter, edits: list[tuple[str, str]]):
    """The firmware with each (old, new) text of its assembly that it has (one at least) replaced
    once, assembled again (a program without sequences has no reading while one plays)."""
    text = firmware.unit.text
    for old, new in edits:
        text = text.replace(old, new, 1)
    assert text != firmware.unit.text
    return api.assemble(dataclasses.replace(firmware.unit, text=text), reporter)


def stop_after_group(firmware, reporter):
    """The firmware with the reading stopping at a group line's end, as servoc built it before the
    reading went on into the next line (the side-by-side row)."""
    return _patched(firmware, reporter, [(f"CJNE    A, #0x01, {p}_n", f"SJMP    {p}_n       ") for p in ("hp", "pr")])


def stall_at_line_ends(firmware, reporter):
    """The firmware with the reading stopping before every line end after a group line, as servoc
    built it before group lines read in one frame joined (the side-by-side row)."""
    return _patched(firmware, reporter, [(f"{p}_j:  MOV     A, HST", f"{p}_j:  SJMP    {p}_n  ") for p in ("hp", "pr")])


def wait_every_entry(firmware, reporter):
    """The firmware with the reading in XRAM waiting before the '#' that ends any entry of a line
    not gone bad after a group line, as servoc built it before a line's entries kept their own
    generation (the side-by-side row)."""
    edits = [(m.group(0), f"SJMP    {m.group(1)}_n\n        NOP\n        NOP")
             for m in re.finditer(r"MOV     A, HHP\n        CJNE    A, #HHO\+\d+, (\w+)_th", firmware.unit.text)]
    return _patched(firmware, reporter, edits)


def without_holds(fe, reporter):
    """(front end, firmware) built without the holds (`Plan.holds`), as servoc built it before: a
    '#' that ends an entry for a servo of the group waiting waits for the commit (the side-by-side
    row)."""
    plan = dataclasses.replace(fe.plan, holds=False)
    return dataclasses.replace(fe, plan=plan), api.assemble(api.codegen.generate(plan), reporter)


def sustained_few(seconds: float, program: str, what: str, size: int, patch=None, same: bool = False,
                  holds: bool = True, channels: tuple[int, ...] = tuple(range(24))) -> list[str]:
    """Group lines that set `size` servos each, the servos of `channels` in turn (`same`: the first
    `size` in every line), back to back at 9600 baud; `holds` False: built without them
    (`without_holds`)."""
    fe, firmware, reporter = build(program)
    if not holds:
        fe, firmware = without_holds(fe, reporter)
    if patch is not None:
        firmware = patch(firmware, reporter)
    plan = fe.plan
    first = (lambda n: 0) if same else (lambda n: n * size)
    lines = ["".join(f"#{channels[c % len(channels)]}P{1000 + (n * 37 + c * 11) % 900}"
                     for c in range(first(n), first(n) + size)) + "\r"
             for n in range(int(seconds * 960 / (8 * size)))]
    report, sent, read, lost = _stream(fe, firmware, lines, seconds)
    return [f"sustained, {what}: {len(lines)} group lines of {size} servos{' (the same ones)' if same else ''} "
            f"({sent} bytes back to back at 9600 baud, "
            f"{sent * 10 / 9600:.1f} s, P = {plan.period_us} us): {read} bytes read by the parser, {lost} lost; "
            f"verify {'OK' if report.ok else 'FAILED'}"]


def sustained_answers(seconds: float, program: str, what: str, answer: str, holds: bool = True) -> list[str]:
    """Group lines of one servo with T, each followed by an answer line (`Q` or `QP c`), back to
    back at 9600 baud, with no wait for the answers; `holds` False: built without the holds' code,
    which also leaves out reading on through answer lines (`flow.reads_answers`)."""
    fe, firmware, reporter = build(program)
    if not holds:
        fe, firmware = without_holds(fe, reporter)
    plan = fe.plan
    lines = [f"#{n % 24}P{1000 + n * 37 % 900}T200\r" + ("Q" if answer == "Q" else f"QP{n % 24}") + "\r"
             for n in range(int(seconds * 960 / 16))]
    report, sent, read, lost = _stream(fe, firmware, lines, seconds)
    return [f"sustained, {what}: {len(lines)} group lines each followed by `{answer}` ({sent} bytes back to back at "
            f"9600 baud, P = {plan.period_us} us): {read} bytes read by the parser, {lost} lost; "
            f"verify {'OK' if report.ok else 'FAILED'}"]


def sustained_one_channel(seconds: float, program: str, what: str, patch=None,
                          channels: tuple[int, ...] = (0, 1, 2, 7)) -> list[str]:
    """One-channel group lines (`#c P w`, 8 bytes, 9 for channels past 9) back to back at 9600
    baud, cycling through `channels`: at the arm each longer than a frame brings, shorter than a
    line that sets every servo; at 24 servos about a third of what a frame brings."""
    fe, firmware, reporter = build(program)
    if patch is not None:
        firmware = patch(firmware, reporter)
    plan = fe.plan
    lines = [f"#{c}P{1000 + (97 * n) % 900}\r" for n, c in
             enumerate(list(channels) * int(seconds * 960 / 8 / len(channels) + 1))]
    report, sent, read, lost = _stream(fe, firmware, lines, seconds)
    size = "8 bytes" if max(channels) < 10 else "8 or 9 bytes"
    return [f"sustained, {what}: {len(lines)} one-channel group lines of {size} ({sent} bytes back to back at "
            f"9600 baud, {sent * 10 / 9600:.1f} s, P = {plan.period_us} us): {read} bytes read by the parser, "
            f"{lost} lost; verify {'OK' if report.ok else 'FAILED'}"]


def periods() -> list[str]:
    out = ["| servos on P1 | clock, baud | P with `host` (us) | P without (us) |", "|---|---|---|---|"]
    for clock, baud in (("11.0592MHz", 9600), ("12MHz", 4800), ("22.1184MHz", 9600)):
        for count in (1, 2, 4, 5, 8):
            servos = "".join(f"servo s{i} = P1.{i}\n" for i in range(count))
            pose = "pose p { " + ", ".join(f"s{i}: {40 + 20 * i}" for i in range(count)) + " }\n"
            head = f"target stc89c52rc clock {clock}\nserial {baud}\n"
            with_host = head + "host ssc32\n" + servos + pose + "home p\nmain {\n  host\n}\n"
            far = "pose q { " + ", ".join(f"s{i}: 250" for i in range(count)) + " }\n"     # anywhere, as the host
            without = (head + servos + pose + far + "home p\nmain {\n  loop { select { on \"x\" { move q } "
                       "on \"y\" { move p } } }\n}\n")
            cells = []
            for text in (with_host, without):
                fe, firmware, reporter = build(text)
                errors = [d for d in reporter.diagnostics if d.is_error]
                cells.append(f"refused: {errors[0].code}" if errors else f"{fe.plan.min_period_us}")
            out.append(f"| {count} | {clock}, {baud} | {cells[0]} | {cells[1]} |")
    return out


def capacity() -> list[str]:
    """The most servos `main { host }` carries on one, two and three ports at 9600 baud and 11.0592
    MHz, per chip (the STC89s keep the host's per-servo state in XRAM), and the period at that."""
    out = ["| chip | ports | most servos | P (us) |", "|---|---|---|---|"]
    for chip in ("at89c52", "stc89c52rc", "stc89c58rd"):
        for ports in ((1,), (1, 2), (0, 1, 2)):
            best = None
            for count in range(len(ports), 8 * len(ports) + 1):
                pins = [(ports[i % len(ports)], i // len(ports)) for i in range(count)]
                text = (f"target {chip} clock 11.0592MHz\nserial 9600\nhost ssc32\n"
                        + "".join(f"servo s{i} = P{p}.{b}\n" for i, (p, b) in enumerate(pins)) + "main { host }\n")
                fe, firmware, reporter = build(text)
                if any(d.is_error for d in reporter.diagnostics):
                    continue
                best = (count, fe.plan.min_period_us)
            out.append(f"| {chip} | {len(ports)} | {best[0] if best else 0} | {best[1] if best else '-'} |")
    return out


def main() -> int:
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    arm = ARM.read_text(encoding="utf-8")
    arm20 = arm.replace("serial 9600", "serial 9600\nframe 20ms")
    for line in (latency(arm, "the arm (4 servos)")
                 + latency(arm, "the arm while `PL 0 SQ 0` plays its wave", '0.1s "PL 0 SQ 0\\r"\n', 250_000)
                 + latency(arm, "the same, reading one byte a frame while it plays (as servoc did before)",
                           '0.1s "PL 0 SQ 0\\r"\n', 250_000, one_byte_a_frame)
                 + latency(EIGHT, "8 servos on P1")
                 + latency(TWENTY_FOUR, "24 servos on P1, P2, P0 (STC89C58RD+)")
                 + sustained(seconds, 4, arm, (0, 1, 2, 7)) + sustained(seconds, 24, arm, (0, 1, 2, 7))
                 + sustained(seconds, 24, EIGHT, tuple(range(8)))
                 + sustained(seconds, 24, TWENTY_FOUR, tuple(range(24)))
                 + sustained_one_channel(seconds, arm, "the arm")
                 + sustained_one_channel(seconds, arm, "the same, stopping the reading at a group line's end "
                                         "(as servoc did before)", stop_after_group)
                 + sustained_one_channel(seconds, TWENTY_FOUR, "24 servos", channels=tuple(range(24)))
                 + sustained_one_channel(seconds, TWENTY_FOUR, "the same, stopping the reading before every "
                                         "line end after a group line (as servoc did before)", stall_at_line_ends,
                                         tuple(range(24)))
                 + sustained_few(seconds, TWENTY_FOUR, "24 servos", 2)
                 + sustained_few(seconds, TWENTY_FOUR, "the same, waiting before every entry of a servo after a "
                                 "group line (as servoc did before)", 2, wait_every_entry)
                 + sustained_few(seconds, TWENTY_FOUR, "24 servos", 2, same=True)
                 + sustained_few(seconds, TWENTY_FOUR, "the same, built without holds (as servoc did before)", 2,
                                 same=True, holds=False)
                 + sustained_few(seconds, TWENTY_FOUR, "24 servos", 3, same=True)
                 + sustained_answers(seconds, TWENTY_FOUR, "24 servos", "QP")
                 + sustained_answers(seconds, TWENTY_FOUR, "the same, built without holds (and without reading "
                                     "on through answer lines, as servoc did before)", "QP", holds=False)
                 + sustained_answers(seconds, TWENTY_FOUR, "24 servos", "Q")
                 + sustained_answers(seconds, TWENTY_FOUR, "the same, built without holds (as servoc did before)",
                                     "Q", holds=False)
                 + sustained_few(seconds, arm20, "the arm at `frame 20ms`", 2, same=True, channels=(0, 1, 2, 7))
                 + sustained_few(seconds, arm20, "the same, built without holds (as servoc did before)", 2,
                                 same=True, holds=False, channels=(0, 1, 2, 7))
                 + periods() + capacity()):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
