"""The `servoc` command line: lint, plan, compile, verify, sim (servoc/simlink.py), flash, import.

Exit status: 0 success (warnings allowed), 1 errors in the program or a
failed verification, 2 usage errors and missing tools. Never a traceback.

With `--format json` everything is machine-readable: the diagnostics, with
whatever stopped servoc (a usage error, a missing tool, an output that cannot
be written), are one JSON document, on standard output for `lint` (its only
output) and on standard error for the other commands; `init`, `compile` and
`verify` print their result as JSON; `plan` prints its table as `--csv` or
`--json` ask.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import difflib
import functools
import importlib
import gc
import io
import json
import math
import os
import re
import shutil
import sys
from fractions import Fraction

from . import __version__, api, costs
from .diagnostics import Severity, render_full, summary, to_dict
from .plan import has_selects
from .steps import AfterBranch, branch_text, HostStep, Plan, SelectStep, SendStep, host_playable, steps
from .starter import starter
from .verify import SETTLE_MARGIN, coverage, max_frames, verify_settle, verify_span
from .target import fmt_us
from .units import DAV_DEG, fmt_ms

EXAMPLES = """\
examples:
  servoc init arm                             write arm.servo, a commented starter program
  servoc lint examples/biped.servo            check a program, show diagnostics
  servoc plan examples/biped.servo            a table of every move's frames and speeds
  servoc plan examples/biped.servo --csv      the same as CSV
  servoc compile examples/biped.servo -o biped.hex --asm biped.asm
  servoc verify examples/biped.servo          run the firmware in ucsim, check every pulse
  servoc verify examples/hexapod_serial.servo --events examples/events/hexapod_serial.events
                                              the same with timed button presses and host bytes
  servoc sim examples/hexapod_serial.servo --link /tmp/hexapod
                                              run it in ucsim, its serial line on a pseudo-terminal that a
                                              host program opens like /dev/ttyUSB0 (here also as /tmp/hexapod)
  servoc flash prog.servo --port /dev/ttyUSB0 compile and write it to an STC89 board (needs servoc[flash]);
                                              for an AT89 chip, print the programmer's command
  servoc import walk.json -o walk.servo       a program from a Blender servo-animation export (also Maestro
                                              settings, Bottango code exports, CSV), then lint it
  servoc lint prog.servo --format json        diagnostics for editors and tools
  servoc verify prog.servo --format json      the check's figures and every mismatch as JSON

exit status:
  0 success (warnings and notes allowed), 1 errors in the program or a failed verify,
  2 usage errors, outputs that cannot be written and missing tools

environment:
  SERVOC_SDAS8051, SERVOC_SDLD, SERVOC_S51, SERVOC_PACKIHX
                    the path of the SDCC assembler, linker, ucsim simulator and packihx,
                    instead of looking them up on PATH
  NO_COLOR          no colour in diagnostics
"""


COMMANDS = ("init", "lint", "plan", "compile", "verify", "sim", "flash", "import", "lsp")
LSP_MISSING = "the language server needs pygls: pip install 'servoc[lsp]'"


class _Stop(Exception):
    """servoc stops for a reason outside the program (exit 2): `kind` is `usage`, `missing-tool`,
    `missing-extra` or `cannot-write`."""

    def __init__(self, message: str, kind: str = "usage", parser: argparse.ArgumentParser | None = None):
        super().__init__(message)
        self.message, self.kind, self.parser = message, kind, parser


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # usage errors: exit 2 with a hint
        m = re.search(r"invalid choice: '([^']*)'", message)
        if m and self.prog == "servoc":
            close = difflib.get_close_matches(m.group(1), COMMANDS, n=1, cutoff=0.5)
            message = f"unknown command `{m.group(1)}`"
            if close:
                message += f"; did you mean `servoc {close[0]}`?"
        raise _Stop(message, parser=self)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="servoc", description="Compile .servo motion programs into cycle-exact 8051 firmware "
                     "(8052-class chips: AT89C52 at 12 MHz by default; AT89S52, AT89C55WD, STC89C52RC, "
                     "STC89C58RD, any crystal they are rated for, 6T mode) and verify every pulse in the ucsim "
                     "simulator.",
                     epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-V", "--version", action="version", version=f"servoc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def fmt(p: argparse.ArgumentParser) -> None:
        p.add_argument("--format", choices=("text", "json"), default="text",
                       help="text, or JSON for tools: the result on standard output, the diagnostics as one "
                            "document (see docs/language.md)")

    def add(name: str, help_: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_, description=help_)
        p.add_argument("file", metavar="FILE.servo", help="the program")
        fmt(p)
        return p

    p = sub.add_parser("init", help="write a commented starter program", description="write a commented starter program")
    p.add_argument("name", metavar="NAME", help="the program to create: NAME.servo")
    fmt(p)
    p = add("lint", "check a program and print its diagnostics")
    p.add_argument("--emit", choices=("ast", "model", "plan"), help="print an intermediate form as JSON instead")
    p = add("plan", "show every move's frames, duration and speed per servo")
    table = p.add_mutually_exclusive_group()
    table.add_argument("--csv", action="store_true", help="print the table as CSV")
    table.add_argument("--json", action="store_true", help="print the table as JSON, one object per move")
    p.add_argument("--plot", metavar="OUT.png", help="also draw every servo's angle over time (needs servoc[plot])")
    p.add_argument("--emit", choices=("ast", "model", "plan"), help="print an intermediate form as JSON instead")
    def size(p: argparse.ArgumentParser) -> None:
        p.add_argument("--size", action="store_true",
                       help="build the firmware for size (loops where the build for speed is unrolled; a longer "
                            "shortest period) even when the build for speed fits")

    p = add("compile", "compile to Intel HEX for the program's target (default AT89C52 at 12 MHz)")
    size(p)
    p.add_argument("-o", "--output", metavar="OUT.hex", help="HEX file to write (default: FILE.hex)")
    p.add_argument("--asm", metavar="OUT.asm", help="also write the generated assembly")
    p = add("verify", "compile, run in ucsim and compare every pulse and every byte sent with the plan "
                      "(--events: with timed inputs and bytes from a host)")
    p.add_argument("--vcd", metavar="OUT.vcd", help="also write the simulated pin waveforms (needs servoc[vcd])")
    p.add_argument("--hex", metavar="FILE.hex", help="check this HEX (built from FILE.servo) instead of compiling")
    size(p)
    p.add_argument("--events", metavar="EVENTS", help="drive the program's inputs and serial line with these "
                   "timed events (lines `500ms button active`, `1.2s \"w\"`; docs/language.md, \"servoc verify "
                   "--events\"); the report lists each select reached and the branch it took")
    p.add_argument("--frames", type=int, metavar="N",
                   help="frames to check from the first pulse (default: the whole program and 20 more; for a "
                        "program that loops forever, up to its loop and two passes of it, at least 400; with "
                        "--events, on until the last event's branch has ended; at most 60 s of simulated time unless asked, and "
                        "never more than ucsim's clock counter holds, about 358 s at 12 MHz)")
    help_ = ("run the firmware in ucsim with its serial line on a pseudo-terminal, which any host program "
             "opens as it would /dev/ttyUSB0 (the program needs `serial`)")
    p = sub.add_parser("sim", help=help_, epilog=SIM_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
                       description=_wrap(help_ + ". It prints the pseudo-terminal's path and the baud rate, and every few "
                       "seconds how fast the simulation runs against real time; it runs until Ctrl-C (or SIGTERM), "
                       "or for --seconds of simulated time, then exits 0 and removes what it made."))
    p.add_argument("file", metavar="FILE.servo", help="the program; it must declare `serial BAUD`")
    p.add_argument("--link", metavar="PATH", help="also make PATH a symlink to the pseudo-terminal, a fixed name "
                   "for the host's configuration (e.g. /tmp/ttyROBOT); removed at exit")
    p.add_argument("--seconds", metavar="S", help="stop after S seconds of simulated time (default: run until "
                   "Ctrl-C or SIGTERM)")
    p.add_argument("--events", metavar="EVENTS", help="also drive the inputs, and send bytes, at these simulated "
                   "times: the file `servoc verify --events` reads (times from reset)")
    p.add_argument("--view", action="store_true", help="print each servo's pulse width in µs as the firmware "
                   "puts it out, one line per frame shown (about 10 per simulated second; slows ucsim by up to 25 %%)")
    p.add_argument("--view-every", type=int, metavar="N", help="with --view: one line every N frames")
    size(p)
    p = add("flash", "compile and write to an STC89 board (needs servoc[flash]), or print an AT89's "
                     "programmer command")
    p.add_argument("--port", metavar="PORT", help="the STC89 board's serial port, e.g. /dev/ttyUSB0 or COM3 "
                                                  "(needed for STC chips)")
    p.add_argument("-o", "--output", metavar="OUT.hex", help="HEX file to write (default: FILE.hex)")
    p.add_argument("--baud", type=int, metavar="N", default=None,
                   help="stcgal's transfer rate in baud (default: 115200)")
    size(p)
    help_ = ("write a .servo program from motion made in another tool (Pololu Maestro Control Center "
             "settings, Blender servo-animation .json/.h/.bin, Bottango code export, CSV), then lint it")
    p = sub.add_parser("import", help=help_, description=help_ + ". Channels 0-7 go on P1.0-P1.7, 8-15 on "
                       "P2.0-P2.7, 16-23 on P0.0-P0.7 unless --pins maps them. The exit status is lint's.")
    p.add_argument("file", metavar="FILE", help="the file to import")
    p.add_argument("-o", "--output", metavar="OUT.servo", help="the program to write (default: FILE with .servo)")
    p.add_argument("--from", dest="source_format", choices=("maestro", "blender", "bottango", "csv"),
                   help="the file's format (default: recognised from its content)")
    p.add_argument("--pins", metavar="CH=PIN,...", help="put channels on other pins, e.g. `--pins 0=P0.0,1=P0.1`")
    p.add_argument("--fps", metavar="N", help="frames per second (needed for a Blender .bin)")
    p.add_argument("--ticks", metavar="HZ", help="positions are PCA9685 ticks (4096 per period) at a PWM "
                   "rate of HZ, not µs")
    fmt(p)
    help_ = "run the language server on stdin/stdout, for editors (needs servoc[lsp])"
    sub.add_parser("lsp", help=help_, description=help_)
    return parser


SIM_EPILOG = """\
example:
  servoc sim examples/hexapod_serial.servo --link /tmp/hexapod
      serial: /dev/pts/7
      link: /tmp/hexapod -> /dev/pts/7
      baud: 4800, 8 data bits, no parity, 1 stop bit (Timer1 makes 4807.7)
      ...
  then, in another terminal: python examples/host.py /tmp/hexapod w s l

