"""servoc import: the CSV reader, the writer (keyed moves, the fit of sampled tracks), pins, the command."""

from __future__ import annotations

import itertools
import json
import math
import os
from fractions import Fraction

import pytest
from hypothesis import given, settings, strategies as st

from servoc import api, cli
from servoc.diagnostics import Reporter
from servoc.imports import csvfile
from servoc.imports import write as W
from servoc.imports.keyframes import Channel, ImportError_, Key, Keyframes, ReadOptions, Track, decimal, identifier
from servoc.plan import expand
from servoc.source import SourceFile
from servoc.units import round_half_up, width_to_n


def front(text: str, name: str = "imported.servo"):
    source = SourceFile(name, text)
    reporter = Reporter(source)
    return api.front_end(source, reporter), reporter


def read_csv(text: str, ticks=None):
    return csvfile.read(text.encode(), "walk.csv", ReadOptions(ticks_hz=ticks))


# ---- CSV ------------------------------------------------------------------------------

def test_csv_rows_are_keys_and_empty_cells_keep_the_target():
    kf = read_csv("time_ms,pan,tilt\n0,1500,1500\n400,1000,\n900.5,,2000\n")
    assert [c.name for c in kf.channels] == ["pan", "tilt"]
    (track,) = kf.tracks
    assert track.name == "walk" and not track.sampled
    assert [k.at_ms for k in track.keys] == [0, 400, Fraction(1801, 2)]
    assert [k.targets for k in track.keys] == [{0: 1500, 1: 1500}, {0: 1000}, {1: 2000}]
    assert track.keys[2].source.startswith("row 4")


def test_csv_ticks_become_microseconds():
    kf = read_csv("time_ms,a\n0,307.2\n", ticks=50)      # 307.2 / 4096 x 20 ms = 1.5 ms
    assert kf.tracks[0].keys[0].targets == {0: 1500}


@pytest.mark.parametrize("text, words", [
    ("", "header"),
    ("time,a\n0,1500\n", "header"),
    ("time_ms,a,\n0,1500\n", "a name for every column"),
    ("time_ms,a\n", "no keyframe rows"),
    ("time_ms,a\n0,15x0\n", "`15x0` is not a number"),
    ("time_ms,a\n100,1500\n50,1500\n", "comes before"),
    ("time_ms,a\n0,1500,1500\n", "3 cells"),
])
def test_broken_csv_is_a_clear_error(text, words):
    with pytest.raises(ImportError_, match=words):
        read_csv(text)


def test_csv_sniff():
    assert csvfile.sniff(b"\xef\xbb\xbftime_ms,a\n0,1500\n", "x.txt")
    assert not csvfile.sniff(b"<UscSettings>", "x.csv")


# ---- names ----------------------------------------------------------------------------

def test_identifiers_are_valid_and_distinct():
    taken: set = set()
    names = [identifier(t, "ch", taken) for t in ("Left Arm", "left-arm!", "left_arm", "3", "move", "P1", "")]
    assert names == ["Left_Arm", "left_arm", "left_arm_2", "ch_3", "move_", "P1_", "ch"]


# ---- the writer: keyed tracks ---------------------------------------------------------

def keyed(*keys, channels=(Channel(0, "a"), Channel(1, "b"))):
    return Keyframes("csv", tuple(channels), (Track("seq", tuple(keys)),))


def test_each_key_is_a_move_that_arrives_at_its_time():
    kf = keyed(Key(Fraction(0), {0: 1500, 1: 1500}, "row 2"), Key(Fraction(600), {0: 1004}, "row 3"),
               Key(Fraction(600), {1: 2004}, "row 4"), Key(Fraction(900), {}, "row 5"))
    imp = W.write(kf, {0: "P1.0", 1: "P1.1"}, W.Timing(5300), "x.csv")
    body = imp.text[imp.text.index("sequence seq {"):]
    assert "  move seq_0 in 0ms  # row 2\n" in body      # arrives at time 0: its first frame
    assert "  move seq_1 in 600ms  # row 3\n" in body
    assert "  move seq_2 in 0ms  # row 4\n" in body      # at the time of the one before: one frame
    assert "  hold 299ms  # row 5\n" in body      # 56 frames: row 4's frame is taken back, row 5 ends on 900 ms
    assert "pose seq_1 { a: 1004us }" in imp.text    # a pose names only what its key sets
    assert imp.moves_out == 4 and imp.frames_in == 4 and imp.off_grid == 0
    fe, rep = front(imp.text)
    row4 = imp.text.split("\n").index("  move seq_2 in 0ms  # row 4") + 1
    errors = [(d.code, rep.source.line_col(d.span.start)[0]) for d in rep.diagnostics if d.is_error]
    assert errors == [("infeasible-speed", row4)]      # b to 2004 us in one frame: the user's to fix


