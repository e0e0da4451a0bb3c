"""Tests of servoc.toolchain: sdas8051/sdld wrapper, HEX output, tool lookup."""

from __future__ import annotations

import io
import os
import shutil
import stat
from pathlib import Path

import pytest
from intelhex import IntelHex

from servoc import sim, toolchain
from servoc.toolchain import (
    AssemblyError,
    HexImage,
    ToolNotFound,
    assemble,
    find_tool,
    rom_end,
    rom_used,
    write_atomic,
)

pytestmark = pytest.mark.toolchain

ASM_DIR = Path(__file__).parent / "asm"

TINY = """\
; tiny program: a jump over the Timer0 vector, a table and an equate
\t.area CSEG (ABS,CODE)
\t.org 0x0000
\t.globl start, table, LIMIT
start:\tljmp main
\t.org 0x000B
\treti
\t.org 0x0030
main:\tmov p1,#0xA5
\tsetb p1.3
\tsjmp main
table::\t.db 0x12, 0x34
\t.dw 0xBEEF
LIMIT = 0x55
"""


def _ihex(hex_text: str) -> IntelHex:
    ih = IntelHex()
    ih.loadhex(io.StringIO(hex_text))
    return ih


def test_tiny_program_bytes_at_known_addresses():
    image = assemble(TINY)
    assert isinstance(image, HexImage)
    ih = _ihex(image.hex_text)
    assert [ih[a] for a in range(3)] == [0x02, 0x00, 0x30]  # LJMP 0x0030
    assert ih[0x0B] == 0x32  # RETI
    main = [0x75, 0x90, 0xA5, 0xD2, 0x93, 0x80, 0xF9]  # MOV P1,#A5; SETB P1.3; SJMP main
    assert [ih[0x30 + i] for i in range(len(main))] == main
    assert [ih[0x37 + i] for i in range(4)] == [0x12, 0x34, 0xBE, 0xEF]  # .db, .dw big-endian
    assert sorted(ih.addresses()) == [0, 1, 2, 0x0B] + list(range(0x30, 0x3B))
    assert image.code_bytes == 3 + 1 + 7 + 4


def test_symbols_come_from_the_map():
    image = assemble(TINY)
    # Only globals defined by the module: no linker s_/l_ area symbols, no
    # local labels (main is not global).
    assert image.symbols == {"LIMIT": 0x55, "start": 0x0000, "table": 0x0037}


def test_listing_has_final_addresses_and_code():
    image = assemble(TINY)
    assert "75 90 A5" in image.listing
    assert "000030" in image.listing


def test_hex_text_is_clean_intel_hex():
    image = assemble(TINY)
    lines = image.hex_text.split("\n")
    assert lines[-1] == ""  # ends with a newline
    assert lines[-2] == ":00000001FF"
    assert all(ln.startswith(":") for ln in lines[:-1])
    assert "\r" not in image.hex_text
    # only data records and the EOF record (no start address records)
    assert {ln[7:9] for ln in lines[:-1]} == {"00", "01"}
    assert all(int(ln[1:3], 16) <= 16 for ln in lines[:-1])


def test_assemble_is_deterministic():
    first = assemble(TINY)
    second = assemble(TINY)
    assert first.hex_text == second.hex_text
    assert first.hex_text.encode() == second.hex_text.encode()
    assert first.symbols == second.symbols
    assert first.listing == second.listing
    # the module name only names the temporary files
    assert assemble(TINY, name="other").hex_text == first.hex_text


def test_result_holds_no_temporary_paths():
    image = assemble(TINY)
    for text in (image.hex_text, image.listing):
        assert "servoc-as-" not in text
        assert "/tmp" not in text


def test_undefined_symbol_reports_file_and_line():
    src = "\t.area CSEG (ABS,CODE)\n\t.org 0\n\tnop\n\tljmp nowhere\n"
    with pytest.raises(AssemblyError) as info:
        assemble(src, name="fw")
    err = info.value
    assert [(m.file, m.line) for m in err.messages] == [("fw.asm", 4)]
    assert "undefined symbol" in err.messages[0].message
    assert "fw.asm:4:" in str(err)
    assert "fw.asm:4" in err.output


def test_bad_mnemonic_reports_line():
    src = "\t.area CSEG (ABS,CODE)\n\t.org 0\n\tnop\n\tnop\n\tfrobnicate a\n"
    with pytest.raises(AssemblyError) as info:
        assemble(src)
    assert [m.line for m in info.value.messages] == [5]