The host may set any rate on the pseudo-terminal: bytes reach the firmware at its own rate, in
simulated time. Events files: docs/language.md, "servoc verify --events".
"""


def _wrap(text: str) -> str:
    import textwrap
    return textwrap.fill(text, width=min(100, shutil.get_terminal_size().columns - 2))


class _Run:
    """What one run reports besides its result: the diagnostics and what stopped it; with
    `--format json` they are written at the end as one document."""

    def __init__(self, argv: list[str]):
        self.json = _json_requested(argv)
        self.command = next((a for a in argv if a in COMMANDS), None)
        self.emit = False
        self.diags: list = []
        self.source = None
        self.error: dict | None = None
        self.extra: dict = {}        # more of the document (`servoc import`'s figures)

    @property
    def doc_on_stdout(self) -> bool:
        return self.command in ("lint", "import") and not self.emit

    def stop(self, kind: str, message: str, parser: argparse.ArgumentParser | None = None) -> None:
        if self.json:
            self.error = {"kind": kind, "message": message}
            return
        if parser is not None:
            parser.print_usage(sys.stderr)
            message += "\n(see `servoc --help`)" if parser.prog == "servoc" else f"\n(see `{parser.prog} --help`)"
        sys.stderr.write(f"servoc: error: {message}\n")

    def document(self) -> str:
        doc = to_dict(self.diags, self.source)
        doc.update(self.extra)
        if self.error is not None:
            doc["error"] = self.error
        return json.dumps(doc, indent=2)


def _json_requested(argv: list[str]) -> bool:
    """`--format json` (or `--format=json`, or an abbreviation such as `--form json`) in argv: known
    before argparse has read it, so that its usage errors can be JSON too."""
    for i, arg in enumerate(argv):
        if arg == "--":
            break
        name, eq, value = arg.partition("=")
        if len(name) >= 4 and "--format".startswith(name):
            if (value if eq else (argv[i + 1] if i + 1 < len(argv) else "")) == "json":
                return True
    return False


def main(argv: list[str] | None = None) -> int:
    try:
        return _command(argv)
    except BrokenPipeError:     # `servoc lint x --format json | head`: the reader left; no traceback
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())       # Python's flush at exit would fail again
        except (OSError, ValueError):
            pass
        return 141 if argv is None else 1
    finally:
        gc.unfreeze()       # the command froze its program's objects (see _main); a caller in the same
                            # process gets them back to the collector


def _command(argv: list[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    run = _Run(argv)
    try:
        rc = _main(argv, run)
    except KeyboardInterrupt:
        return 130
    except _Stop as exc:
        run.stop(exc.kind, exc.message, exc.parser)
        rc = 2
    except SystemExit as exc:       # --help, --version: their output is all there is
        return exc.code if isinstance(exc.code, int) else 2
    except BrokenPipeError:
        raise                       # the reader of the output left (see main)
    except Exception as exc:  # a bug in servoc, not in the user's program
        message = (f"{type(exc).__name__}: {exc}. This is a bug in servoc; please report it with the program "
                   "that caused it.")
        if not run.json:
            sys.stderr.write(f"servoc: internal error: {type(exc).__name__}: {exc}\n"
                             "This is a bug in servoc; please report it with the program that caused it.\n")
            return 3
        run.error = {"kind": "internal", "message": message}
        rc = 3
    if run.json:
        print(run.document(), file=sys.stdout if run.doc_on_stdout else sys.stderr)
    return rc


def _color(stream) -> bool:
    return "NO_COLOR" not in os.environ and hasattr(stream, "isatty") and stream.isatty()


@functools.lru_cache(maxsize=1)
def _parser() -> argparse.ArgumentParser:
    """The command line's parser, built once a process (parsing leaves it as it was)."""
    return build_parser()


