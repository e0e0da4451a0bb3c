"""The reader for the Blender Servo Animation add-on's exports (servoc.imports.blender).

The fixtures in tests/fixtures/import/blender/ are one animation (3 servos,
20 frames at 30 fps) written by the `export_*` functions below, which follow the
add-on's exporters (JSON, Arduino header, binary; add-on 2.x). Regenerate them
with `python tests/test_import_blender.py`.
"""

from __future__ import annotations

import json
import os
import random
import time
from fractions import Fraction

import pytest
from conftest import damaged
from hypothesis import given, settings, strategies as st

from servoc.imports import blender
from servoc.imports.keyframes import MAX_FRAMES, Channel, ImportError_, Key, ReadOptions, Track, ticks_to_us, unit_note

FIXTURES = os.path.join(os.path.dirname(__file__), "fixtures", "import", "blender")
FPS = 30
IDS = (0, 10, 60)           # 10 = 0x0A (a line break), 60 = 0x3C (a record start)

# The width of each servo (ids 0, 10, 60) at each frame. 1852 = 0x073C, 2570 = 0x0A0A,
# 1290 = 0x050A, 1598 = 0x063E, 2620 = 0x0A3C, 2366 = 0x093E: marker bytes inside positions.
TABLE = [
    (1500, 1852, 2570), (1520, 1852, 2570), (1540, 2570, 2570), (1560, 2570, 1852),
    (1580, 1290, 1852), (1580, 1290, 1852), (1598, 1290, 2366), (1852, 1300, 2366),
    (1852, 1310, 2620), (2570, 1320, 2620),
] + [(2570 - 50 * j, 1320 + 10 * j, 2620 if j % 2 else 1852) for j in range(1, 11)]


def frames_of(table, ids=IDS, skip_unchanged=True):
    """Per frame {id: position}, leaving out unchanged servos as the add-on does by default."""
    frames, last = [], {}
    for row in table:
        frame = {i: p for i, p in zip(ids, row) if not (skip_unchanged and last.get(i) == p)}
        last.update(frame)
        frames.append(frame)
    return frames


def records(frames) -> bytes:
    out = bytearray()
    for frame in frames:
        for sid, position in frame.items():
            out += bytes((0x3C, sid)) + position.to_bytes(2, "big") + b"\x3e"
        out.append(0x0A)
    return bytes(out)


def export_bin(frames) -> bytes:
    return records(frames)


def export_json(frames, fps=FPS, indent=2) -> bytes:
    doc = {"description": "Blender Servo Animation Positions", "fps": fps, "frames": len(frames),
           "seconds": round(len(frames) / fps), "bones": len(frames[0]), "file": "anim.blend",
           "scene": "Scene", "positions": [{str(i): p for i, p in f.items()} for f in frames]}
    return json.dumps(doc, indent=indent).encode()


def export_h(frames, fps=FPS, namespace=None, include=True) -> str:
    data = records(frames)
    rows = "".join("    " + ", ".join(f"{b:#04x}" for b in data[i:i + 12]) + ",\n" for i in range(0, len(data), 12))
    text = (f"/*\n  Blender Servo Animation Positions\n\n  FPS: {fps}\n  Frames: {len(frames)}\n"
            f"  Seconds: {round(len(frames) / fps)}\n  Bones: {len(frames[0])}\n  Scene: {namespace or 'Scene'}\n"
            "  File: anim.blend\n*/\n\n" + ("#include <Arduino.h>\n" if include else ""))
    if namespace:
        text += f"\nnamespace {namespace} {{\n"
    text += (f"\nconst byte FPS = {fps};\nconst int FRAMES = {len(frames)};\nconst int LENGTH = {len(data)};\n\n"
             f"const byte PROGMEM ANIMATION_DATA[LENGTH] = {{\n{rows}}};\n")
    if namespace:
        text += f"\n}} // namespace {namespace}\n"
    return text


def generated() -> dict:
    frames = frames_of(TABLE)
    return {"anim.json": export_json(frames), "anim.h": export_h(frames).encode(), "anim.bin": export_bin(frames)}


GENERATED = generated()     # the fixtures' content, for the parameters of the broken-input tests


