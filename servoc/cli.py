"""The `servoc` command line: lint, plan, compile, verify.

Exit status: 0 success (warnings allowed), 1 errors in the program or a
failed verification, 2 usage errors and missing tools. Never a traceback.
"""

from __future__ import annotations

import argparse
import csv
import difflib
import io
import os
import re
import sys
from fractions import Fraction

from . import __version__, api
from .diagnostics import Severity, render_full, summary, to_json
from .plan import Plan, verify_frames
from .starter import starter
from .units import DAV_DEG, fmt_ms

EXAMPLES = """\
examples:
  servoc init arm                             write arm.servo, a commented starter program
  servoc lint examples/biped.servo            check a program, show diagnostics
  servoc plan examples/biped.servo            a table of every move's frames and speeds
  servoc plan examples/biped.servo --csv      the same as CSV
  servoc compile examples/biped.servo -o biped.hex --asm biped.asm
  servoc verify examples/biped.servo          run the firmware in ucsim, check every pulse
  servoc lint prog.servo --format json        diagnostics for editors and tools
"""


COMMANDS = ("init", "lint", "plan", "compile", "verify")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # usage errors: exit 2 with a hint
        self.print_usage(sys.stderr)
        hint = ""
        m = re.search(r"invalid choice: '([^']*)'", message)
        if m:
            close = difflib.get_close_matches(m.group(1), COMMANDS, n=1, cutoff=0.5)
            message = f"unknown command `{m.group(1)}`"
            hint = f"did you mean `servoc {close[0]}`? " if close else ""
        sys.stderr.write(f"servoc: error: {message}\n{hint}(see `servoc --help`)\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="servoc", description="Compile .servo motion programs into cycle-exact 8051 firmware "
                     "(AT89C52, 12 MHz) and verify every pulse in the ucsim simulator.",
                     epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"servoc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def add(name: str, help_: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_, description=help_)
        p.add_argument("file", metavar="FILE.servo", help="the program")
        p.add_argument("--format", choices=("text", "json"), default="text", help="how to print diagnostics")
        return p

    p = sub.add_parser("init", help="write a commented starter program", description="write a commented starter program")
    p.add_argument("name", metavar="NAME", help="the program to create: NAME.servo")
    p = add("lint", "check a program and print its diagnostics")
    p.add_argument("--emit", choices=("ast", "model", "plan"), help="print an intermediate form as JSON instead")
    p = add("plan", "show every move's frames, duration and speed per servo")
    p.add_argument("--csv", action="store_true", help="print the table as CSV")
    p.add_argument("--plot", metavar="OUT.png", help="also draw every servo's angle over time (needs servoc[plot])")
    p.add_argument("--emit", choices=("ast", "model", "plan"), help="print an intermediate form as JSON instead")
    p = add("compile", "compile to Intel HEX for the AT89C52")
    p.add_argument("-o", "--output", metavar="OUT.hex", help="HEX file to write (default: FILE.hex)")
    p.add_argument("--asm", metavar="OUT.asm", help="also write the generated assembly")
    p = add("verify", "compile, run in ucsim and compare every pulse with the plan")
    p.add_argument("--vcd", metavar="OUT.vcd", help="also write the simulated pin waveforms (needs servoc[vcd])")
    p.add_argument("--hex", metavar="FILE.hex", help="check this HEX (built from FILE.servo) instead of compiling")
    p.add_argument("--frames", type=int, metavar="N",
                   help="frames to check from the first pulse (default: the whole program and 20 more; for a "
                        "program that loops forever, up to its loop and two passes of it, at least 400)")
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except KeyboardInterrupt:
        return 130
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    except Exception as exc:  # a bug in servoc, not in the user's program
        sys.stderr.write(f"servoc: internal error: {type(exc).__name__}: {exc}\n"
                         "This is a bug in servoc; please report it with the program that caused it.\n")
        return 3


def _color(stream) -> bool:
    return "NO_COLOR" not in os.environ and hasattr(stream, "isatty") and stream.isatty()


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.command:
        parser.print_help()
        return 2
    if args.command == "init":
        return _init(args.name)
    try:
        source, reporter = api.load_source(args.file)
    except api.UsageError as exc:
        sys.stderr.write(f"servoc: error: {exc}\n")
        return 2
    if getattr(args, "frames", None) is not None and args.frames < 1:
        sys.stderr.write("servoc: error: --frames must be at least 1\n")
        return 2

    firmware = None
    try:
        if args.command in ("compile", "verify"):
            fe, firmware = api.build(source, reporter)
        else:
            fe = api.front_end(source, reporter)
    except api.ToolNotFound as exc:
        _diagnostics(reporter, args)
        sys.stderr.write(f"servoc: error: {exc}\n")
        return 2

    emit = getattr(args, "emit", None)
    if emit:
        if reporter.has_errors:
            _diagnostics(reporter, args)
            return 1
        from .dump import dump
        print(dump({"ast": fe.tree, "model": fe.program, "plan": fe.plan}[emit], source))
        return 0

    _diagnostics(reporter, args)
    if reporter.has_errors:
        return 1
    plan = fe.plan
    assert plan is not None
    if args.command == "lint":
        if args.format == "text":
            print(f"{source.path}: {_plan_line(plan)}")
        return 0
    if args.command == "plan":
        sys.stdout.write(plan_table(plan, source, csv_out=args.csv))
        if args.plot:
            from .plot import MissingExtra, plot_plan
            try:
                plot_plan(plan, args.plot, source)
            except (MissingExtra, OSError) as exc:
                sys.stderr.write(f"servoc: error: {exc}\n")
                return 2
        return 0
    assert firmware is not None
    if args.command == "compile":
        out = args.output or os.path.splitext(args.file)[0] + ".hex"
        for path, text in ((args.asm, firmware.unit.text), (out, firmware.hex_text)):
            if path:
                try:
                    api.write_atomic(path, text)
                except OSError as exc:
                    sys.stderr.write(f"servoc: error: cannot write {path}: {exc.strerror or exc}\n")
                    return 2
        print(f"{out}: {_plan_line(plan)}; ROM {firmware.rom_bytes}/{api.ROM_BYTES} bytes "
              f"(runtime {firmware.runtime_bytes}, program {firmware.program_bytes}, data {firmware.data_bytes}), "
              f"RAM {firmware.unit.ram_bytes}/{api.RAM_BYTES} bytes (stack {firmware.unit.stack_bytes})")
        return 0
    frames = args.frames or verify_frames(plan)
    hex_text = firmware.hex_text
    if args.hex:
        try:
            with open(args.hex, encoding="ascii") as f:
                hex_text = f.read()
        except (OSError, UnicodeDecodeError) as exc:
            sys.stderr.write(f"servoc: error: {args.hex}: cannot read an Intel HEX file ({exc})\n")
            return 2
    try:
        if _color(sys.stderr):
            sys.stderr.write(f"servoc: simulating {frames} frames in ucsim...\r")
        trace = api.simulate(hex_text, api.cycles_needed(plan, frames))
        if _color(sys.stderr):
            sys.stderr.write(" " * 60 + "\r")
    except api.ToolNotFound as exc:
        sys.stderr.write(f"servoc: error: {exc}\n")
        return 2
    report = api.check_trace(plan, trace, frames)
    if args.vcd:
        from .vcd import MissingExtra, write_vcd
        try:
            write_vcd(plan, trace, args.vcd, source.path)
        except (MissingExtra, OSError) as exc:
            sys.stderr.write(f"servoc: error: {exc}\n")
            return 2
    print(f"{source.path}: {report.summary()}")
    for m in report.mismatches[:20]:
        print(f"  {m}")
    if len(report.mismatches) > 20:
        print(f"  ... and {len(report.mismatches) - 20} more mismatches")
    return 0 if report.ok else 1


def _init(name: str) -> int:
    path = name if name.endswith(".servo") else name + ".servo"
    if os.path.exists(path):
        sys.stderr.write(f"servoc: error: {path} already exists; choose another name\n")
        return 2
    stem = os.path.splitext(os.path.basename(path))[0]
    try:
        api.write_atomic(path, starter(stem))
    except OSError as exc:
        sys.stderr.write(f"servoc: error: cannot write {path}: {exc.strerror or exc}\n")
        return 2
    print(f"{path}: written. Next: servoc lint {path}")
    return 0


def _diagnostics(reporter, args) -> None:
    diags = reporter.sorted()
    if args.command != "lint":      # notes are for `servoc lint`; the other commands show what matters
        diags = [d for d in diags if d.severity is not Severity.NOTE]
    if args.format == "json":
        # lint's only output; the other commands keep standard output for their own result
        print(to_json(diags, reporter.source), file=sys.stdout if args.command == "lint" else sys.stderr)
        return
    color = _color(sys.stderr)
    for d in diags:
        sys.stderr.write(render_full(d, reporter.source, color) + "\n")
    if diags:
        sys.stderr.write(summary(diags) + "\n")


def _plan_line(plan: Plan) -> str:
    servos = len(plan.channels)
    ports = ", ".join(f"P{p}" for p in plan.ports) or "no ports"
    kind = "default" if plan.period_is_default else "frame"
    if plan.total_frames is None:
        length = "loops forever"
    else:
        length = (f"{plan.total_frames} frame{'' if plan.total_frames == 1 else 's'} = "
                  f"{fmt_ms(plan.total_frames * plan.period_us)}")
    return (f"{servos} servo{'s' if servos != 1 else ''} on {ports}, P = {fmt_ms(plan.period_us)} ({kind}; "
            f"shortest {fmt_ms(plan.min_period_us)}), program {length}")


def plan_table(plan: Plan, source, csv_out: bool = False) -> str:
    """Every move instance: line, pose, frames, duration, each servo's delta and speed in % of its top speed."""
    rows = []
    for inst in sorted(plan.moves, key=lambda m: m.step.span.start):
        line, _ = source.line_col(inst.step.span.start)
        ms = Fraction(inst.frames * plan.period_us, 1000)
        cells = []
        for m in inst.motions:
            if m.n0 is not None and m.delta == 0:
                continue
            ch = plan.channels[m.channel]
            t_dav = plan.class_t_dav_us[ch.speed_class]
            speed = abs(m.delta) * t_dav * 100 / (inst.frames * plan.period_us)
            cells.append((ch.name, "set" if m.n0 is None else f"{m.delta:+d}",
                          None if m.n0 is None else round(float(speed))))
        rows.append((line, inst.step.pose, inst.frames, float(ms), inst.step.ease, cells))
    if csv_out:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["line", "pose", "frames", "ms", "ease", "servo", "delta", "speed_percent"])
        for line, pose, frames, ms, ease, cells in rows:
            for name, delta, speed in cells:
                w.writerow([line, pose, frames, f"{ms:g}", ease, name, delta, "" if speed is None else speed])
        return buf.getvalue()
    out = [f"frame period P = {fmt_ms(plan.period_us)}; speed = share of the servo's top speed "
           f"(delta in DAV of {float(DAV_DEG):g}°)",
           f"{'line':>5}  {'pose':<14} {'frames':>6} {'ms':>9}  servos (delta, speed)"]
    for line, pose, frames, ms, ease, cells in rows:
        servos = ", ".join(f"{n} {d}" + ("" if s is None else f" ({s}%)") for n, d, s in cells) or "(already there)"
        tag = "" if ease == "linear" else f" [{ease}]"
        out.append(f"{line:>5}  {pose:<14} {frames:>6} {ms:>9.1f}  {servos}{tag}")
    if plan.total_frames is None:
        out.append("total: the program loops forever")
    else:
        out.append(f"total: {plan.total_frames} frames = {fmt_ms(plan.total_frames * plan.period_us)}, "
                   "then the last targets repeat")
    return "\n".join(out) + "\n"