def _main(argv: list[str], run: _Run) -> int:
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    if extra:                   # the command's own usage, not the top level's
        sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
        owner = sub.choices.get(args.command) if sub is not None and args.command else None
        (owner or parser).error(f"unrecognized arguments: {' '.join(extra)}")
    run.command = args.command
    if hasattr(args, "format"):
        run.json = args.format == "json"
    if not args.command:
        if run.json:
            raise _Stop("no command given", parser=parser)
        parser.print_help()
        return 2
    if args.command == "lsp":
        return _lsp()
    if args.command == "init":
        return _init(args.name, run)
    if args.command == "import":
        return _import(args, run)
    run.emit = bool(getattr(args, "emit", None))
    _check_options(args)
    source, reporter, hex_text, fe, firmware = _front(args, run)
    if run.emit:
        _diagnostics(reporter, args, run, quiet=not reporter.has_errors)
        if reporter.has_errors:
            return 1
        from .dump import dump
        print(dump({"ast": fe.tree, "model": fe.program, "plan": fe.plan}[args.emit], source))
        return 0
    _diagnostics(reporter, args, run)
    if reporter.has_errors:
        return 1
    assert fe.plan is not None
    if args.command == "lint":
        return _lint(run, source, fe.plan)
    if args.command == "plan":
        return _plan(args, run, source, fe.plan)
    assert firmware is not None
    if args.command == "flash":
        return _flash(args, run, source, fe.plan, firmware)
    if args.command == "compile":
        return _compile(args, run, source, fe.plan, firmware)
    if args.command == "sim":
        return _sim(args, run, source, fe.plan, firmware)
    return _verify(args, run, source, fe.plan, hex_text or firmware.hex_text, firmware)


def _check_options(args) -> None:
    """Option values argparse cannot check: usage errors before any work."""
    if getattr(args, "frames", None) is not None and args.frames < 1:
        raise _Stop("--frames must be at least 1")
    if args.command == "sim":
        _check_sim_options(args)
    if args.command == "flash":
        from .flash import BAUDS
        if args.baud is not None and args.baud not in BAUDS:
            raise _Stop(f"--baud {args.baud} is not a rate stcgal can ask for: use one of "
                        + ", ".join(map(str, BAUDS)))


def _front(args, run: _Run):
    """Read the program, check the outputs, and run the front end (and, for compile, verify and
    flash, code generation and assembly): (source, reporter, the --hex text or None, front end,
    firmware or None)."""
    try:
        source, reporter = api.load_source(args.file)
    except api.UsageError as exc:
        raise _Stop(str(exc)) from None
    run.source = source
    hex_text = _check_inputs_and_outputs(args)
    firmware = None
    # The program's tree, model and plan (up to two million objects for a 1 MB
    # program, benchmarks/lint_scale.py) live until the command ends: the cyclic collector is paused while they are
    # built, and never walks them afterwards.
    gc.disable()
    try:
        if args.command in ("compile", "verify", "flash", "sim"):
            fe, firmware = api.build(source, reporter, getattr(args, "size", False))
        else:
            fe = api.front_end(source, reporter)
    except api.ToolNotFound as exc:
        _diagnostics(reporter, args, run)
        raise _Stop(str(exc), "missing-tool") from None
    finally:
        gc.freeze()
        gc.enable()
    return source, reporter, hex_text, fe, firmware


def _lint(run: _Run, source, plan: Plan) -> int:
    """`servoc lint`: the diagnostics (printed already), then the plan's summary line."""
    if not run.json:
        print(f"{source.path}: {_plan_line(plan)}")
    return 0


def _plan(args, run: _Run, source, plan: Plan) -> int:
    """`servoc plan`: the table of every move (text, CSV or JSON), and the plot."""
    if args.json or (run.json and not args.csv):     # `--format json` gives the table as JSON too
        print(json.dumps(plan_data(plan, source), indent=2))
    else:
        sys.stdout.write(plan_table(plan, source, csv_out=args.csv))
    if args.plot:
        from .plot import MissingExtra, plot_plan
        try:
            plot_plan(plan, args.plot, source)
        except MissingExtra as exc:
            raise _Stop(str(exc), "missing-extra") from None
        except OSError as exc:
            raise _Stop(f"cannot write {args.plot}: {exc.strerror or exc}", "cannot-write") from None
    return 0


def _compile(args, run: _Run, source, plan: Plan, firmware) -> int:
    """`servoc compile`: the HEX (and --asm) written atomically, and what it uses."""
    out = _hex_out(args)
    for path, text in ((args.asm, firmware.unit.text), (out, firmware.hex_text)):
        if path:
            try:
                api.write_atomic(path, text)
            except OSError as exc:
                raise _Stop(f"cannot write {path}: {exc.strerror or exc}", "cannot-write") from None
    if run.json:
        print(json.dumps(_compile_data(source, out, args.asm, plan, firmware), indent=2))
    else:
        target = firmware.unit.target
        chip = target.chip
        print(f"{out}: {_plan_line(plan)}; ROM {firmware.rom_bytes}/{chip.code_bytes} bytes "
              f"{'built for size ' if plan.compact else ''}(start-up {firmware.startup_bytes}, runtime {firmware.runtime_bytes}, program "
              f"{firmware.program_bytes}, data {firmware.data_bytes}), "
              f"RAM {firmware.unit.ram_bytes}/{chip.ram_bytes} bytes (stack {firmware.unit.stack_bytes}); "
              + (f"XRAM {firmware.unit.xram_bytes}/{chip.xram_bytes} bytes; " if firmware.unit.xram_bytes else "")
              + f"{target.describe()}, machine cycle {fmt_us(target.cycle_us)}, "
              + ("every width exactly 500 + 8 N µs" if not target.width_error_us()
                 else f"widths within {fmt_us(target.width_error_us())} of 500 + 8 N µs"))
    return 0