def fixture(name: str) -> bytes:
    with open(os.path.join(FIXTURES, name), "rb") as f:
        return f.read()


def read(data: bytes, path: str, **options):
    return blender.read(data, path, ReadOptions(**options))


def expected_track(table=TABLE, fps=FPS, name="anim", ids=IDS) -> Track:
    keys = tuple(Key(at_ms=Fraction(1000 * k) / fps, targets={i: Fraction(p) for i, p in zip(ids, row)},
                     source=f"frame {k}") for k, row in enumerate(table))
    return Track(name=name, keys=keys, sampled=True)


# --- one animation, three exports ---------------------------------------------------------------

def test_fixtures_are_what_the_writers_write():
    for name, data in generated().items():
        assert fixture(name) == data, f"{name} differs: run python tests/test_import_blender.py"


def test_the_three_exports_give_identical_keyframes():
    kf_json = read(fixture("anim.json"), "anim.json")
    kf_h = read(fixture("anim.h"), "anim.h")
    kf_bin = read(fixture("anim.bin"), "anim.bin", fps=Fraction(FPS))
    for kf in (kf_json, kf_h, kf_bin):
        assert kf.format == "blender"
        assert kf.channels == tuple(Channel(index=i, name=f"servo_{i}") for i in IDS)
        assert kf.tracks == (expected_track(),)
        assert kf.notes == (unit_note(None),)       # which unit the positions were read in
    assert kf_json == kf_h == kf_bin


def test_marker_bytes_inside_ids_and_positions_are_data():
    data = fixture("anim.bin")
    assert b"\x07\x3c" in data and b"\x0a\x0a" in data and b"\x3c\x0a" in data   # what fools a marker parser
    keys = read(data, "anim.bin", fps=Fraction(FPS)).tracks[0].keys
    assert len(keys) == 20
    assert keys[0].targets == {0: 1500, 10: 1852, 60: 2570}
    assert keys[2].targets == {0: 1540, 10: 2570, 60: 2570}
    assert keys[9].targets == {0: 2570, 10: 1320, 60: 2620}
    assert keys[3].at_ms == 100 and keys[1].at_ms == Fraction(100, 3) and keys[7].source == "frame 7"


def test_unchanged_servos_keep_their_position():
    frames = frames_of(TABLE)
    assert frames[5] == {} and frames[1] == {0: 1520}          # the add-on's "skip unchanged positions"
    assert b"\x3e\x0a\x0a\x3c" in fixture("anim.bin")           # frame 5 is a bare line break
    keys = read(fixture("anim.json"), "anim.json").tracks[0].keys
    assert keys[5].targets == keys[4].targets == {0: 1580, 10: 1290, 60: 1852}
    assert keys[1].targets == {0: 1520, 10: 1852, 60: 2570}


def test_a_servo_twice_in_a_frame_ends_at_the_last():
    data = records([{0: 1500}]) + b"\x3c\x00\x05\xf0\x3e\x3c\x00\x06\x40\x3e\x0a"
    keys = read(data, "a.bin", fps=Fraction(FPS)).tracks[0].keys
    assert [k.targets for k in keys] == [{0: 1500}, {0: 1600}]


def test_add_on_1x_counts_need_ticks_and_say_so():
    """1.4's JSON (servos by id) in the add-on's default range 150..600: neither degrees nor µs."""
    old = {"description": "Blender Servo Animation Positions", "fps": 30, "frames": 2, "armature": "Armature",
           "servos": {"0": {"name": "Neck", "positions": [375, 376]}}}
    assert blender.sniff(json.dumps(old).encode(), "old.json")
    with pytest.raises(ImportError_, match=r"^old\.json: Neck: positions 375\.\.376 of an add-on 1\.x export are "
                                           r"neither degrees .*--ticks HZ.* export the animation again with add-on 2\.x"):
        read(json.dumps(old).encode(), "old.json")
    kf = read(json.dumps(old).encode(), "old.json", ticks_hz=Fraction(50))
    assert kf.channels == (Channel(0, "Neck"),)
    assert [k.targets for k in kf.tracks[0].keys] == [{0: ticks_to_us(375, 50)}, {0: ticks_to_us(376, 50)}]


