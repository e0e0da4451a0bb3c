"""`servoc flash`: write the compiled HEX to a board, or say exactly how.

The chip is the program's `target` (`plan.program.target.chip`):

* STC89C52RC and STC89C58RD+ are written through their serial bootloader by
  stcgal's Python API (`stcgal.frontend.StcGal`), protocol `stc89`, on the
  serial port `--port`; the option byte's 6T bit is set to the program's
  `mode` (`cpu_6t_enabled`), since the firmware's timing depends on it.
  stcgal is an optional dependency (extra `flash`), imported only here; its
  absence raises `MissingStcgal`.
* The Atmel chips have no bootloader servoc can drive: `command` gives the
  exact avrdude (AT89S52; avrdude 7.1 or later, with a programmer that drives
  reset active-high) or minipro (AT89C52, AT89C55WD) command line from
  `Chip.flash`, with the real HEX path in place of `prog.hex`.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import shlex
from typing import IO

from .target import Chip, Target

__all__ = ["BAUDS", "DEFAULT_BAUD", "HANDSHAKE_BAUD", "MISSING", "MissingStcgal", "PROTOCOL", "command", "how",
           "load_stcgal", "needs_hex_name", "stcgal_options", "uses_stcgal", "write_stc"]

PROTOCOL = "stc89"                      # stcgal's protocol for the STC89/90 bootloader
DEFAULT_BAUD = 115200                   # stcgal's default transfer rate
HANDSHAKE_BAUD = 2400                   # stcgal's default handshake rate
BAUDS = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)   # rates the STC89 bootloader is asked for
HEX_SUFFIXES = (".hex", ".ihx", ".ihex")    # stcgal reads a file as Intel HEX only by these names
MISSING = "servoc flash needs stcgal: pip install 'servoc[flash]'"


class MissingStcgal(ImportError):
    """stcgal (or its pyserial) cannot be imported."""

    def __init__(self):
        super().__init__(MISSING, name="stcgal")


def uses_stcgal(chip: Chip) -> bool:
    """Whether servoc writes this chip itself, through stcgal (the STC89 family)."""
    return chip.name.startswith("stc")


def needs_hex_name(path: str) -> bool:
    """Whether stcgal would take `path` for a binary image (it tells Intel HEX by the name)."""
    return not path.lower().endswith(HEX_SUFFIXES)


def command(chip: Chip, hex_path: str) -> str:
    """The command line that writes `hex_path` to `chip`: the one in `chip.flash`, with the path
    (quoted for a POSIX shell where needed) in place of `prog.hex`."""
    found = re.search(r"`([^`]*prog\.hex[^`]*)`", chip.flash)
    if found is None:
        raise ValueError(f"no command in the flash text of {chip.display}: {chip.flash!r}")
    return shlex.join(word.replace("prog.hex", hex_path) for word in shlex.split(found.group(1)))


def how(chip: Chip) -> str:
    """What `chip.flash` says before its command, e.g. `a parallel programmer, e.g. a TL866 with minipro`."""
    return re.split(r":\s*`", chip.flash, maxsplit=1)[0]


def stcgal_options(port: str, code_image: IO[bytes], baud: int = DEFAULT_BAUD, six_t: bool = False
                   ) -> argparse.Namespace:
    """The options `stcgal.frontend.StcGal` takes (those of stcgal's own command line) to write
    `code_image`, an open Intel HEX file, over `port` with protocol stc89."""
    return argparse.Namespace(
        code_image=code_image, eeprom_image=None, erase=False,
        autoreset=False, resetpin="dtr", resetcmd=None,
        protocol=PROTOCOL, port=port, baud=baud, handshake=HANDSHAKE_BAUD,
        option=[f"cpu_6t_enabled={'true' if six_t else 'false'}"],
        trim=0.0, debug=False, version=False)


def _stcgal_frontend():
    try:
        from stcgal import frontend
    except ImportError as exc:          # stcgal, or the pyserial it needs
        raise MissingStcgal() from exc
    return frontend


def load_stcgal() -> None:
    """Raise MissingStcgal unless stcgal can be imported (checked before anything is written)."""
    _stcgal_frontend()


def write_stc(hex_path: str, port: str, target: Target, baud: int = DEFAULT_BAUD,
              log: IO[str] | None = None) -> int:
    """Write the Intel HEX file `hex_path` to an STC89 board on `port` with stcgal; stcgal's exit
    status (0: written). stcgal prints its progress (and asks to power-cycle the board) on
    standard output and its errors on standard error; with `log`, both go there instead."""
    frontend = _stcgal_frontend()
    with open(hex_path, "rb") as image:
        opts = stcgal_options(port, image, baud, target.six_t)
        with contextlib.ExitStack() as stack:
            if log is not None:
                stack.enter_context(contextlib.redirect_stdout(log))
                stack.enter_context(contextlib.redirect_stderr(log))
            rc = frontend.StcGal(opts).run()
    return rc if isinstance(rc, int) else 1