def _verify(args, run: _Run, source, plan: Plan, hex_text: str, firmware) -> int:
    """`servoc verify`: run the HEX in ucsim (with --events, as they say), watching what the
    firmware does at its selects, and compare every pulse and every byte sent with the plan of
    the branches it took; say what the run did not reach."""
    from . import events as _events
    from .observe import ProbeError, hex_matches
    events = None
    if getattr(args, "events", None):
        try:
            events = _events.parse(_events_text(args.events), plan.program.inputs, plan.program.serial is not None)
        except _events.EventsError as exc:
            raise _Stop(f"{args.events}: {exc}") from None
    if args.frames:
        most = max_frames(plan)
        if args.frames > most:
            seconds = most * plan.period_us / 1e6
            raise _Stop(f"--frames {args.frames} is more than verify can run: ucsim's clock counter holds at most "
                        f"{most} frames of this program ({seconds:.1f} s at P = {plan.period_us / 1000:g} ms)")
    try:
        span = verify_span(plan, args.frames, events)
        stim = api.stimulus(plan, span.events)
    except _events.EventsError as exc:
        raise _Stop(f"{args.events}: {exc}") from None
    try:
        probes = api.probes(firmware)
    except ProbeError as exc:
        raise _Stop(f"cannot watch the firmware run: {exc}; report this program as a bug") from None
    watched = bool(firmware.unit.selects) or plan.program.serial is not None
    if hex_text != firmware.hex_text and not hex_matches(probes, hex_text):
        if firmware.unit.selects:
            raise _Stop(f"{args.hex} is not the firmware servoc builds from {source.path}: verify cannot watch its "
                        "selects (compile the program again, or verify it without --hex)")
        watched = False
    progress = _color(sys.stderr) and not run.json
    line_of = (lambda sp: source.line_col(sp.start)[0])

    def text_of(sp) -> str:            # the statement as written, its first line, at most 60 characters
        text = " ".join(source.snippet(sp).split("\n", 1)[0].split("#")[0].split())
        return text if len(text) <= 60 else text[:57].rstrip() + "..."

    frames = span.frames
    choices: tuple = ()
    cycles = 0
    for _ in range(4):      # until the consequences of the last event are checked
        try:
            if progress:
                sys.stderr.write(f"servoc: simulating {frames} frames in ucsim...\r")
            cycles = max(api.cycles_needed(plan, frames, choices), stim.last() + 1)
            trace = api.simulate(hex_text, cycles, plan.program.target, stim, probes if watched else None)
            _listens_first(trace, span.events, plan.program.target, args.events)
            if progress:
                sys.stderr.write(" " * 60 + "\r")
        except api.ToolNotFound as exc:
            raise _Stop(str(exc), "missing-tool") from None
        except api.SimError as exc:
            raise _Stop(f"ucsim could not run the firmware: {exc}") from None
        if not watched:
            report = api.check_trace(plan, trace, frames)
            break
        choices, report = api.events_report(plan, trace, frames, span.events, line_of)
        if api.cycles_needed(plan, frames, choices) > trace.cycles:
            continue        # the branches taken put the first pulse later: run on to the frames asked
        settle = verify_settle(plan, choices)
        if args.frames or not events or settle is None or settle + SETTLE_MARGIN <= frames or frames >= span.limit:
            break
        frames = min(span.limit, settle + SETTLE_MARGIN)
    unchecked = list(span.notes)
    if events is not None and not args.frames:
        settle = verify_settle(plan, choices)
        if settle is not None and settle + SETTLE_MARGIN > frames:
            unchecked.append(f"the branch taken last runs past the {frames} frames checked (it waits again at "
                             f"frame {settle}): its end is not checked")
    missed, ended = coverage(plan, choices, frames, line_of, text_of)
    report = dataclasses.replace(report, unchecked=tuple(unchecked + missed), ended=ended)
    if args.vcd:
        from .events import byte_arrivals
        from .target import byte_cycles
        from .vcd import MissingExtra, write_vcd
        try:
            serial = plan.program.serial
            bit_cycles = 0 if serial is None else byte_cycles(serial.th1, serial.smod) // 10
            rx = () if serial is None or not events else tuple(
                (plan.program.target.cycles(at) - 10 * bit_cycles, b)
                for at, b in byte_arrivals(events, 10 * bit_cycles, plan.program.target))
            write_vcd(plan, trace, args.vcd, source.path, stim.pins, rx, bit_cycles)
        except MissingExtra as exc:
            raise _Stop(str(exc), "missing-extra") from None
        except OSError as exc:
            raise _Stop(f"cannot write {args.vcd}: {exc.strerror or exc}", "cannot-write") from None
    if run.json:
        print(json.dumps(verify_data(report, source, plan), indent=2))
        return 0 if report.ok else 1
    print(f"{source.path}: {report.summary()}")
    for m in report.mismatches[:20]:
        print(f"  {m}")
    if len(report.mismatches) > 20:
        print(f"  ... and {len(report.mismatches) - 20} more mismatches")
    for r in report.reactions:
        print(f"  {r}")
    for w in report.warnings:
        print(f"  warning: {w}")
    for u in report.unchecked:
        print(f"  not checked: {u}")
    if report.ended:
        print(f"  when the run ended: {report.ended}")
    return 0 if report.ok else 1


def _check_sim_options(args) -> None:
    """`servoc sim`: --seconds, --view-every and --link make sense, the events file can be read
    (its text is kept in args.events_text); all before compiling."""
    if args.seconds is not None:
        try:
            seconds = Fraction(args.seconds.strip())
        except (ValueError, ZeroDivisionError):
            seconds = Fraction(-1)
        if not 0 < seconds <= 1_000_000:
            raise _Stop(f"--seconds {args.seconds}: give a positive number of seconds of simulated time, e.g. 2.5")
        args.seconds = seconds
    if args.view_every is not None and args.view_every < 1:
        raise _Stop("--view-every must be at least 1")
    if args.link is not None:
        link = args.link
        if link == "":
            raise _Stop("--link needs a path, not an empty one")
        if os.path.lexists(link) and not os.path.islink(link):
            what = "a directory" if os.path.isdir(link) else "a file"
            raise _Stop(f"cannot make the link {link}: it is {what}, not a symlink (--link); name another path")
        folder = os.path.dirname(link) or "."
        if not os.path.isdir(folder):
            raise _Stop(f"cannot make the link {link}: {folder} " + (
                "is not a folder" if os.path.exists(folder) else "does not exist") + " (--link)")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise _Stop(f"cannot make the link {link}: no permission to write in {folder} (--link)")
    args.events_text = None
    if args.events:
        args.events_text = _events_text(args.events)