def test_full_frames_read_the_same_as_skipped_ones():
    full = frames_of(TABLE, skip_unchanged=False)
    assert read(export_bin(full), "a.bin", fps=Fraction(FPS)).tracks == read(fixture("anim.bin"), "a.bin", fps=Fraction(FPS)).tracks
    assert read(export_json(full, indent=None), "anim.json").tracks == (expected_track(),)


# --- frame rate --------------------------------------------------------------------------------

def test_fps_comes_from_the_json_and_the_header():
    for name in ("anim.json", "anim.h"):
        assert read(fixture(name), name).tracks[0].keys[1].at_ms == Fraction(100, 3)
        assert read(fixture(name), name, fps=Fraction(30)).tracks == (expected_track(),)
        with pytest.raises(ImportError_, match=r"says (fps|FPS) 30 but --fps says 25"):
            read(fixture(name), name, fps=Fraction(25))


def test_bin_takes_fps_from_the_option():
    keys = read(fixture("anim.bin"), "anim.bin", fps=Fraction(25)).tracks[0].keys
    assert [k.at_ms for k in keys[:3]] == [0, 40, 80]
    assert read(fixture("anim.bin"), "anim.bin", fps=Fraction(24000, 1001)).tracks[0].keys[1].at_ms == Fraction(1001, 24)


def test_bin_without_fps_is_an_error():
    with pytest.raises(ImportError_, match=r"anim\.bin.*--fps N"):
        read(fixture("anim.bin"), "anim.bin")


@pytest.mark.parametrize("fps", [Fraction(0), Fraction(-5)])
def test_bin_with_fps_not_positive_is_an_error(fps):
    with pytest.raises(ImportError_, match="more than 0"):
        read(fixture("anim.bin"), "anim.bin", fps=fps)


# --- units ---------------------------------------------------------------------------------------

def test_ticks_are_converted_to_microseconds():
    table = [(150, 375, 600), (300, 375, 4095)]
    hz = Fraction(60)
    for data, path in ((export_bin(frames_of(table)), "t.bin"), (export_json(frames_of(table)), "t.json"),
                       (export_h(frames_of(table)).encode(), "t.h")):
        keys = read(data, path, fps=Fraction(FPS), ticks_hz=hz).tracks[0].keys
        assert keys[1].targets == {i: ticks_to_us(Fraction(p), hz) for i, p in zip(IDS, table[1])}
        assert keys[0].targets[0] == Fraction(150 * 1_000_000, 4096 * 60)
    plain = read(export_bin(frames_of(table[:1])), "t.bin", fps=Fraction(FPS))
    assert plain.tracks[0].keys[0].targets == {0: 150, 10: 375, 60: 600}


def test_small_positions_give_a_note_unless_ticks():
    data = export_bin(frames_of([(150, 375, 450)]))
    assert any("--ticks" in n for n in read(data, "t.bin", fps=Fraction(FPS)).notes)
    assert read(data, "t.bin", fps=Fraction(FPS), ticks_hz=Fraction(50)).notes == (unit_note(Fraction(50)),)


def test_ticks_above_4095_are_an_error():
    with pytest.raises(ImportError_, match=r"frame 1: servo 60 position 4096 is not a PCA9685 count"):
        read(export_bin(frames_of([(300, 300, 300), (300, 300, 4096)])), "t.bin", fps=Fraction(30), ticks_hz=Fraction(50))


# --- several scenes in one header -----------------------------------------------------------------

def test_a_header_with_two_namespaced_scenes_gives_two_tracks():
    a = frames_of([(1500, 1600), (1510, 1600)], ids=(0, 1))
    b = frames_of([(1700,), (1800,), (1900,)], ids=(2,))
    text = export_h(a, fps=30, namespace="SceneA") + export_h(b, fps=60, namespace="SceneB", include=False)
    kf = read(text.encode(), "show.h")
    assert [c.index for c in kf.channels] == [0, 1, 2]
    assert kf.tracks == (expected_track([(1500, 1600), (1510, 1600)], 30, "SceneA", (0, 1)),
                         expected_track([(1700,), (1800,), (1900,)], 60, "SceneB", (2,)))
    with pytest.raises(ImportError_, match=r"show\.h:\d+: the file says FPS 60"):
        read(text.encode(), "show.h", fps=Fraction(30))