def csv_frames(tmp_path, text: str):
    """Import the CSV `text` and plan it: (the program's text, its period, every frame's N per servo)."""
    src = tmp_path / "rows.csv"
    src.write_text(text)
    imported = api.import_motion(str(src))
    fe, rep = front(imported.text)
    assert fe.plan is not None and not rep.has_errors, [d.message for d in rep.diagnostics]
    return imported.text, fe.plan.period_us, [f.n for _, f in zip(range(fe.plan.total_frames), expand(fe.plan))]


def test_rows_arrive_on_the_frame_nearest_their_time_without_drift(tmp_path):
    """50 rows 8 ms apart (1.509 frames of 5.3 ms each): rounding each gap on its own made every
    move 2 frames, and the last row arrived 130 ms late. Row r ends on frame round(t_r / P), counted
    from the sequence's first frame (frame 0, at time 0), and the program ends there."""
    rows = [(8 * r, 1500 + 8 * (r % 2)) for r in range(50)]
    text, period, frames = csv_frames(tmp_path, "time_ms,a\n" + "".join(f"{t},{w}\n" for t, w in rows))
    assert period == 5300 and "frame 5.3ms\n" in text
    for t, w in rows:
        k = round_half_up(Fraction(t * 1000, period))
        assert frames[k] == (width_to_n(w),), (t, k)
    assert len(frames) == round_half_up(Fraction(392_000, period)) + 1        # 75 frames, not 99
    assert "  move rows_1 in 8ms  # row 3, 8 ms\n" in text      # the source's gap where it gives the frames
    assert "  move rows_2 in 7ms  # row 4, 16 ms\n" in text     # else the whole ms nearest it that does


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from([0, 1, 2.5, 6, 8, 10.6, 13, 100, 333.3]), st.booleans(), st.booleans()),
                min_size=1, max_size=30))
def test_any_rows_end_on_the_frame_nearest_their_time(tmp_path_factory, rows):
    """Whatever the gaps (some shorter than a frame, some rows setting nothing), each row that moves
    ends on the frame nearest its time, unless the rows before it took that frame (a move takes one
    frame at least), and then as soon as it can: no error piles up."""
    at, lines, times = Fraction(0), [], []
    for gap, sets, high in rows:
        at += Fraction(str(gap))
        lines.append(f"{decimal(at)},{(1508 if high else 1500) if sets else ''}")
        times.append((at, (1508 if high else 1500) if sets else None))
    if times[0][1] is None:
        return                                        # the servo needs a position in the first row
    text, period, frames = csv_frames(tmp_path_factory.mktemp("csv"), "time_ms,a\n" + "\n".join(lines) + "\n")
    end = -1
    for t, w in times:
        want = round_half_up(t * 1000 / period)
        if w is not None:
            end = max(want, end + 1)
            assert frames[end] == (width_to_n(w),), (t, end, text)
        else:
            end = max(want, end)
    assert len(frames) == end + 1


def test_a_negative_width_is_an_error_that_names_the_row_and_writes_nothing(tmp_path, capsys):
    """-1500 µs is no pulse width, and `-1500us` is not a .servo width: the import is refused."""
    src = tmp_path / "neg.csv"
    src.write_text("time_ms,a\n0,1500\n100,-1500\n")
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 2 and "Traceback" not in err
    assert f"{src}: row 3, 100 ms: `a` is at -1500 µs, a negative pulse width" in err, err
    assert os.listdir(tmp_path) == ["neg.csv"]
    src.write_text("time_ms,a_deg\n0,90\n100,-100\n")            # -100 degrees: -581.081 µs
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 2 and "row 3, 100 ms: `a` is at -581.081 µs" in err, err


def test_off_grid_widths_are_rounded_and_counted():
    imp = W.write(keyed(Key(Fraction(0), {0: 1000, 1: 1505}, "r")), {0: "P1.0", 1: "P1.1"}, W.Timing(5300), "x.csv")
    assert "a: 1004us" in imp.text and "b: 1508us" in imp.text
    assert imp.off_grid == 2 and any("2 of 2 positions" in n for n in imp.notes)


