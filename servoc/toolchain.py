"""Toolchain wrapper: 8051 assembly text -> Intel HEX image, via SDCC's tools.

Input
    `assemble` takes the complete text of one sdas8051 assembly module.  The
    module must place its code absolutely, which is how the firmware
    templates write it::

        .area CSEG (ABS,CODE)
        .org 0x0000
        ljmp main
        .org 0x002B          ; Timer2 vector
        ...

    Several ``.org`` directives inside one ABS area are fine (sdas8051 splits
    them into sub-areas CSEG0, CSEG1, ...; each keeps its absolute address).
    Relocatable code areas (``.area X (CODE)``) also link, placed one after
    another from address 0 in order of appearance (sdld's default), but
    interrupt vectors need absolute placement.
    The assembler predefines the 8051/8052 SFR and bit names in both cases
    (``P1``, ``p1.0``, ``RCAP2H``, ``TF2``, ...).  Symbols must all be defined
    in the module: it is assembled without ``-g``, so an undefined name is an
    error with a line number instead of an unresolved global at link time.

Output
    `HexImage`: the Intel HEX text (16 data bytes per record, ascending
    addresses, LF line ends, no start-address record, ends with the EOF
    record), the number of code bytes it defines, the address of every
    symbol the module defines as global (``.globl name`` or ``name::``,
    including global equates), and the assembler listing (after linking,
    i.e. with final addresses).

Invariants
    * Deterministic: the same assembly text gives a byte-identical HexImage
      (no timestamps, no temporary paths anywhere in the result).
    * Every tool runs in a fresh temporary directory with relative file
      names, stdin from /dev/null and a timeout; nothing is left behind.
    * Errors are exceptions: `ToolNotFound` when a tool is missing,
      `AssemblyError` (with the tool output and parsed ``file:line``
      messages) when assembling or linking fails.  Linker warnings (e.g. an
      undefined global) count as failures.

Commands run (in the temporary directory, NAME = the `name` argument)::

    sdas8051 -plosff NAME.asm       # -p no pagination, -l listing, -o object,
                                    # -s symbol file, -ff flag relocations
    sdld -n -m -w -u -i NAME.ihx NAME.rel
                                    # -n quiet, -m/-w wide map, -u listing
                                    # with final addresses (NAME.rst),
                                    # -i Intel HEX output

The linker's HEX is then re-emitted with `intelhex` (normalised records).
Tool paths: environment variables SERVOC_SDAS8051, SERVOC_SDLD, SERVOC_S51,
SERVOC_PACKIHX override the search on PATH.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

__all__ = [
    "AssemblyError",
    "AsmMessage",
    "HexImage",
    "ToolNotFound",
    "ToolchainError",
    "assemble",
    "find_tool",
    "rom_end",
    "rom_used",
    "rom_used_in",
    "write_atomic",
]

TOOL_TIMEOUT = 60.0
"""Seconds any single assembler or linker run may take."""

# tool name -> (override variable, Debian package providing it)
_TOOLS: dict[str, tuple[str, str]] = {
    "sdas8051": ("SERVOC_SDAS8051", "sdcc"),
    "sdld": ("SERVOC_SDLD", "sdcc"),
    "packihx": ("SERVOC_PACKIHX", "sdcc"),
    "s51": ("SERVOC_S51", "sdcc-ucsim"),
}

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class ToolchainError(Exception):
    """Base class of the errors raised by this module."""


class ToolNotFound(ToolchainError):
    """A required external tool is not installed (or its override is bad)."""

    def __init__(self, tool: str, detail: str = ""):
        env, package = _TOOLS.get(tool, ("", "sdcc"))
        text = f"{tool} not found"
        if detail:
            text += f" ({detail})"
        text += (
            f"; install it (Debian/Ubuntu: apt-get install sdcc sdcc-ucsim;"
            f" {tool} is in the '{package}' package)"
        )
        if env:
            text += f" or set {env} to the path of the executable"
        super().__init__(text)
        self.tool = tool


@dataclass(frozen=True)
class AsmMessage:
    """One diagnostic line of the assembler or linker."""

    file: str
    line: int  # 1-based line in `file`; 0 when the tool gave none
    message: str

    def __str__(self) -> str:
        if self.line:
            return f"{self.file}:{self.line}: {self.message}"
        return f"{self.file}: {self.message}"


class AssemblyError(ToolchainError):
    """Assembling or linking failed.

    `output` is the tool's complete output (stdout then stderr); `messages`
    are the parsed ``file:line: message`` diagnostics (may be empty when the
    tool printed nothing parseable, e.g. on a timeout).
    """

    def __init__(self, summary: str, output: str = "", messages: tuple[AsmMessage, ...] = ()):
        self.summary = summary
        self.output = output
        self.messages = tuple(messages)
        lines = [summary]
        if self.messages:
            lines.extend(f"  {m}" for m in self.messages)
        elif output.strip():
            lines.extend(f"  {ln}" for ln in output.strip().splitlines())
        super().__init__("\n".join(lines))


@dataclass(frozen=True)
class HexImage:
    """An assembled and linked firmware image."""

    hex_text: str
    code_bytes: int
    symbols: dict[str, int] = field(default_factory=dict)
    listing: str = ""


def find_tool(name: str) -> str:
    """Path of the executable `name` (sdas8051, sdld, s51 or packihx).

    The override variable (SERVOC_SDAS8051, SERVOC_SDLD, SERVOC_S51,
    SERVOC_PACKIHX) wins when set and non-empty; it must name an existing
    executable file, else `ToolNotFound`.  Otherwise the tool is looked up
    on PATH.
    """
    if name not in _TOOLS:
        raise ValueError(f"unknown tool {name!r}; expected one of {sorted(_TOOLS)}")
    env, _package = _TOOLS[name]
    override = os.environ.get(env, "")
    if override:
        path = Path(override)
        if not path.is_file():
            raise ToolNotFound(name, f"{env}={override} does not exist")
        if not os.access(path, os.X_OK):
            raise ToolNotFound(name, f"{env}={override} is not executable")
        return str(path)
    found = shutil.which(name)
    if found is None:
        raise ToolNotFound(name, "not on PATH")
    return found


def _run(argv: list[str], cwd: str, what: str) -> subprocess.CompletedProcess[str]:
    try:
        return subprocess.run(
            argv,
            cwd=cwd,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            errors="replace",
            timeout=TOOL_TIMEOUT,
            check=False,
        )
    except subprocess.TimeoutExpired as exc:
        out = _as_text(exc.stdout) + _as_text(exc.stderr)
        raise AssemblyError(f"{what} timed out after {TOOL_TIMEOUT:g} s", out) from None
    except OSError as exc:
        raise ToolNotFound(Path(argv[0]).name, f"cannot run {argv[0]}: {exc.strerror}") from None


def _as_text(data: str | bytes | None) -> str:
    if data is None:
        return ""
    if isinstance(data, bytes):
        return data.decode("utf-8", "replace")
    return data


# sdas8051: "fw.asm:5: Error: <o> .org in REL area or directive / mnemonic error"
_AS_MSG_RE = re.compile(r"^(?P<file>[^\s:]+):(?P<line>\d+):\s*(?P<msg>.*\S)\s*$")
# sdld: "?ASlink-Warning-Undefined Global 'bar' referenced by module ''"
_LD_MSG_RE = re.compile(r"^\?ASlink-(?P<msg>(?:Warning|Error)-.*\S)\s*$")


def _parse_messages(output: str, default_file: str) -> tuple[AsmMessage, ...]:
    msgs: list[AsmMessage] = []
    for raw in output.splitlines():
        m = _AS_MSG_RE.match(raw.strip())
        if m:
            msgs.append(AsmMessage(m["file"], int(m["line"]), m["msg"]))
            continue
        m = _LD_MSG_RE.match(raw.strip())
        if m:
            msgs.append(AsmMessage(default_file, 0, m["msg"]))
    return tuple(msgs)


def assemble(asm_text: str, name: str = "firmware") -> HexImage:
    """Assemble and link `asm_text`; see the module docstring for the rules.

    `name` is the base name of the files inside the temporary directory (so
    it appears in error messages as ``NAME.asm:LINE``); it must be a plain
    identifier.
    """
    if not _NAME_RE.match(name):
        raise ValueError(f"invalid module name {name!r}: use letters, digits and '_'")
    sdas = find_tool("sdas8051")
    sdld = find_tool("sdld")
    asm_file = f"{name}.asm"
    with tempfile.TemporaryDirectory(prefix="servoc-as-") as tmp:
        tmpdir = Path(tmp)
        text = asm_text if asm_text.endswith("\n") else asm_text + "\n"
        (tmpdir / asm_file).write_bytes(text.encode("utf-8"))

        proc = _run([sdas, "-plosff", asm_file], tmp, "sdas8051")
        out = proc.stdout + proc.stderr
        msgs = _parse_messages(out, asm_file)
        if proc.returncode != 0 or any("Error" in m.message for m in msgs) or not (tmpdir / f"{name}.rel").is_file():
            raise AssemblyError(f"sdas8051 failed on {asm_file} (exit status {proc.returncode})", out, msgs)

        proc = _run([sdld, "-n", "-m", "-w", "-u", "-i", f"{name}.ihx", f"{name}.rel"], tmp, "sdld")
        out = proc.stdout + proc.stderr
        msgs = _parse_messages(out, asm_file)
        ihx = tmpdir / f"{name}.ihx"
        if proc.returncode != 0 or msgs or not ihx.is_file():
            raise AssemblyError(f"sdld failed on {name}.rel (exit status {proc.returncode})", out, msgs)

        hex_text = _normalize_hex(ihx.read_text(encoding="ascii", errors="replace"))
        map_path = tmpdir / f"{name}.map"
        map_text = map_path.read_text(errors="replace") if map_path.is_file() else ""
        rel_text = (tmpdir / f"{name}.rel").read_text(errors="replace")
        symbols = _symbols(rel_text, map_text)
        listing = ""
        for ext in ("rst", "lst"):
            p = tmpdir / f"{name}.{ext}"
            if p.is_file():
                listing = p.read_text(errors="replace")
                break
    return HexImage(hex_text=hex_text, code_bytes=rom_used(hex_text), symbols=symbols, listing=listing)


def _load_hex(hex_text: str):
    from intelhex import IntelHex, IntelHexError

    ih = IntelHex()
    try:
        ih.loadhex(io.StringIO(hex_text))
    except IntelHexError as exc:
        raise ValueError(f"invalid Intel HEX: {exc}") from None
    return ih


def _normalize_hex(hex_text: str) -> str:
    ih = _load_hex(hex_text)
    buf = io.StringIO()
    ih.write_hex_file(buf, write_start_addr=False, byte_count=16)
    return buf.getvalue().replace("\r\n", "\n")


def rom_used(hex_text: str) -> int:
    """Number of code bytes defined by an Intel HEX text."""
    return len(_load_hex(hex_text).addresses())


def rom_used_in(hex_text: str, start: int, end: int) -> int:
    """Number of code bytes an Intel HEX text defines at addresses start..end-1."""
    return sum(1 for a in _load_hex(hex_text).addresses() if start <= a < end)


def rom_end(hex_text: str) -> int:
    """One past the highest code address defined (0 for an empty image).

    Compare with the target chip's `code_bytes` (servoc.target) to check that the image fits.
    """
    addrs = _load_hex(hex_text).addresses()
    return (max(addrs) + 1) if addrs else 0


# .rel: "S start Def000000" = symbol defined (and global) in this module
_REL_DEF_RE = re.compile(r"^S\s+(\S+)\s+Def([0-9A-Fa-f]+)\s*$", re.M)
# .map: "C:   0000000D  tbl" or "     00000055  K" (value, then name)
_MAP_SYM_RE = re.compile(r"^\s*(?:[A-Z]:)?\s*([0-9A-Fa-f]{4,8})\s+(\S+)\s*$", re.M)


def _symbols(rel_text: str, map_text: str) -> dict[str, int]:
    """Global symbols defined by the module, with their linked addresses.

    The object file says which globals the module defines (this excludes the
    linker's own s_AREA / l_AREA symbols); the map gives the final values
    (the object's value is used when the map lacks the name).
    """
    defined = {name: int(val, 16) for name, val in _REL_DEF_RE.findall(rel_text) if not name.startswith(".__.")}
    linked: dict[str, int] = {}
    for val, name in _MAP_SYM_RE.findall(map_text):
        if name in defined:
            linked[name] = int(val, 16)
    return {name: linked.get(name, defined[name]) for name in sorted(defined)}


def write_atomic(path: str | os.PathLike[str], data: str | bytes) -> None:
    """Write `data` to `path` atomically (temp file in the same directory,
    fsync, `os.replace`).  A str is written as UTF-8 without newline
    translation.  An existing file keeps its permission bits; a new one gets
    0o644.  On any error the temporary file is removed and `path` is
    untouched.
    """
    target = Path(path)
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    directory = target.parent if str(target.parent) else Path(".")
    try:
        mode = target.stat().st_mode & 0o7777
    except FileNotFoundError:
        mode = 0o644
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(payload)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp_name, mode)
        os.replace(tmp_name, target)
    except BaseException:
        try:
            os.unlink(tmp_name)
        except FileNotFoundError:
            pass
        raise