def test_a_header_may_write_bytes_in_decimal():
    text = b"const byte FPS = 25;\nconst byte ANIMATION_DATA[] = {60, 0, 5, 220, 62, 10, 0x3c, 0, 0x05, 0xf0, 0x3E, 0x0A};"
    assert [k.targets for k in read(text, "d.h").tracks[0].keys] == [{0: 1500}, {0: 1520}]


def test_a_header_without_fps_needs_the_option():
    text = fixture("anim.h").decode().replace("const byte FPS = 30;", "")
    with pytest.raises(ImportError_, match=r"anim\.h:\d+: no `FPS = N;`.*--fps N"):
        read(text.encode(), "anim.h")
    assert read(text.encode(), "anim.h", fps=Fraction(30)).tracks == (expected_track(),)


# --- broken inputs ------------------------------------------------------------------------------

def json_with(**changes) -> bytes:
    doc = json.loads(GENERATED["anim.json"])
    doc.update(changes)
    return json.dumps(doc).encode()


@pytest.mark.parametrize("data, message", [
    (b"{not json", r"not valid JSON"),
    (b"{\"fps\": 30, \"positions\": [\xff]}", r"not UTF-8"),
    (b"[1, 2]", r"not a Blender servo-animation JSON"),
    (b"{\"fps\": 30}", r"no \"fps\" and \"positions\""),
    (json_with(fps="30"), r"fps must be a whole number, not '30'"),
    (json_with(fps=True), r"fps must be a whole number"),
    (json_with(fps=0), r"fps must be more than 0"),
    (json_with(fps=-30), r"fps must be more than 0"),
    (json_with(frames=21), r"\"frames\" is 21 but \"positions\" has 20 frames"),
    (json_with(frames="20"), r"\"frames\" must be a whole number"),
    (json_with(positions="1500"), r"\"positions\" must be a list"),
    (json_with(positions=[[1500]], frames=1), r"\"positions\" must be a list with one object per frame"),
    (json_with(positions=[{"0": "1500"}], frames=1), r"frame 0: position of servo 0 must be a whole number"),
    (json_with(positions=[{"0": 1500}, {"0": 1500.5}], frames=2), r"frame 1: position of servo 0"),
    (json_with(positions=[{"0": 1500}, {"0": None}], frames=2), r"frame 1: position of servo 0"),
    (json_with(positions=[{"0": 1500}, {"0": True}], frames=2), r"frame 1: position of servo 0"),
    (json_with(positions=[{"a": 1500}], frames=1), r"frame 0: servo id 'a' is not a number 0..255"),
    (json_with(positions=[{"256": 1500}], frames=1), r"servo id '256'"),
    (json_with(positions=[{"0": -1}], frames=1), r"frame 0: servo 0 position -1 is not a width"),
    (json_with(positions=[{}, {}], frames=2), r"no servo positions in 2 frames"),
    (json_with(positions=[], frames=0), r"no servo positions in 0 frames"),
    (json_with(positions=[{"0": 1500}, {"0": 1500, "3": 1600}], frames=2),
     r"servo 3 has no position in frame 0 \(its first is in frame 1\)"),
])
def test_broken_json_is_refused(data, message):
    with pytest.raises(ImportError_, match=r"^anim\.json: .*" + message):
        read(data, "anim.json")


def header_with(old: str, new: str) -> bytes:
    text = GENERATED["anim.h"].decode()
    assert old in text
    return text.replace(old, new, 1).encode()