def _events_text(path: str) -> str:
    """An events file's text: UTF-8 (a BOM is skipped), or UTF-16 with its BOM; a byte that is
    neither is a usage error at its line."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise _Stop(f"cannot read {path}: {exc.strerror or exc}") from None
    codec = "utf-16" if data[:2] in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig"
    try:
        return data.decode(codec)
    except UnicodeDecodeError as exc:
        text = data[:exc.start].decode(codec, errors="replace")
        raise _Stop(f"{path}: line {text.count(chr(10)) + 1}: not {'UTF-16' if codec == 'utf-16' else 'UTF-8'} "
                    f"text (byte 0x{data[exc.start]:02X}); write bytes past 127 as \\xHH") from None


def _sim(args, run: _Run, source, plan: Plan, firmware) -> int:
    """`servoc sim`: the firmware in ucsim, its UART on a pseudo-terminal (servoc/simlink.py), until
    Ctrl-C, SIGTERM or --seconds of simulated time."""
    from . import events as _events
    from . import simlink
    from .target import byte_cycles
    program = plan.program
    serial = program.serial
    if serial is None:
        raise _Stop(f"{source.path} declares no serial line: servoc sim puts the firmware's UART on a "
                    "pseudo-terminal, so the program needs `serial BAUD` (e.g. `serial 9600`); "
                    "`servoc verify` runs a program without one")
    target = program.target
    events: list = []
    if args.events_text is not None:
        try:
            events = _events.parse(args.events_text, program.inputs, True)
            _events.uart_windows(events, byte_cycles(serial.th1, serial.smod), target)     # lines in order
        except _events.EventsError as exc:
            raise _Stop(f"{args.events}: {exc}") from None
    pins = tuple(_events.pin_changes(events, program.inputs, target))
    rx = tuple((max(2, target.cycles(ev.time_us)), ev.data) for ev in events if isinstance(ev, _events.ByteEvent))
    view_every = None
    if args.view or args.view_every is not None:
        view_every = args.view_every or max(1, round(100_000 / plan.period_us))
    setup = simlink.Setup(firmware.hex_text, target.sim_hz, target.cycle_us, serial.baud, serial.actual,
                          args.seconds, args.link, plan.channels, plan.period_us, view_every, pins, rx)
    try:
        api.toolchain.find_tool("s51")
    except api.ToolNotFound as exc:
        raise _Stop(str(exc), "missing-tool") from None
    print(f"{source.path}: {_plan_line(plan)}; the {target.describe()} in ucsim", flush=True)
    if any(isinstance(st, HostStep) for st in steps(plan)):
        from .model import host_channel
        print("host: SSC-32 commands (docs/host-protocol.md) while `host` runs; channels "
              + ", ".join(f"{k} {name}" for k, name in sorted((host_channel(c.servo), c.name) for c in plan.channels)),
              flush=True)
    try:
        simlink.run(setup, sys.stdout, sys.stderr)
    except api.ToolNotFound as exc:
        raise _Stop(str(exc), "missing-tool") from None
    except simlink.LinkError as exc:
        raise _Stop(str(exc)) from None
    return 0


def _flash(args, run: _Run, source, plan: Plan, firmware) -> int:
    """`servoc flash`: write the HEX, then to an STC89 board through stcgal, or print the command
    that writes it to an AT89 chip. The port and stcgal are checked before the HEX is written."""
    from . import flash
    target = plan.program.target
    chip = target.chip
    out = _hex_out(args)
    stc = flash.uses_stcgal(chip)
    baud = args.baud or flash.DEFAULT_BAUD
    if stc:
        if not args.port:
            raise _Stop(f"the {chip.display} is written through its serial bootloader: name its serial port "
                        "with --port, e.g. --port /dev/ttyUSB0 (COM3 on Windows)")
        if flash.needs_hex_name(out):
            raise _Stop(f"cannot write {out} for stcgal: it reads Intel HEX only from a file named *.hex, *.ihx "
                        "or *.ihex (-o)")
        try:
            flash.load_stcgal()
        except flash.MissingStcgal:
            raise _Stop(flash.MISSING, "missing-extra") from None
    try:
        api.write_atomic(out, firmware.hex_text)
    except OSError as exc:
        raise _Stop(f"cannot write {out}: {exc.strerror or exc}", "cannot-write") from None
    result = {"file": source.path, "hex": out, "chip": chip.display, "six_t": target.six_t,
              "flashed": False, "port": None, "baud": None, "command": None, "stcgal_output": None}
    if not stc:
        result["command"] = flash.command(chip, out)
        if run.json:
            print(json.dumps(result, indent=2))
            return 0
        ignored = [o for o, v in (("--port", args.port), ("--baud", args.baud)) if v is not None]
        if ignored:
            sys.stderr.write(f"servoc: {' and '.join(ignored)} {'is' if len(ignored) == 1 else 'are'} for "
                             f"the STC89's serial bootloader; ignored for the {chip.display}\n")
        print(f"{out}: written. servoc does not program the {chip.display} itself; run ({flash.how(chip)}):")
        print(result["command"])
        return 0
    result.update(port=args.port, baud=baud)
    log = io.StringIO() if run.json else None
    if log is None:
        sys.stderr.write(f"servoc: writing {out} to the {chip.display} on {args.port} with stcgal (protocol "
                         f"{flash.PROTOCOL}, {baud} baud, {'6T' if target.six_t else '12T'} mode); "
                         "power-cycle the board when it asks\n")
    rc = flash.write_stc(out, args.port, target, baud, log=log)
    result["flashed"] = rc == 0
    if log is not None:
        result["stcgal_output"] = log.getvalue()
        print(json.dumps(result, indent=2))
    elif rc == 0:
        print(f"{out}: {_plan_line(plan)}; written to the {chip.display} on {args.port}")
    else:
        sys.stderr.write(f"servoc: error: stcgal could not write {out} to the {chip.display} on {args.port} "
                         f"(exit status {rc}, its message is above): check the port and the wiring, and "
                         "power-cycle the board when stcgal asks\n")
    return 0 if rc == 0 else 1


def _lsp() -> int:
    try:
        from .lsp import main as lsp_main
    except ImportError:
        raise _Stop(LSP_MISSING, "missing-extra") from None
    rc = lsp_main()
    return rc if isinstance(rc, int) else 0


def _init(name: str, run: _Run) -> int:
    path = name if name.endswith(".servo") else name + ".servo"
    if os.path.exists(path):
        raise _Stop(f"{path} already exists; choose another name")
    _check_output("init", path)
    stem = os.path.splitext(os.path.basename(path))[0]
    try:
        api.write_atomic(path, starter(stem))
    except OSError as exc:
        raise _Stop(f"cannot write {path}: {exc.strerror or exc}", "cannot-write") from None
    if run.json:
        print(json.dumps({"file": path}, indent=2))
    else:
        print(f"{path}: written. Next: servoc lint {path}")
    return 0


def _import(args, run: _Run) -> int:
    """`servoc import`: write the program, then report on it as `servoc lint OUT` does."""
    from fractions import Fraction
    from .imports.keyframes import ReadOptions
    out = args.output or os.path.splitext(args.file)[0] + ".servo"
    if args.output is None and _same_file(out, args.file):      # importing a .servo file: never over it
        out = args.file + ".servo"
    _check_output("-o" if args.output else "the program", out)
    if os.path.exists(args.file) and _same_file(out, args.file):
        raise _Stop(f"cannot write {out}: it is the file to import; name another with -o")
    pins = {}
    for item in filter(None, (args.pins or "").split(",")):
        ch, eq, pin = item.strip().partition("=")
        if not eq or not ch.strip().isdigit() or not re.fullmatch(r"P[0-2]\.[0-7]", pin.strip().upper()):
            raise _Stop(f"--pins: `{item.strip()}` is not CHANNEL=PIN (e.g. 0=P1.0; pins P0.0-P2.7)")
        pins[int(ch)] = pin.strip().upper()
    numbers = {}
    for option, value in (("--fps", args.fps), ("--ticks", args.ticks)):
        if value is not None:
            try:
                numbers[option] = Fraction(value)
            except (ValueError, ZeroDivisionError):
                numbers[option] = Fraction(0)
            if not 0 < numbers[option] <= 10_000:
                raise _Stop(f"{option} {value}: give a positive number (frames per second, or the PWM rate in Hz)")
    options = ReadOptions(numbers.get("--fps"), numbers.get("--ticks"))
    try:
        imported = api.import_motion(args.file, args.source_format, pins, options)
    except api.UsageError as exc:
        raise _Stop(str(exc)) from None
    try:
        api.write_atomic(out, imported.text)
    except OSError as exc:
        raise _Stop(f"cannot write {out}: {exc.strerror or exc}", "cannot-write") from None
    figures = {"file": args.file, "servo": out, "frames_in": imported.frames_in, "moves_out": imported.moves_out,
               "max_deviation_n": imported.deviation, "off_grid": imported.off_grid, "notes": list(imported.notes),
               "warnings": list(imported.warnings)}
    if run.json:
        run.extra["import"] = figures
    else:
        print(f"{out}: written from {args.file}: {imported.frames_in} source frames became "
              f"{imported.moves_out} moves, every source position met within {imported.deviation} N")
        for note in imported.notes:
            print(f"  note: {note}")
        for warning in imported.warnings:      # on the diagnostics' stream, naming the file they are about
            print(f"{args.file}: warning: {warning}", file=sys.stderr)
    source, reporter = api.load_source(out)
    run.source = source
    fe = api.front_end(source, reporter)
    _diagnostics(reporter, args, run)
    if reporter.has_errors:
        return 1
    if not run.json:
        print(f"{source.path}: {_plan_line(fe.plan)}")
    return 0


# ---- outputs are checked before any work ---------------------------------------------

def _hex_out(args) -> str:
    return args.output or os.path.splitext(args.file)[0] + ".hex"


def _same_file(a: str, b: str) -> bool:
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.normcase(os.path.realpath(a)) == os.path.normcase(os.path.realpath(b))


def _check_output(option: str, path: str) -> None:
    """Refuse (exit 2) an output that cannot be written: a directory, or in a folder that does not exist."""
    if path == "":
        raise _Stop(f"{option} needs a file name, not an empty one")
    if os.path.isdir(path):
        raise _Stop(f"cannot write {path}: it is a directory, not a file ({option})")
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        what = "is not a folder" if os.path.exists(folder) else "does not exist"
        raise _Stop(f"cannot write {path}: {folder} {what} ({option})")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise _Stop(f"cannot write {path}: no permission to write in {folder} ({option})")


def _need_extra(module: str, feature: str, extra: str, package: str) -> None:
    try:
        importlib.import_module(module)
    except ImportError:
        from .plot import MissingExtra
        raise _Stop(str(MissingExtra(feature, extra, package)), "missing-extra") from None


def _check_inputs_and_outputs(args) -> str | None:
    """Before parsing, compiling or simulating: every output can be written and overwrites neither
    the program nor another output; the optional packages an output needs are there; `--hex` can
    be read (its text is returned)."""
    outputs: list[tuple[str, str]] = []
    if args.command in ("compile", "flash"):
        outputs = [("-o" if args.output else "the HEX", _hex_out(args))]
        if getattr(args, "asm", None) is not None:
            outputs.insert(0, ("--asm", args.asm))
    elif args.command == "plan" and args.plot is not None and not args.emit:
        outputs = [("--plot", args.plot)]
    elif args.command == "verify" and args.vcd is not None:
        outputs = [("--vcd", args.vcd)]
    inputs = [(args.file, "the program")]
    if getattr(args, "hex", None):
        inputs.append((args.hex, "the HEX to check"))
    for i, (option, path) in enumerate(outputs):
        _check_output(option, path)
        for given, what in inputs:
            if _same_file(path, given):
                raise _Stop(f"cannot write {path}: it is {what}, {given} ({option}); name another file")
        for other, earlier in outputs[:i]:
            if _same_file(path, earlier):
                raise _Stop(f"cannot write {path}: {other} and {option} name the same file; name two files")
    if args.command == "plan" and args.plot is not None and not args.emit:
        _need_extra("matplotlib", "plotting", "plot", "matplotlib")
    if args.command == "verify" and args.vcd is not None:
        _need_extra("vcd", "VCD output", "vcd", "pyvcd")
    if getattr(args, "hex", None):
        try:
            with open(args.hex, encoding="ascii") as f:
                return f.read()
        except (OSError, UnicodeDecodeError) as exc:
            raise _Stop(f"{args.hex}: cannot read an Intel HEX file ({exc})") from None
    return None


# ---- diagnostics and results ------------------------------------------------------------

def _diagnostics(reporter, args, run: _Run, quiet: bool = False) -> None:
    """Print the diagnostics as text (unless `quiet`), or keep them for the JSON document."""
    diags = reporter.sorted()
    if args.command not in ("lint", "import"):      # notes are for `servoc lint`; the other commands show what matters
        diags = [d for d in diags if d.severity is not Severity.NOTE]
    if run.json:
        run.diags = diags
        return
    if quiet:
        return
    color = _color(sys.stderr)
    for d in diags:
        sys.stderr.write(render_full(d, reporter.source, color) + "\n")
    if diags:
        sys.stderr.write(summary(diags) + "\n")


def _compile_data(source, out: str, asm: str | None, plan: Plan, firmware) -> dict:
    """`servoc compile --format json`: what was written and what it uses."""
    chip = firmware.unit.target.chip
    return {"file": source.path, "hex": out, "asm": asm,
            "period_us": plan.period_us, "period_is_default": plan.period_is_default,
            "min_period_us": plan.min_period_us, "total_frames": plan.total_frames,
            "chip": chip.display, "clock_hz": firmware.unit.target.clock_hz, "six_t": firmware.unit.target.six_t,
            "machine_cycle_us": float(firmware.unit.target.cycle_us),
            "width_error_us": float(firmware.unit.target.width_error_us()), "rom_bytes": firmware.rom_bytes, "rom_size": chip.code_bytes,
            "startup_bytes": firmware.startup_bytes,
            "runtime_bytes": firmware.runtime_bytes, "program_bytes": firmware.program_bytes,
            "data_bytes": firmware.data_bytes, "ram_bytes": firmware.unit.ram_bytes, "ram_size": chip.ram_bytes,
            "xram_bytes": firmware.unit.xram_bytes,
            "stack_bytes": firmware.unit.stack_bytes, "built_for_size": plan.compact}


def _listens_first(trace, events: list, target, path: str) -> None:
    """A usage error when the events' first bytes start before the firmware's UART receives
    (serial_init sets its receiver on a little after reset): a chip would miss them or read a
    wrong byte, and ucsim holds them back, so no run of the program is what verify would check."""
    from .events import ByteEvent
    obs = getattr(trace, "observation", None)
    first = next((e for e in events if isinstance(e, ByteEvent)), None)
    if obs is None or obs.listening is None or first is None or not trace.uart:
        return
    start = trace.uart[0][0]
    if start < obs.listening:
        on = obs.listening * float(target.cycle_us)
        raise _Stop(f"{path}: line {first.line}: the bytes at {float(first.time_us) / 1000:g} ms start before the "
                    f"firmware's serial line receives ({on / 1000:.3f} ms after reset): a chip would miss them or read "
                    f"a wrong byte; send them from {math.ceil(on) / 1000:g} ms on")


def verify_data(report, source, plan: Plan) -> dict:
    """`servoc verify --format json`: the summary's numbers and every mismatch."""
    cycle = plan.program.target.cycle_us

    def us(cycles):         # machine cycles -> µs at the program's clock (3 decimals: ns)
        return None if cycles is None else round(float(cycles * cycle), 3)

    return {"file": source.path, "ok": report.ok, "frames": report.frames, "pulses": report.pulses,
            "max_error_cycles": report.max_error_cycles, "machine_cycle_us": float(cycle),
            "planned_period_us": plan.period_us, "planned_period_cycles": plan.program.target.cycles(plan.period_us),
            "period_cycles": {"min": report.period_min, "max": report.period_max, "mean": report.period_mean},
            "period_us": {"min": us(report.period_min), "max": us(report.period_max), "mean": us(report.period_mean)},
            "reset_low_cycles": report.reset_low_cycles, "reset_low_us": us(report.reset_low_cycles),
            "bytes_sent": report.bytes_sent,
            "mismatches": [{"frame": m.frame, "servo": m.servo, "pin": m.pin,
                            "expected_cycles": m.expected_us, "measured_cycles": m.measured_us,
                            "expected_us": us(m.expected_us), "measured_us": us(m.measured_us), "what": m.what}
                           for m in report.mismatches],
            "selects": [{"line": r.line, "frame": r.frame, "time_us": round(r.time_us, 3), "branch": r.branch,
                         "event": r.event, "waited_frames": r.waited} for r in report.reactions],
            "warnings": list(report.warnings), "not_checked": list(report.unchecked),
            "partial": report.ok and bool(report.unchecked), "span_s": round(report.span_s, 6),
            "ended": report.ended}


