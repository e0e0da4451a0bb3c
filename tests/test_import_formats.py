"""servoc import, what the formats' documentation says that the first readers left out: Bottango's
servo speeds and its other kinds of actuators, the Blender add-on's 1.x exports, CSV columns in
degrees, which unit the positions were read in, limits that never widen the source's range,
numbers in messages, and every text format in UTF-16 and Windows-1252.

The inputs are written here from the formats' documentation: Bottango's driver
(`BasicCommands.h`: `rSVPin` is pin, min µs, max µs, max µs per second, start µs; `rCtrl`
registers a relay controller, `sR` passes a command on to one, `rMTR` registers a custom motor),
and the Blender Servo Animation add-on 1.x exporters (`positions` by bone name, 1.0 writing them
as strings; `servos` by id from 1.3; `.h` arrays `const int Bone[N] PROGMEM = {...};`, the frame
rate in the comment at the top, `// Servo ID: N` from 1.3, `FPS`/`FRAMES` constants from 1.4).
"""

from __future__ import annotations

import json
import re
from fractions import Fraction

import pytest
from conftest import damaged

from servoc import api, cli
from servoc.imports import blender, bottango, csvfile
from servoc.imports import write as W
from servoc.imports.keyframes import (Channel, ImportError_, Key, Keyframes, ReadOptions, Track, decimal, deg_to_us,
                                      ticks_to_us, unit_note)
from servoc.units import deg_to_n, width_to_n