def test_unresolved_global_is_a_link_error():
    src = "\t.area CSEG (ABS,CODE)\n\t.globl elsewhere\n\t.org 0\n\tljmp elsewhere\n"
    with pytest.raises(AssemblyError) as info:
        assemble(src)
    assert "sdld" in str(info.value)
    assert "elsewhere" in str(info.value)


def test_invalid_module_name():
    with pytest.raises(ValueError):
        assemble(TINY, name="../evil")


def test_rom_used_and_rom_end():
    image = assemble(TINY)
    assert rom_used(image.hex_text) == image.code_bytes
    assert rom_end(image.hex_text) == 0x3B
    assert rom_end(":00000001FF\n") == 0
    assert rom_used(":00000001FF\n") == 0
    with pytest.raises(ValueError):
        rom_used(":0100000000FE\n")  # bad checksum


# -- tool lookup -------------------------------------------------------------


@pytest.mark.parametrize("tool", ["sdas8051", "sdld", "s51"])
def test_find_tool_on_path(tool, monkeypatch):
    monkeypatch.delenv(toolchain._TOOLS[tool][0], raising=False)
    path = find_tool(tool)
    assert os.access(path, os.X_OK)
    assert Path(path).name == tool


def test_find_tool_override(monkeypatch, tmp_path):
    real = shutil.which("sdas8051")
    assert real is not None
    link = tmp_path / "my-sdas"
    link.symlink_to(real)
    monkeypatch.setenv("SERVOC_SDAS8051", str(link))
    assert find_tool("sdas8051") == str(link)
    image = assemble(TINY)
    assert image.code_bytes == 15


def test_missing_override_raises_tool_not_found(monkeypatch, tmp_path):
    missing = tmp_path / "no-such-sdas8051"
    monkeypatch.setenv("SERVOC_SDAS8051", str(missing))
    with pytest.raises(ToolNotFound) as info:
        find_tool("sdas8051")
    text = str(info.value)
    assert "sdas8051" in text
    assert "SERVOC_SDAS8051" in text
    assert str(missing) in text
    assert "apt-get install sdcc sdcc-ucsim" in text
    with pytest.raises(ToolNotFound):
        assemble(TINY)


def test_non_executable_override(monkeypatch, tmp_path):
    fake = tmp_path / "sdld"
    fake.write_text("not a program\n")
    fake.chmod(0o644)
    monkeypatch.setenv("SERVOC_SDLD", str(fake))
    with pytest.raises(ToolNotFound, match="not executable"):
        find_tool("sdld")


def test_tool_not_on_path_names_the_package(monkeypatch, tmp_path):
    monkeypatch.delenv("SERVOC_S51", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(ToolNotFound) as info:
        find_tool("s51")
    assert "'sdcc-ucsim'" in str(info.value)
    assert "SERVOC_S51" in str(info.value)


def test_sim_reports_missing_s51(monkeypatch, tmp_path):
    monkeypatch.setenv("SERVOC_S51", str(tmp_path / "s51"))
    image = assemble(TINY)
    with pytest.raises(ToolNotFound, match="s51"):
        sim.run(image.hex_text, 100)


def test_unknown_tool_name():
    with pytest.raises(ValueError):
        find_tool("gcc")


# -- write_atomic ------------------------------------------------------------


def test_write_atomic_text_and_bytes(tmp_path):
    target = tmp_path / "fw.hex"
    write_atomic(target, ":00000001FF\n")
    assert target.read_bytes() == b":00000001FF\n"
    write_atomic(target, b"\x00\x01\r\n")
    assert target.read_bytes() == b"\x00\x01\r\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fw.hex"]


def test_write_atomic_keeps_mode_of_existing_file(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    target.chmod(0o600)
    write_atomic(target, "new")
    assert target.read_text() == "new"
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    fresh = tmp_path / "fresh.txt"
    write_atomic(str(fresh), "x")
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o644


def test_write_atomic_failure_leaves_no_temp_file(tmp_path):
    target = tmp_path / "a-directory"
    target.mkdir()
    (target / "keep").write_text("k")
    with pytest.raises(OSError):
        write_atomic(target, "data")  # cannot replace a directory by a file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-directory"]
    assert (target / "keep").read_text() == "k"


def test_fixture_programs_assemble():
    for path in sorted(ASM_DIR.glob("*.asm")):
        image = assemble(path.read_text(), name=path.stem)
        assert image.code_bytes > 0, path.name