def _plan_line(plan: Plan) -> str:
    servos = len(plan.channels)
    ports = ", ".join(f"P{p}" for p in plan.ports) or "no ports"
    kind = "default" if plan.period_is_default else "frame"
    if has_selects(plan):
        length = "runs as its events come"
    elif plan.total_frames is None:
        length = "loops forever"
    else:
        length = (f"{plan.total_frames} frame{'' if plan.total_frames == 1 else 's'} = "
                  f"{fmt_ms(plan.total_frames * plan.period_us)}")
    return (f"{servos} servo{'s' if servos != 1 else ''} on {ports}, P = {fmt_ms(plan.period_us)} ({kind}; "
            f"shortest {fmt_ms(plan.min_period_us)}{'; built for size' if plan.compact else ''}"
            f"{'; the ports pulse overlapping' if plan.rises_among_falls else ''}"
            f"{'; the ports pulse overlapping, all at once' if plan.ports_at_once else ''}), program {length}")


def _plan_rows(plan: Plan, source) -> list:
    """Every move instance in source order: (line, pose, frames, ms, ease, [(servo, delta or "set", speed %)])."""
    rows = []
    for inst in sorted(plan.moves, key=lambda m: m.step.span.start):
        line, _ = source.line_col(inst.step.span.start)
        ms = Fraction(inst.frames * plan.period_us, 1000)
        cells = []
        power_up = any(inst.step is st for st in plan.power_up)
        for m in inst.motions:
            if power_up:            # the home pose's first pulses set the servos
                cells.append((plan.channels[m.channel].name, "set", None))
                continue
            if m.n0 is not None and m.delta == 0:
                continue
            ch = plan.channels[m.channel]
            t_dav = plan.class_t_dav_us[ch.speed_class]
            speed = abs(m.delta) * t_dav * 100 / (inst.frames * plan.period_us)
            cells.append((ch.name, "set" if m.n0 is None else f"{m.delta:+d}",
                          None if m.n0 is None else round(float(speed))))
        rows.append((line, inst.step.pose, inst.frames, float(ms), inst.step.ease, cells))
    return rows