def run(args, capsys):
    rc = cli.main(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


# ---- Bottango: speeds, other actuators, no servo -------------------------------------------------

SETUP = 'const char SETUP_DATA_0[] PROGMEM = "{}";\n'
ANIM = '// animation 0, "Wave"\nconst char ANIM_0_DATA0[] PROGMEM = "{}";\n'


def bottango_file(setup: str, anim: str = "sC,9,0,1000,0,250,0,8192,-250,0\\n") -> bytes:
    return (SETUP.format(setup) + ANIM.format(anim)).encode()


def read_bottango(data: bytes, path="GeneratedCodeAnimations.cpp"):
    return bottango.read(data, path, ReadOptions())


def test_a_bottango_servo_s_maximum_speed_is_its_speed():
    kf = read_bottango(bottango_file("rSVPin,9,1000,2000,1600,1500\\nrSVPin,10,1000,2000,0,1500\\n"))
    assert [c.speed_us_s for c in kf.channels] == [1600, None]       # 0: the export says no speed
    imp = W.write(kf, {9: "P1.1", 10: "P1.2"}, W.Timing(5300), "x.cpp")
    # 1600 µs a second is 200 DAV of 0.74°: 148° a second
    assert "servo pin_9 = P1.1 speed 1s/148deg limit 1004us..1996us" in imp.text
    assert re.search(r"servo pin_10 = P1\.2 limit", imp.text)


def test_a_bottango_servo_faster_than_the_default_keeps_its_speed(tmp_path, capsys):
    """rSVPin's maximum speed is the servo's `speed` even when faster than the default servo's
    (3243 µs/s): 6000 µs/s is 750 DAV, 555°, a second. A curve that the default servo could not
    follow (1000 to 2000 µs in 300 ms) then imports without a speed error."""
    data = bottango_file("rSVPin,1,1000,2000,6000,1500\\n", "sC,1,0,300,0,0,0,8192,0,0\\nsC,1,300,250,8192,0,0,0,0,0\\n")
    kf = read_bottango(data)
    assert kf.channels[0].speed_us_s == 6000 and kf.channels[0].servo_speed
    src = tmp_path / "GeneratedCodeAnimations.cpp"
    src.write_bytes(data)
    rc, out, err = run(["import", str(src), "-o", str(tmp_path / "fast.servo")], capsys)
    assert rc == 0 and "infeasible-speed" not in err, err
    assert "servo pin_1 = P1.1 speed 1s/555deg limit 1004us..1996us" in (tmp_path / "fast.servo").read_text()


def test_a_negative_bottango_speed_is_an_error():
    with pytest.raises(ImportError_, match=r"line 1: .*negative maximum speed"):
        read_bottango(bottango_file("rSVPin,9,1000,2000,-5,1500\\n"))


def test_other_kinds_of_actuators_are_left_out_with_one_note():
    setup = ("rSVPin,9,1000,2000,3000,1500\\nrCtrl,1,2,AA:BB\\nrMTR,m1,0,100,50,0\\n"
             "rSVI2C,64,3,1000,2000,3000,1500\\nrNEWThing,z,1\\nsCfg,RLY,1\\n")
    anim = ("sC,9,0,1000,0,250,0,8192,-250,0\\nsC,m1,0,500,0,10,0,8192,-10,0\\nsR,1,sC,4,0,100,0,1,0,1,-1,0\\n"
            "sR,1,sCI,4,100\\nsC,643,0,500,0,10,0,8192,-10,0\\n")
    kf = read_bottango(bottango_file(setup, anim))
    assert [c.index for c in kf.channels] == [9]
    (note,) = [n for n in kf.notes if "actuators" in n]
    for name in ("rCtrl", "rMTR", "rSVI2C", "rNEWThing", "sR x2"):
        assert name in note, note
    assert "2 curves of theirs" in note                     # the motor's and the I2C servo's
    assert "sCfg" not in note


def test_an_unknown_command_that_registers_nothing_is_still_an_error():
    with pytest.raises(ImportError_, match=r"unknown command 'zQ'"):
        read_bottango(bottango_file("rSVPin,9,1000,2000,3000,1500\\nzQ,1\\n"))


@pytest.mark.parametrize("setup, anim, named", [
    ("rMTR,m1,0,100,50,0\\nrSVI2C,64,3,1000,2000,3000,1500\\n", "sC,m1,0,500,0,10,0,8192,-10,0\\n",
     "rMTR, rSVI2C"),
    ("rCtrl,1,2\\nsR,1,rSVPin,9,1000,2000,3000,1500\\n", "sR,1,sC,9,0,100,0,1,0,1,-1,0\\n", "rCtrl, sR"),
    ("", "sC,9,0,1000,0,250,0,8192,-250,0\\n", None),
])
def test_an_export_with_no_servo_is_an_error_that_says_so(setup, anim, named):
    with pytest.raises(ImportError_) as caught:
        read_bottango(bottango_file(setup, anim))
    message = str(caught.value)
    assert message.startswith("GeneratedCodeAnimations.cpp: no servo: ") and "no rSVPin" in message, message
    if named:
        assert f"only other kinds of actuators ({named})" in message, message


def test_no_servo_through_the_command_writes_nothing(tmp_path, capsys):
    src = tmp_path / "GeneratedCodeAnimations.cpp"
    src.write_bytes(bottango_file("rMTR,m1,0,100,50,0\\n", "sC,m1,0,500,0,10,0,8192,-10,0\\n"))
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 2 and "no servo" in err and "rMTR" in err and "Traceback" not in err
    assert not (tmp_path / "GeneratedCodeAnimations.servo").exists()


# ---- Blender add-on 1.x ----------------------------------------------------------------------------

FPS = 30
# Two bones over six frames: `Neck` set up for the Arduino Servo library (0..180, degrees) and
# `Jaw` in µs (500..2500).
DEGREES = [90, 91.5, 93, 94.25, 96, 96]
MICROS = [1500, 1520, 1540, 1560, 1580, 1580]


def v1_json_by_bone(positions: dict, as_strings=False, key="positions") -> bytes:
    """The 1.0-1.2 JSON exporter: positions by bone name; 1.0-1.2 wrote `str(position)`."""
    doc = {"description": "Blender Animation Servo Positions", "fps": FPS, "frames": len(next(iter(positions.values()))),
           "seconds": 0, "bones": len(positions), "armature": "Armature", "file": "head.blend",
           key: {bone: [str(p) for p in values] if as_strings else values for bone, values in positions.items()}}
    return json.dumps(doc, indent=4).encode()


def v1_json_by_id(servos: dict) -> bytes:
    """The 1.3-1.4 JSON exporter: servos by id, each with its bone's name."""
    doc = {"description": "Blender Servo Animation Positions", "fps": FPS, "frames": len(next(iter(servos.values()))[1]),
           "seconds": 0, "bones": len(servos), "armature": "Armature", "file": "head.blend",
           "servos": {str(sid): {"name": name, "positions": values} for sid, (name, values) in servos.items()}}
    return json.dumps(doc, indent=4).encode()


def v1_header(servos: dict, variables=False, namespace=None, ids=True, chunk=4) -> str:
    """The 1.x Arduino exporter: `servos` is id -> (bone, positions)."""
    frames = len(next(iter(servos.values()))[1])
    any_float = any(isinstance(p, float) for _, values in servos.values() for p in values)
    text = (f"/*\n  Blender Servo Animation Positions\n\n  FPS: {FPS}\n  Frames: {frames}\n  Seconds: 0\n"
            f"  Bones: {len(servos)}\n  Armature: Armature\n  File: head.blend\n*/\n\n#include <Arduino.h>\n")
    if namespace:
        text += f"\nnamespace {namespace} {{\n"
    if variables:
        text += f"\nconst byte FPS = {FPS};\nconst int FRAMES = {frames};\n"
    for sid, (bone, values) in servos.items():
        text += f"\n// Servo ID: {sid}\n" if ids else "\n"
        text += f"const {'float' if any_float else 'int'} {bone}[{'FRAMES' if variables else frames}] PROGMEM = {{\n"
        for i in range(0, len(values), chunk):
            text += "  " + ", ".join(str(v) for v in values[i:i + chunk]) + ",\n"
        text += "};\n"
    if namespace:
        text += f"\n}} // namespace {namespace}\n"
    return text


def expected_v1(ids=(0, 1)):
    return [{ids[0]: deg_to_us(Fraction(str(a))), ids[1]: Fraction(us)} for a, us in zip(DEGREES, MICROS)]


def read_blender(data: bytes, path: str, **options):
    return blender.read(data, path, ReadOptions(**options))


@pytest.mark.parametrize("data, path, ids", [
    (v1_json_by_bone({"Neck": DEGREES, "Jaw": MICROS}), "head.json", (0, 1)),
    (v1_json_by_bone({"Neck": DEGREES, "Jaw": MICROS}, as_strings=True), "head.json", (0, 1)),
    (v1_json_by_bone({"Neck": DEGREES, "Jaw": MICROS}, as_strings=True, key="pulses"), "head.json", (0, 1)),
    (v1_json_by_id({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}), "head.json", (3, 7)),
    (v1_header({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}, ids=False).encode(), "head.h", (0, 1)),
    (v1_header({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}).encode(), "head.h", (3, 7)),
    (v1_header({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}, variables=True, namespace="Head").encode(), "head.h", (3, 7)),
])
def test_add_on_1x_exports_are_read(data, path, ids):
    assert blender.sniff(data, path)
    kf = read_blender(data, path)
    assert [(c.index, c.name) for c in kf.channels] == [(ids[0], "Neck"), (ids[1], "Jaw")]
    (track,) = kf.tracks
    assert track.sampled and [k.at_ms for k in track.keys] == [Fraction(1000 * k, FPS) for k in range(6)]
    assert [k.targets for k in track.keys] == expected_v1(ids)
    (note,) = kf.notes
    assert "1.x" in note and "degrees" in note and "Neck" in note and "µs (all 500 or more): Jaw" in note


def test_add_on_1x_degrees_are_the_widths_of_a_servo_s_deg():
    """A degrees is what `A deg` means in a .servo program: N = floor(A x 250/185 + 1/2)."""
    for a in (0, 45, 90, Fraction(183, 2), Fraction(1001, 10), 180):
        assert width_to_n(deg_to_us(a)) == deg_to_n(Fraction(a))
    assert [width_to_n(deg_to_us(a)) for a in (0, 45, 90, 180)] == [0, 61, 122, 243]     # the spec's table


def test_add_on_1x_counts_need_ticks():
    counts = [375, 376, 380, 400, 450, 488]
    data = v1_header({0: ("Neck", counts)}).encode()
    with pytest.raises(ImportError_, match=r"^head\.h:\d+: Neck: positions 375\.\.488 of an add-on 1\.x export are "
                                           r"neither degrees \(0\.\.180\) nor µs.*--ticks HZ.*add-on 2\.x"):
        read_blender(data, "head.h")
    kf = read_blender(data, "head.h", ticks_hz=Fraction(50))
    assert [k.targets[0] for k in kf.tracks[0].keys] == [ticks_to_us(c, 50) for c in counts]
    assert kf.notes == (unit_note(Fraction(50), "add-on 1.x positions"),)


def test_the_json_and_the_header_of_one_1x_animation_give_the_same_program(tmp_path, capsys):
    servos = {0: ("Neck", DEGREES), 1: ("Jaw", MICROS)}
    texts = []
    for name, data in (("a.json", v1_json_by_id(servos)), ("a.h", v1_header(servos).encode())):
        (tmp_path / name).write_bytes(data)
        out = tmp_path / (name + ".servo")
        rc, said, err = run(["import", str(tmp_path / name), "-o", str(out)], capsys)
        assert rc == 0, err
        texts.append(out.read_text().split("\n", 1)[1])       # all but the line that names the file
    assert texts[0] == texts[1]


@pytest.mark.parametrize("data, path, message", [
    (v1_header({0: ("Neck", DEGREES)}).replace("FPS: 30", "").encode(), "head.h", r"no `FPS: N`.*--fps N"),
    (v1_header({0: ("Neck", DEGREES)}).replace("Neck[6]", "Neck[7]").encode(), "head.h", r"Neck\[7\] has 6 positions"),
    (v1_header({0: ("Neck", DEGREES)}).replace("94.25", "9o4").encode(), "head.h", r"'9o4' is not a number"),
    (v1_header({0: ("Neck", DEGREES)}).rsplit("};", 1)[0].encode(), "head.h", r"without its closing"),
    (v1_header({0: ("Neck", DEGREES), 1: ("Jaw", MICROS[:5])}).encode(), "head.h", r":21: Jaw\[6\] has 5 positions, not 6"),
    (v1_header({0: ("Neck", DEGREES), 1: ("Jaw", MICROS[:5])}).replace("[6]", "[]").encode(), "head.h",
     r"different lengths \(5, 6\)"),
    (v1_json_by_bone({"Neck": DEGREES[:5], "Jaw": MICROS}), "head.json", r"\"frames\" is 5 but servo 1 \(Jaw\) has 6"),
    (v1_json_by_bone({"Neck": ["90", "ninety"] + DEGREES[2:]}), "head.json", r"frame 1: the position 'ninety'"),
    (v1_json_by_bone({"Neck": [90, -1] + DEGREES[2:]}), "head.json", r"frame 1: the position -1 is outside 0\.\.10000"),
    (v1_json_by_bone({"Neck": [90, True] + DEGREES[2:]}), "head.json", r"frame 1: the position True is not a number"),
    (json.dumps({"fps": 30, "frames": 1, "positions": {"Neck": [float("nan")]}}).encode(), "head.json",
     r"the position nan is not a number"),
    (json.dumps({"fps": 30, "frames": 0, "positions": {"Neck": []}}).encode(), "head.json", r"no servo positions"),
    (json.dumps({"fps": 30, "frames": 1, "servos": {"x": {"name": "a", "positions": [90]}}}).encode(), "head.json",
     r"servo id 'x' is not a number"),
])
def test_broken_1x_exports_are_clear_errors(data, path, message):
    with pytest.raises(ImportError_, match=f"^{re.escape(path)}.*{message}"):
        read_blender(data, path)


def test_a_header_that_is_no_export_does_not_talk_of_bin_files():
    with pytest.raises(ImportError_) as caught:
        read_blender(b"/* nothing */\nint x = 1;\n", "anim.h", fps=Fraction(30))
    assert "no ANIMATION_DATA array" in str(caught.value) and ".bin" not in str(caught.value)


# ---- CSV in degrees ------------------------------------------------------------------------------

def read_csv(text: str, path="walk.csv", **options):
    return csvfile.read(text.encode(), path, ReadOptions(**options))


def test_a_deg_column_is_in_degrees():
    kf = read_csv("time_ms,pan_deg,tilt\n0,90,1500\n500,45.5,1600\n")
    assert [c.name for c in kf.channels] == ["pan", "tilt"]
    assert [k.targets for k in kf.tracks[0].keys] == [{0: deg_to_us(90), 1: 1500},
                                                      {0: deg_to_us(Fraction("45.5")), 1: 1600}]
    assert any("pan read as degrees" in n and "_deg" in n for n in kf.notes)
    assert any(n.startswith("tilt read as µs") for n in kf.notes)


def test_a_deg_column_is_degrees_whatever_ticks_says():
    kf = read_csv("time_ms,PAN_DEG,b\n0,90,307.2\n", ticks_hz=Fraction(50))
    assert kf.tracks[0].keys[0].targets == {0: deg_to_us(90), 1: 1500}
    assert kf.channels[0].name == "PAN"


def test_positions_all_below_500_are_refused_with_the_suffix_named(tmp_path, capsys):
    with pytest.raises(ImportError_) as caught:
        read_csv("time_ms,pan,tilt\n0,90,45\n500,120,60\n")
    message = str(caught.value)
    assert message.startswith("walk.csv: every position is below 500 (the largest is 120)")
    assert "`pan_deg`, `tilt_deg`" in message and "--ticks HZ" in message
    assert read_csv("time_ms,pan,tilt\n0,300,450\n", ticks_hz=Fraction(50)).tracks   # counts with --ticks: fine
    src = tmp_path / "small.csv"
    src.write_text("time_ms,pan\n0,90\n")
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 2 and "pan_deg" in err and not (tmp_path / "small.servo").exists()


def test_a_deg_csv_imports_to_the_same_program_as_deg_in_a_servo_file(tmp_path, capsys):
    src = tmp_path / "d.csv"
    src.write_text("time_ms,pan_deg\n0,90\n1000,45\n")
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 0, err
    text = (tmp_path / "d.servo").read_text()
    assert "pan: 1476us" in text and "pan: 988us" in text       # 90deg: N 122, 45deg: N 61


# ---- the unit read, in the summary ---------------------------------------------------------------

@pytest.mark.parametrize("name, content, ticks, said", [
    ("a.csv", "time_ms,a\n0,1500\n", None, "positions read as µs"),
    ("a.csv", "time_ms,a\n0,307\n", "50", "positions read as PCA9685 counts at 50 Hz (--ticks 50)"),
    ("a.json", json.dumps({"fps": 30, "frames": 1, "positions": [{"0": 1500}]}), None, "positions read as µs"),
    ("a.json", json.dumps({"fps": 30, "frames": 1, "positions": [{"0": 307}]}), "60",
     "positions read as PCA9685 counts at 60 Hz (--ticks 60)"),
])
def test_the_summary_says_which_unit_was_read(tmp_path, capsys, name, content, ticks, said):
    src = tmp_path / name
    src.write_text(content)
    rc, out, err = run(["import", str(src)] + (["--ticks", ticks] if ticks else []), capsys)
    assert rc in (0, 1) and f"  note: {said}" in out, out + err


def test_ticks_on_a_format_that_gives_widths_itself_is_ignored_with_a_note(tmp_path, capsys):
    src = tmp_path / "GeneratedCodeAnimations.cpp"
    src.write_bytes(bottango_file("rSVPin,9,1000,2000,3000,1500\\n"))
    rc, out, err = run(["import", str(src), "--ticks", "50"], capsys)
    assert rc == 0 and "note: --ticks ignored: a Bottango export gives its widths in µs" in out, out + err


# ---- limits, pins, numbers in messages -------------------------------------------------------------

def test_a_limit_never_widens_the_source_s_range_and_positions_stay_inside():
    chans = (Channel(0, "a", Fraction(1001), Fraction(2000), Fraction(1001)),)
    keys = (Key(Fraction(0), {0: Fraction(1001)}, "r1"), Key(Fraction(500), {0: Fraction(2000)}, "r2"))
    imp = W.write(Keyframes("csv", chans, (Track("t", keys),)), {0: "P1.0"}, W.Timing(5300), "x.csv")
    assert "limit 1004us..1996us" in imp.text                  # 1001 up to 1004, 2000 down to 1996
    assert "a: 1996us" in imp.text and "a: 2004us" not in imp.text
    assert any("1 position at the edge" in n for n in imp.notes)    # 2000, not 1001 (it rounds to 1004)
    fe_errors = [d for d in _lint(imp.text) if d.is_error]
    assert not fe_errors, [d.message for d in fe_errors]


def test_a_curve_at_its_servo_s_max_stays_inside_the_limit(tmp_path, capsys):
    src = tmp_path / "GeneratedCodeAnimations.cpp"
    src.write_bytes(bottango_file("rSVPin,9,1000,2000,3000,1500\\n", "sC,9,0,1000,4096,250,0,8192,-250,0\\n"))
    rc, out, err = run(["import", str(src), "-o", str(tmp_path / "b.servo")], capsys)
    assert rc == 0, err
    text = (tmp_path / "b.servo").read_text()
    assert "limit 1004us..1996us" in text and "2004us" not in text and "pin_9: 1996us" in text


def test_a_servo_held_halfway_between_two_n_does_not_cut_the_fit_into_frames():
    """1200 µs is N 87.5, written 88: holding there is 1/2 N from the source, which the fit allows."""
    rows = [(1200, 1500 + 5 * k) for k in range(60)]
    kf = Keyframes("blender", (Channel(0), Channel(1)),
                   (Track("t", tuple(Key(Fraction(1000 * k, 30), {0: Fraction(a), 1: Fraction(b)}, f"frame {k}")
                                     for k, (a, b) in enumerate(rows)), sampled=True),))
    imp = W.write(kf, {0: "P1.0", 1: "P1.1"}, W.sampled_timing(Fraction(30), 5300), "x.json")
    assert imp.moves_out <= 3 and imp.deviation <= 1, imp.text


def test_a_bottango_curve_within_its_servo_s_speed_imports_without_speed_errors(tmp_path, capsys):
    """A curve at up to about 1,900 µs/s on a servo of 3000 µs/s (1.99 DAV a frame of 5.3 ms), the
    other servo held at 1200 µs (N 87.5): the fit once cut such a track into one-frame moves, and
    the samples, rounded to N, step 1 or 2 N a frame: a one-frame move of 2 N is too fast for
    the servo. The fit lets the held servo stay put, and takes moves of many frames."""
    src = tmp_path / "GeneratedCodeAnimations.cpp"
    src.write_bytes(bottango_file("rSVPin,9,1000,2000,3000,1500\\nrSVPin,10,600,2400,3000,1200\\n",
                                  "sC,9,0,400,4096,130,-200,8192,-130,0\\n"))
    rc, out, err = run(["import", str(src), "-o", str(tmp_path / "b.servo")], capsys)
    assert rc == 0 and "infeasible-speed" not in err, err
    assert "speed 1s/277.5deg" in (tmp_path / "b.servo").read_text()


def _lint(text):
    from servoc.diagnostics import Reporter
    from servoc.source import SourceFile
    source = SourceFile("x.servo", text)
    reporter = Reporter(source)
    api.front_end(source, reporter)
    return reporter.diagnostics


def test_no_pin_left_names_the_file():
    kf = Keyframes("bottango", tuple(Channel(i) for i in range(25)), ())
    with pytest.raises(api.UsageError, match=r"^show\.cpp: channel 24: all 24 pins are taken"):
        api.import_pins(kf, {}, "show.cpp")


def test_numbers_in_messages_are_decimals():
    assert decimal(Fraction(1860033, 1000)) == "1860.033" and decimal(Fraction(3721, 2)) == "1860.5"
    assert decimal(Fraction(1, 3)) == "0.333" and decimal(Fraction(-5, 2)) == "-2.5" and decimal(30) == "30"
    with pytest.raises(ImportError_) as caught:
        read_csv("time_ms,a\n1860.033,1500\n1000,1500\n")
    assert "(1860.033 ms)" in str(caught.value) and "/" not in str(caught.value).split(":", 2)[2]
    kf = read_csv("time_ms,a\n1860.033,1500\n")
    assert kf.tracks[0].keys[0].source == "row 2, 1860.033 ms"
    with pytest.raises(ImportError_, match=r"says fps 30 but --fps says 29\.97"):
        read_blender(json.dumps({"fps": 30, "frames": 1, "positions": [{"0": 1500}]}).encode(), "a.json",
                     fps=Fraction(2997, 100))


# ---- encodings -----------------------------------------------------------------------------------

def import_bytes(tmp_path, capsys, name: str, data: bytes):
    src = tmp_path / name
    src.write_bytes(data)
    out = tmp_path / "out.servo"
    rc, said, err = run(["import", str(src), "-o", str(out)], capsys)
    assert rc == 0 and out.exists(), said + err
    return [ln.strip() for ln in out.read_text(encoding="utf-8").splitlines() if ln.strip().startswith(("move", "pose"))]


BOTTANGO_TEXT = ('// Generated by Bottango: "Kopfnicken für Gäste"\n'
                 'const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,2000,3000,1500\\n";\n'
                 '// animation 0, "Begrüßung"\n'
                 'const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,1000,4096,250,0,8000,-250,0\\n";\n')
BLENDER_H = v1_header({0: ("Nacken", DEGREES)}).replace("Armature", "Hals über Kopf")
BLENDER_2_H = ("/*\n  Blender Servo Animation Positions\n\n  Scene: Café\n*/\n\nconst byte FPS = 30;\nconst int FRAMES = 2;\n"
               "const int LENGTH = 12;\n\nconst byte PROGMEM ANIMATION_DATA[LENGTH] = {\n"
               "  0x3c, 0x00, 0x05, 0xdc, 0x3e, 0x0a, 0x3c, 0x00, 0x06, 0x40, 0x3e, 0x0a,\n};\n")


@pytest.mark.parametrize("name, text", [("GeneratedCodeAnimations.cpp", BOTTANGO_TEXT), ("head.h", BLENDER_H),
                                        ("scene.h", BLENDER_2_H), ("keys.csv", "time_ms,Gelenk_ä\n0,1500\n900,1900\n")])
@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-be", "cp1252", "utf-8-sig"])
def test_every_text_format_in_utf16_and_windows_1252(tmp_path, capsys, name, text, encoding):
    data = text.encode(encoding)
    if encoding == "utf-16-be":
        data = b"\xfe\xff" + data                               # big-endian, with its byte-order mark
    assert import_bytes(tmp_path, capsys, name, data) == import_bytes(tmp_path, capsys, name, text.encode("utf-8"))


def test_the_readers_convert_the_bytes_themselves_too():
    """Called directly (not through api.read_motion), the CSV and Bottango readers still read
    UTF-16 and Windows-1252: converting bytes that are already UTF-8 changes nothing."""
    csv_text = "time_ms,Gelenk_ä\n0,1500\n"
    for encoding in ("utf-16", "cp1252"):
        assert read_csv_bytes(csv_text.encode(encoding)).channels[0].name == "Gelenk_ä"
        assert read_bottango(BOTTANGO_TEXT.encode(encoding)).tracks[0].name == "Begrüßung"


def read_csv_bytes(data: bytes):
    return csvfile.read(data, "k.csv", ReadOptions())


# ---- never a traceback -----------------------------------------------------------------------------

from hypothesis import given, settings, strategies as st     # noqa: E402

V1_FILES = {"head.h": v1_header({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}, variables=True, namespace="Head").encode(),
            "old.h": v1_header({0: ("Neck", DEGREES)}, ids=False).encode(),
            "head.json": v1_json_by_bone({"Neck": DEGREES, "Jaw": MICROS}, as_strings=True),
            "ids.json": v1_json_by_id({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}),
            "bottango.cpp": bottango_file("rSVPin,9,1000,2000,3000,1500\\nrCtrl,1,2\\nrMTR,m,0,9,9,0\\n",
                                          "sC,9,0,1000,0,250,0,8192,-250,0\\nsR,1,sCI,4,100\\n")}


@settings(max_examples=400, deadline=None)
@given(st.sampled_from(sorted(V1_FILES)), st.randoms(use_true_random=False), st.sampled_from([None, Fraction(50)]))
def test_damaged_new_inputs_give_keyframes_or_an_import_error(name, rnd, ticks):
    data = damaged(V1_FILES[name], rnd, (b"9", b"-", b".", b"e9", b"1e99", b"\"", b",", b"}", b"]"))
    reader = bottango if name.endswith(".cpp") else blender
    try:
        kf = reader.read(data, name, ReadOptions(fps=Fraction(30), ticks_hz=ticks))
    except ImportError_ as e:
        assert str(e).startswith(name)
    else:
        assert kf.channels and kf.tracks


@settings(max_examples=100, deadline=None)
@given(st.sampled_from(sorted(V1_FILES)), st.randoms(use_true_random=False), st.sampled_from([None, Fraction(50)]))
def test_damaged_new_inputs_import_or_fail_clearly(tmp_path_factory, name, rnd, ticks):
    data = bytearray(V1_FILES[name])
    for _ in range(rnd.randint(1, 3)):
        i = rnd.randrange(len(data))
        data[i:i + rnd.randint(0, 3)] = rnd.choice([b"9", b"-", b".", b"1e99", b"\"", b",", b"}", b"", b"\xff"])
    path = tmp_path_factory.mktemp("damaged") / name
    path.write_bytes(bytes(data))
    try:
        imported = api.import_motion(str(path), None, {}, ReadOptions(ticks_hz=ticks))
    except api.UsageError as exc:
        assert str(exc) and "Traceback" not in str(exc)
        return
    from servoc.diagnostics import Reporter
    from servoc.source import SourceFile
    source = SourceFile("x.servo", imported.text)
    assert api.front_end(source, Reporter(source)).tree is not None     # what the import writes always parses


# ---- round trips: what the new readings write compiles, and its firmware sends the planned pulses ----

@pytest.mark.toolchain
@pytest.mark.parametrize("name, data", [
    ("GeneratedCodeAnimations.cpp", bottango_file("rSVPin,9,1000,2000,1500,1500\\nrCtrl,r1\\n",
                                                  "sC,9,0,1000,4096,300,0,8192,-300,0\\n")),
    ("head.json", v1_json_by_bone({"Neck": DEGREES, "Jaw": MICROS})),
    ("head.h", v1_header({3: ("Neck", DEGREES), 7: ("Jaw", MICROS)}).encode()),
    ("pan.csv", b"time_ms,pan_deg,tilt\n0,90,1500\n500,120,1600\n900,45,1200\n"),
])
def test_new_readings_compile_and_verify_in_ucsim(tmp_path, capsys, name, data):
    from servoc.plan import verify_frames
    src, out = tmp_path / name, tmp_path / "out.servo"
    src.write_bytes(data)
    rc, _, err = run(["import", str(src), "-o", str(out)], capsys)
    assert rc == 0, err
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None, [d.message for d in reporter.diagnostics if d.is_error]
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok and report.max_error_cycles == 0, report.mismatches[:5]