@pytest.mark.parametrize("data, message", [
    (GENERATED["anim.h"][:-40], r":18: ANIMATION_DATA has no closing '}'"),
    (header_with("FRAMES = 20", "FRAMES = 19"), r":18: FRAMES is 19 but ANIMATION_DATA has 20 frames"),
    (header_with("LENGTH = ", "LENGTH = 1"), r".*LENGTH is 1\d+ but ANIMATION_DATA has \d+ bytes"),
    (header_with("0x3c, 0x00", "0x3g, 0x00"), r".*ANIMATION_DATA byte 0 is '0x3g', not a byte"),
    (header_with(", 0x3e,", ", 256,"), r".*ANIMATION_DATA byte 4 is '256', not a byte"),
    (header_with(", 0x3e,", ", 062,"), r".*ANIMATION_DATA byte 4 is '062', not a byte"),
    (header_with(", 0x3e,", ", 0x3f,"), r".*ANIMATION_DATA: byte 4 is 0x3F, not 0x3E"),
    (header_with("FPS = 30", "FPS = 0"), r".*FPS must be more than 0"),
    (header_with("ANIMATION_DATA[LENGTH] = {", "ANIMATION_DATA[LENGTH] = {0x3c, "), r".*LENGTH is"),
    (b"const byte FPS = 30;\nconst byte ANIMATION_DATA[] = {0x0a,};\n", r".*no servo positions in 1 frames"),
    (b"const byte FPS = 30;\nconst byte ANIMATION_DATA[] = {0x3c, 0x00, 0x05};\n", r".*byte 0: the servo record is cut short"),
    (b"const byte FPS = 30;\nconst byte ANIMATION_DATA[] = {0xff};\n", r".*byte 0 is 0xFF, not 0x3C"),
    (b"const byte FPS = 30;\nconst byte ANIMATION_DATA[] = {\x80};\n", r".*not UTF-8"),
])
def test_broken_header_is_refused(data, message):
    with pytest.raises(ImportError_, match=r"^anim\.h" + message):
        read(data, "anim.h")


def broken_bin(change) -> bytes:
    data = bytearray(GENERATED["anim.bin"])
    change(data)
    return bytes(data)


@pytest.mark.parametrize("data, message", [
    (GENERATED["anim.bin"][:-3], r"byte 249: the servo record is cut short \(3 of 5 bytes\)"),
    (GENERATED["anim.bin"][:-1], r"frame 19 \(from byte \d+\) does not end with 0x0A"),
    (GENERATED["anim.bin"][:-6], r"frame 19 \(from byte \d+\) does not end with 0x0A"),
    (broken_bin(lambda d: d.__setitem__(0, 0x3B)), r"byte 0 is 0x3B, not 0x3C \(start of a servo record\)"),
    (broken_bin(lambda d: d.__setitem__(4, 0x0A)), r"byte 4 is 0x0A, not 0x3E \(end of the servo record at byte 0\)"),
    (broken_bin(lambda d: d.__setitem__(slice(0, 0), b"\x00")), r"byte 0 is 0x00"),
    (b"", r"no servo positions in 0 frames"),
    (b"\n\n", r"no servo positions in 2 frames"),
    (b"<UscSettings/>", r"byte 0 is 0x3C|byte 4 is 0x53, not 0x3E"),
])
def test_broken_bin_is_refused(data, message):
    with pytest.raises(ImportError_, match=r"^anim\.bin: .*" + message):
        read(data, "anim.bin", fps=Fraction(FPS))


# --- sniff --------------------------------------------------------------------------------------

MAESTRO = b'<?xml version="1.0" encoding="utf-8"?>\n<UscSettings version="1">\n  <Channels/>\n</UscSettings>\n'
CSV = b"time_ms,a,b\n0,1500,1500\n500,2000,1000\n"


def test_sniff_knows_the_three_exports():
    assert blender.sniff(fixture("anim.json"), "anim.json")
    assert blender.sniff(export_json(frames_of(TABLE), indent=None), "x.txt")
    assert blender.sniff(fixture("anim.h"), "anim.h")
    assert blender.sniff(fixture("anim.bin"), "anim.bin")
    assert blender.sniff(fixture("anim.bin"), "ANIM.BIN")


@pytest.mark.parametrize("path", ["anim.dat", "anim", "anim.txt", "anim.h", "anim.json"])
def test_a_bin_export_is_known_by_its_bytes_whatever_its_name(path):
    """Bytes that are nothing but 5-byte records (each frame ended by 0x0A) are a `.bin` export."""
    assert blender.sniff(fixture("anim.bin"), path) and blender.is_records(fixture("anim.bin"))
    assert read(fixture("anim.bin"), path, fps=Fraction(FPS)).tracks[0].keys == expected_track().keys