def test_home_and_limits_come_from_the_channels():
    chans = (Channel(0, "a", Fraction(992), Fraction(2000), Fraction(1500)), Channel(1, "b"))
    imp = W.write(keyed(Key(Fraction(500), {0: 1200, 1: 1500}, "r"), channels=chans), {0: "P1.0", 1: "P1.1"},
                  W.Timing(5300), "x.csv")
    assert "home home\n" in imp.text and "pose home { a: 1500us }" in imp.text
    assert "servo a = P1.0 limit 996us..1996us" in imp.text          # rounded inward: never past 992..2000 µs
    fe, rep = front(imp.text)
    assert fe.plan is not None and not rep.has_errors


# ---- the writer: sampled tracks -------------------------------------------------------

def golden_at_samples(text: str, samples: int, every: int) -> list:
    fe, rep = front(text)
    assert fe.plan is not None, [d.message for d in rep.diagnostics]
    frames = list(itertools.islice(expand(fe.plan), (samples - 1) * every + 1))
    return [frames[k * every].n for k in range(samples)]


def sampled_track(values: list, fps: int = 30) -> Keyframes:
    channels = tuple(Channel(c) for c in range(len(values[0])))
    keys = tuple(Key(Fraction(1000 * k, fps), {c: Fraction(v) for c, v in enumerate(row)}, f"frame {k}")
                 for k, row in enumerate(values))
    return Keyframes("blender", channels, (Track("anim", keys, sampled=True),))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(-40, 40), st.integers(-3, 3)), min_size=2, max_size=40),
       st.sampled_from([24, 30, 60]))
def test_the_fit_meets_every_source_frame_within_one_n(steps, fps):
    """Random walks (steps in µs, some smooth, some not): the firmware's golden frames meet each
    source frame within 1 N of the exact source value, with no more moves than frames."""
    a, b, rows = Fraction(1500), Fraction(1200), []
    for da, db in steps:
        a, b = min(max(a + da + Fraction(1, 3), 600), 2400), min(max(b + db * 7, 600), 2400)
        rows.append((a, b))
    kf = sampled_track(rows, fps)
    timing = W.sampled_timing(Fraction(fps), 5300)
    imp = W.write(kf, {0: "P1.0", 1: "P1.1"}, timing, "x.json")
    assert imp.moves_out <= len(rows)
    got = golden_at_samples(imp.text, len(rows), timing.frames)
    worst = max(abs(n - (w - 500) / 8) for row, g in zip(rows, got) for n, w in zip(g, row))
    assert worst <= 1
    assert imp.deviation == max(abs(n - width_to_n(w)) for row, g in zip(rows, got) for n, w in zip(g, row))


def test_a_smooth_curve_costs_far_fewer_moves_than_frames():
    rows = [(1500 + 300 * math.sin(k / 30), 1500 + 2 * k) for k in range(300)]
    imp = W.write(sampled_track(rows), {0: "P1.0", 1: "P1.1"}, W.sampled_timing(Fraction(30), 5300), "x.json")
    assert imp.moves_out < len(rows) / 5
    assert imp.deviation <= 1


def test_a_still_stretch_is_a_hold():
    imp = W.write(sampled_track([(1500,)] * 10 + [(1600,)]), {0: "P1.0"}, W.sampled_timing(Fraction(30), 5300), "x")
    assert "  hold 300.024ms  # anim: frame 0 to frame 9\n" in imp.text       # 9 source frames of 6 x 5556 us
    assert "  move anim_10 in 33.336ms  # anim: frame 9 to frame 10\n" in imp.text
    assert imp.moves_out == 3          # the start, the still stretch, the step


@pytest.mark.parametrize("fps, floor, want", [
    (30, 5300, W.Timing(5556, 1, 6)), (50, 5300, W.Timing(6667, 1, 3)), (24, 8878, W.Timing(10417, 1, 4)),
    (150, 8878, W.Timing(13333, 2, 1)), (100, 5300, W.Timing(10000, 1, 1))])
def test_sampled_timing(fps, floor, want):
    got = W.sampled_timing(Fraction(fps), floor)
    assert got == want and got.period_us >= floor


# ---- pins -----------------------------------------------------------------------------

def test_pins_follow_the_channel_rule_and_the_map():
    kf = keyed(Key(Fraction(0), {}, "r"), channels=(Channel(0), Channel(9), Channel(17), Channel(30)))
    pins, notes = api.import_pins(kf, {9: "P0.7"})
    assert pins == {0: "P1.0", 9: "P0.7", 17: "P0.1", 30: "P1.1"}
    assert len(notes) == 1 and "channel 30" in notes[0]
    with pytest.raises(api.UsageError, match="both be on P1.0"):
        api.import_pins(kf, {9: "P1.0"})
    with pytest.raises(api.UsageError, match="channel 5, which the file does not have"):
        api.import_pins(kf, {5: "P1.5"})


