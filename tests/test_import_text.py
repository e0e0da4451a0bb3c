"""Import reads what the authoring tools write: any encoding of a text format (UTF-8 with or
without BOM, UTF-16 with BOM, Windows-1252), Bottango's `sSY` lines whose parts end with `;`, and
a Bottango export cut short is an error that writes nothing."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from servoc.cli import main

ROOT = Path(__file__).resolve().parent.parent
CSV = "time_ms,arm\r\n0,1500\r\n1000,2000\r\n"


def run_import(tmp_path, capsys, name: str, data: bytes) -> tuple[int, str, Path]:
    src = tmp_path / name
    src.write_bytes(data)
    out = tmp_path / "out.servo"
    rc = main(["import", str(src), "-o", str(out)])
    captured = capsys.readouterr()
    return rc, captured.out + captured.err, out


@pytest.mark.parametrize("encoding", ["utf-8", "utf-8-sig", "utf-16", "cp1252"])
def test_a_csv_in_any_encoding(tmp_path, capsys, encoding):
    rc, said, out = run_import(tmp_path, capsys, "k.csv", CSV.replace("arm", "ärm" if encoding != "utf-16" else "arm")
                               .encode(encoding))
    assert rc == 0 and out.exists(), said
    text = out.read_text()
    assert "move k_0 in 0ms" in text and "move k_1 in 1000ms" in text, text
    assert re.search(r"pose k_0 \{ \w+: 1500us \}", text) and re.search(r"pose k_1 \{ \w+: 2004us \}", text), text


@pytest.mark.parametrize("encoding", ["utf-16", "cp1252"])
def test_a_maestro_file_in_utf16_or_windows_1252(tmp_path, capsys, encoding):
    text = (ROOT / "examples/import/wave.xml").read_text(encoding="utf-8")
    if encoding == "cp1252":
        text = text.replace('name="', 'name="Gelenk_\u00fc', 1)          # a German channel name
    rc, said, out = run_import(tmp_path, capsys, "w.xml", text.encode(encoding))
    assert rc == 0 and out.exists(), said
    reference = tmp_path / "ref.xml"
    reference.write_text((ROOT / "examples/import/wave.xml").read_text(encoding="utf-8"), encoding="utf-8")
    assert main(["import", str(reference), "-o", str(tmp_path / "ref.servo")]) == 0
    def moves(path):        # the moves, without their comments (which name the servos, renamed here)
        return [ln.split("#")[0] for ln in path.read_text().splitlines() if ln.strip().startswith("move")]
    assert moves(out) == moves(tmp_path / "ref.servo")


BOTTANGO = ('const char SETUP_DATA_0[] PROGMEM = "rSVPin,1,1000,2000,3000,1500\\n";\n'
            'const char ANIM_0_DATA0[] PROGMEM = "sSY,sC,1,0,1000,0,250,0,8192,-250,0;\\n";\n')


def test_bottango_ssy_parts_end_with_a_semicolon(tmp_path, capsys):
    rc, said, out = run_import(tmp_path, capsys, "GeneratedCodeAnimations.cpp", BOTTANGO.encode())
    assert rc == 0 and out.exists(), said
    assert sum(ln.strip().startswith("move") for ln in out.read_text().splitlines()) >= 2


@pytest.mark.parametrize("cut", [110, len(BOTTANGO) - 20])
def test_a_bottango_export_cut_short_is_an_error_and_writes_nothing(tmp_path, capsys, cut):
    data = BOTTANGO.encode()[:cut]
    if cut > 110:                                   # cut inside the last command, the string closed again
        data = BOTTANGO[:cut].encode() + b'";\n'
    rc, said, out = run_import(tmp_path, capsys, "GeneratedCodeAnimations.cpp", data)
    assert rc == 2 and not out.exists() and "cut short" in said, said


def test_a_csv_with_a_lone_carriage_return_is_a_clear_error(tmp_path, capsys):
    rc, said, out = run_import(tmp_path, capsys, "x.csv", b"time_ms,a,b\n\r\x00")
    assert rc == 2 and not out.exists() and "Traceback" not in said and "x.csv" in said, said