@pytest.mark.parametrize("data", [b"", b"\n\n", b"<abc>", b"<abc>\n<d", b"time_ms,a\n", b"<UscSettings>\n",
                                  GENERATED["anim.bin"][:-1], b"\x00" + GENERATED["anim.bin"]])
def test_other_bytes_are_not_records(data):
    assert not blender.is_records(data)


def test_a_bin_export_under_another_name_imports_as_the_bin(tmp_path, capsys):
    """A copy of anim.bin without its extension (its bytes are not UTF-8): recognised from its
    content, and with `--from blender` read as records, not as Windows-1252 text; the same program."""
    from servoc import cli
    (tmp_path / "bin").mkdir()
    named, bare = tmp_path / "bin" / "anim.bin", tmp_path / "anim"
    named.write_bytes(fixture("anim.bin"))
    bare.write_bytes(fixture("anim.bin"))
    programs = []
    for path, options in ((named, []), (bare, []), (bare, ["--from", "blender"])):
        out = tmp_path / f"out{len(programs)}.servo"
        assert cli.main(["import", str(path), "--fps", "30", "-o", str(out), *options]) == 1      # N 259: lint's
        assert "written from" in capsys.readouterr().out
        programs.append(out.read_text().split("\n", 1)[1])     # the same below the first line (the file's name)
    assert programs[0] == programs[1] == programs[2]


@pytest.mark.parametrize("data, path", [
    (MAESTRO, "settings.xml"), (CSV, "moves.csv"), (CSV, "moves.bin"), (b"", "x.bin"),
    (b'{"name": "x", "positions": []}', "x.json"),
    (bytes(range(256)), "x.bin"), (GENERATED["anim.bin"][:-1], "anim.bin"),
])
def test_sniff_refuses_other_files(data, path):
    assert not blender.sniff(data, path)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=64), st.sampled_from(["x.bin", "x.h", "x.json", ""]))
def test_sniff_never_raises(data, path):
    assert blender.sniff(data, path) in (True, False)


# --- never a raw exception, never too slow -------------------------------------------------------

@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["anim.json", "anim.h", "anim.bin"]), st.randoms(use_true_random=False))
def test_damaged_files_give_keyframes_or_an_import_error(name, rnd):
    data = damaged(fixture(name), rnd)
    try:
        kf = read(data, name, fps=Fraction(FPS))
    except ImportError_ as e:
        assert str(e).startswith(name)
    else:
        assert kf.tracks and all(t.keys for t in kf.tracks)


def test_a_million_frames_are_refused_quickly():
    frame = records([{0: 1500, 10: 2570}])
    huge = {"anim.bin": frame * 1_000_000,
            "anim.json": json.dumps({"fps": 30, "frames": 1_000_000, "positions": [{"0": 1500}] * 1_000_000}).encode(),
            "anim.h": b"const byte FPS = 30;\nconst int FRAMES = 1000000;\nconst byte ANIMATION_DATA[] = {0x0a};\n"}
    for name, data in huge.items():
        start = time.perf_counter()
        with pytest.raises(ImportError_, match=r"more than the 100,000"):
            read(data, name, fps=Fraction(30))
        assert time.perf_counter() - start < 3, name


def test_the_largest_accepted_file_reads_in_a_few_seconds():
    rnd = random.Random(7)
    frames = [{i: rnd.randrange(1000, 2000) for i in range(4)} for _ in range(MAX_FRAMES)]
    data = records(frames)
    start = time.perf_counter()
    kf = read(data, "big.bin", fps=Fraction(60))
    assert time.perf_counter() - start < 5
    last = kf.tracks[0].keys[-1]
    assert last.targets == {i: Fraction(p) for i, p in frames[-1].items()}
    assert last.at_ms == Fraction(1000 * (MAX_FRAMES - 1), 60)


if __name__ == "__main__":
    os.makedirs(FIXTURES, exist_ok=True)
    for name, data in generated().items():
        with open(os.path.join(FIXTURES, name), "wb") as f:
            f.write(data)
        print("wrote", os.path.join(FIXTURES, name))