# ---- the command ----------------------------------------------------------------------

def run(args, capsys):
    rc = cli.main(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_import_writes_the_program_and_reports_like_lint(tmp_path, capsys):
    src = tmp_path / "arm.csv"
    src.write_text("time_ms,base,elbow\n0,1500,1500\n1000,1100,1900\n2000,1500,1500\n")
    rc, out, err = run(["import", str(src)], capsys)
    written = tmp_path / "arm.servo"
    assert rc == 0 and written.exists()
    assert "3 source frames became 3 moves" in out
    rc2, out2, err2 = run(["lint", str(written)], capsys)
    assert rc2 == rc and err2 == err and out2.strip() in out


def test_a_program_with_speed_errors_is_still_written(tmp_path, capsys):
    src = tmp_path / "fast.csv"
    src.write_text("time_ms,a\n0,600\n20,2400\n")
    rc, out, err = run(["import", str(src), "-o", str(tmp_path / "out.servo")], capsys)
    assert rc == 1 and "infeasible-speed" in err and (tmp_path / "out.servo").exists()
    assert "out.servo:" in err and "# row 3" in (tmp_path / "out.servo").read_text()


@pytest.mark.parametrize("content", [b"hello world\n", b"\x00\x01\x02", b"{\"a\": 1}"])
def test_an_unknown_file_is_a_usage_error_and_nothing_is_written(tmp_path, capsys, content):
    src = tmp_path / "mystery.dat"
    src.write_bytes(content)
    rc, out, err = run(["import", str(src)], capsys)
    assert rc == 2 and "not a format servoc imports" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == ["mystery.dat"]


@pytest.mark.parametrize("args, words", [
    (["--pins", "0=P3.0"], "not CHANNEL=PIN"), (["--pins", "x"], "not CHANNEL=PIN"),
    (["--fps", "zero"], "positive number"), (["--ticks", "-5"], "positive number"),
    (["--from", "csv", "-o", "missing/dir/x.servo"], "does not exist")])
def test_bad_options_are_usage_errors(tmp_path, capsys, args, words):
    src = tmp_path / "a.csv"
    src.write_text("time_ms,a\n0,1500\n")
    rc, out, err = run(["import", str(src)] + args, capsys)
    assert rc == 2 and words in err
    assert not (tmp_path / "a.servo").exists()


def test_import_json_document(tmp_path, capsys):
    src = tmp_path / "a.csv"
    src.write_text("time_ms,a\n0,1500\n500,1000\n")
    rc, out, err = run(["import", str(src), "--format", "json"], capsys)
    doc = json.loads(out)
    assert rc == 0 and doc["import"]["frames_in"] == 2 and doc["import"]["moves_out"] == 2
    assert doc["import"]["off_grid"] == 1


# ---- any bytes: a clear error or a program, never a traceback --------------------------

FRAGMENTS = [b"time_ms,a,b\n", b"0,1500,1500\n", b"<UscSettings>", b"<Channels>", b'<Channel mode="Servo"/>',
             b"</Channels>", b'<Sequence name="s">', b'<Frame duration="100">', b"6000 0 s 1 a 2", b"</Frame>",
             b'{"fps": 30, "frames": 1, "positions": [{"0": 1500}]}', b"<\x00\x05\xdc>", b"\n", b"<", b">",
             b'const byte FPS = 30; const int FRAMES = 1; const byte ANIMATION_DATA[] = {0x3c, 0x00, 0x05, 0xdc, 0x3e, 0x0a};',
             b"rSVPin,9,1000,2000,3000,1500\\n", b'const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,500,0,1,0,8192,-1,0\\n";',
             b"\xff\xfe", b"-1", b"1e999", b"NaN", b","]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(FRAGMENTS) | st.binary(max_size=12), max_size=14),
       st.sampled_from(["x.csv", "x.xml", "x.json", "x.h", "x.bin", "x.cpp"]),
       st.sampled_from([None] + list(api.IMPORT_FORMATS)))
def test_any_bytes_import_or_fail_clearly(tmp_path_factory, parts, name, fmt):
    path = tmp_path_factory.mktemp("fuzz") / name
    path.write_bytes(b"".join(parts))
    try:
        imported = api.import_motion(str(path), fmt, {}, ReadOptions(fps=Fraction(30)))
    except api.UsageError as exc:
        assert str(exc)
        return
    fe, rep = front(imported.text)
    assert fe.tree is not None, [d.message for d in rep.diagnostics]     # what the import writes always parses