def event_words(ev) -> str:
    """What makes an event happen, in words: `when ...`."""
    if ev.other:
        return "a byte no other `on` of the select names is received"
    if ev.input is None:
        return f"byte {ev.byte} is received"
    if ev.edge == "press":
        return f"input `{ev.input}` becomes active (a press)"
    if ev.edge == "release":
        return f"input `{ev.input}` becomes inactive (a release)"
    return f"input `{ev.input}` is active"


def _branch_rows(plan: Plan, source) -> list:
    """Every branch of every select and every send, in source order: (line, head, frames or None, what)."""
    rows = []
    for st in steps(plan):
        if isinstance(st, SelectStep):
            line, _ = source.line_col(st.span.start)
            for b in st.branches:
                b_line, _ = source.line_col(b.span.start)
                if isinstance(b, AfterBranch):
                    what = f"after {b.frames} frame{'s' if b.frames != 1 else ''} with no event"
                else:
                    what = "when " + event_words(b.event)
                head = ("wait " if st.wait else "") + (b.event.text if st.wait else branch_text(b))
                rows.append((b_line, head, b.frames if isinstance(b, AfterBranch) else None,
                             what + ("" if st.wait else f" (select at line {line})")))
        elif isinstance(st, SendStep):
            line, _ = source.line_col(st.span.start)
            rows.append((line, f"send {st.text}", 0, f"byte {st.byte}, takes no frame"))
    return sorted(rows, key=lambda r: r[0])


def plan_data(plan: Plan, source) -> dict:
    """`servoc plan --format json`: the table's rows as objects, and the period and length; with
    selects, their branches (and the sends) too."""
    data = {"file": source.path, "period_us": plan.period_us, "period_is_default": plan.period_is_default,
            "min_period_us": plan.min_period_us, "total_frames": plan.total_frames, "dav_deg": float(DAV_DEG),
            "built_for_size": plan.compact,
            "moves": [{"line": line, "pose": pose, "frames": frames, "ms": ms, "ease": ease,
                       "servos": [{"servo": name, "delta": None if delta == "set" else int(delta),
                                   "speed_percent": speed} for name, delta, speed in cells]}
                      for line, pose, frames, ms, ease, cells in _plan_rows(plan, source)]}
    if has_selects(plan):
        data["branches"] = [{"line": line, "branch": head, "frames": frames, "what": what}
                            for line, head, frames, what in _branch_rows(plan, source)]
    if plan.startup:
        data["startup"] = {"frames": startup_frames(plan),
                           "servos": [{"servo": plan.channels[ch].name, "frame": f,
                                       "ms": (f - 1) * plan.period_us / 1000} for ch, f in plan.startup]}
    if any(isinstance(st, HostStep) for st in steps(plan)):
        from .model import host_channel
        data["host"] = {"protocol": plan.program.host,
                        "channels": [{"channel": host_channel(c.servo), "servo": c.name}
                                     for c in sorted(plan.channels, key=lambda c: host_channel(c.servo))],
                        "sequences": [q.name for q in plan.program.sequences],
                        "playable": list(host_playable(plan.program))}
    if len(plan.rise_offsets) == len(plan.ports) > 0:
        data["ports"] = _port_rises(plan)
        data["rise_steps"] = plan.rise_steps
        data["rises_among_falls"] = plan.rises_among_falls
        data["ports_at_once"] = plan.ports_at_once
    if plan.cuts:
        data["interruptible"] = [{"line": source.line_col(st.span.start)[0],
                                  "servos": [{"servo": c.name, "low": lo, "high": hi, "unset": unset}
                                             for c, (lo, hi, unset) in _ranges(plan, hull)]}
                                 for st, hull in plan.cuts]
    return data


def _host_reading(plan) -> str:
    """`servoc plan`'s line on what `host` reads a frame and holds (docs/host-protocol.md, Timing)."""
    from .flow import frame_bytes, host_passes, host_xram, reads_answers
    from .layout import host_holds
    k = host_holds(plan)
    held = (f"{k} entr{'y' if k == 1 else 'ies'} held while a group waits" if k else
            "no entry held while a group waits (the reading stops before a line's second entry"
            + (" for a servo of the group)" if host_xram(plan) else ")"))
    return (f"host reading: {float(frame_bytes(plan)):.1f} bytes a frame at {plan.program.serial.baud} baud "
            f"(a host 2 % fast), up to {host_passes(plan)} read; its state in "
            + ("XRAM" if host_xram(plan) else "internal RAM") + f"; {held}; Q, QP and VER lines after a group line "
            + ("read on" if reads_answers(plan) else "wait for its commit"))


def _port_rises(plan: Plan) -> list[dict]:
    """Each port's rise in the frame (µs from the first port's) and the highest N its lines reach."""
    from .flow import port_tops
    return [{"port": p, "rise_us": r, "top": t} for p, r, t in zip(plan.ports, plan.rises_us(), port_tops(plan))]


def startup_frames(plan: Plan) -> int:
    """Frames of the power-up (`home`, `stagger`): up to the last servo's first pulse."""
    return max(f for _, f in plan.startup)


def _ranges(plan: Plan, hull) -> list:
    """(channel, (low N, high N, may have no target yet)) of each servo a meanwhile body can leave anywhere."""
    from .steps import Reach
    out = []
    for c, v in zip(plan.channels, hull):
        if v is None:
            continue
        r = v if isinstance(v, Reach) else Reach(v, v)
        out.append((c, (r.lo, r.hi, r.unset)))
    return out


def plan_table(plan: Plan, source, csv_out: bool = False) -> str:
    """Every move instance: line, pose, frames, duration, each servo's delta and speed in % of its top speed."""
    rows = _plan_rows(plan, source)
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
    lines = []
    for line, pose, frames, ms, ease, cells in rows:
        servos = ", ".join(f"{n} {d}" + ("" if s is None else f" ({s}%)") for n, d, s in cells) or "(already there)"
        tag = "" if ease == "linear" else f" [{ease}]"
        lines.append((line, 1, f"{line:>5}  {pose:<14} {frames:>6} {ms:>9.1f}  {servos}{tag}"))
    for line, head, frames, what in _branch_rows(plan, source):
        f_text = "-" if frames is None else str(frames)
        ms_text = "-" if frames is None else f"{frames * plan.period_us / 1000:.1f}"
        lines.append((line, 0, f"{line:>5}  {head:<14} {f_text:>6} {ms_text:>9}  {what}"))
    out += [text for _, _, text in sorted(lines, key=lambda x: (x[0], x[1]))]
    if len(plan.rise_offsets) == len(plan.ports) > 1:        # where each port's pulses begin in the frame
        out.append("ports: " + ", ".join(f"P{r['port']} rises at {fmt_ms(r['rise_us'])} (its lines reach N {r['top']})"
                                         for r in _port_rises(plan))
                   + (f"; a rise less than {costs.SPLIT} cycles after the last fall before it is a step of that "
                      "fall's run of the edge handler" if plan.rise_steps else "")
                   + ("; each port's rise after the first comes among the falls of the port before it: the ports' "
                      "pulses overlap" if plan.rises_among_falls else "")
                   + ("; every port rises at once (3 cycles apart) and the falls of every port are one timeline: "
                      "the ports' pulses overlap whole" if plan.ports_at_once else ""))
    if plan.startup:
        frames = startup_frames(plan)
        how = (f"`home {plan.program.home.name}`" if plan.program.home is not None
               else f"`stagger` at the first move's pose `{plan.power_up[0].pose}`")
        out.append(f"power-up: {how}, {frames} frame{'s' if frames != 1 else ''} = "
                   f"{fmt_ms(frames * plan.period_us)} before the program's first frame: "
                   + ", ".join(f"{plan.channels[ch].name} at {fmt_ms((f - 1) * plan.period_us)}" for ch, f in plan.startup))
    hosts = [st for st in steps(plan) if isinstance(st, HostStep)]
    if hosts:
        from .model import host_channel
        chans = sorted((host_channel(c.servo), c.name) for c in plan.channels)
        playable = host_playable(plan.program)
        where = ", ".join(str(source.line_col(st.span.start)[0]) for st in hosts)
        out.append(f"host (line{'s' if len(hosts) > 1 else ''} {where}): SSC-32 channels "
                   + ", ".join(f"{k} {name}" for k, name in chans)
                   + ("; PL 0 SQ n plays " + ", ".join(f"{i} `{q.name}`" for i, q in enumerate(plan.program.sequences)
                                                       if q.name in playable)
                      if playable else "")
                   + ("; PL 0 SQ n does nothing for " + ", ".join(f"{i} `{q.name}`" for i, q in enumerate(plan.program.sequences)
                                                                  if q.name not in playable)
                      + " (each runs `host`)" if len(playable) < len(plan.program.sequences) else ""))
        out.append(_host_reading(plan))
    for st, hull in plan.cuts:
        line = source.line_col(st.span.start)[0]
        spans = [f"{c.name} N {lo}..{hi}" + (" (or no target yet)" if unset else "") for c, (lo, hi, unset) in _ranges(plan, hull)]
        out.append(f"select at line {line}: an event can cut its meanwhile body where " + (", ".join(spans) or "nothing has a target")
                   + " (the moves after it are checked from every one of these)")
    if has_selects(plan):
        out.append("total: depends on the events (each move above is listed once per state it can start in)")
    elif plan.total_frames is None:
        out.append("total: the program loops forever")
    else:
        out.append(f"total: {plan.total_frames} frames = {fmt_ms(plan.total_frames * plan.period_us)}, "
                   "then the last targets repeat")
    return "\n".join(out) + "\n"
