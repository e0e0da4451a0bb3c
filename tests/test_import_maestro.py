"""servoc.imports.maestro: Pololu Maestro Control Center settings files -> Keyframes.

Fixtures in tests/fixtures/import/maestro/ are hand-written files laid out as the Control
Center writes them: wave_plain.xml (Mini Maestro 12, targets only) and wave_speeds.xml
(the same sequences in the newer 'targets s speeds a accelerations' form, CRLF lines),
micro6.xml (Micro Maestro 6), no_sequences.xml, and three broken or hostile files.
"""

from __future__ import annotations

import os
import time
from fractions import Fraction

import pytest
from hypothesis import given, settings as hsettings, strategies as st

from servoc.imports import maestro
from servoc.imports.keyframes import Channel, ImportError_, ReadOptions
from servoc.units import round_half_up

HERE = os.path.join(os.path.dirname(__file__), "fixtures", "import", "maestro")


def fixture(name: str) -> bytes:
    with open(os.path.join(HERE, name), "rb") as f:
        return f.read()


def read_fixture(name: str):
    return maestro.read(fixture(name), name, ReadOptions())


def settings(sequences: str, channels: str | None = None) -> bytes:
    """A small Micro Maestro 6 settings file with the given <Sequences> content."""
    if channels is None:
        channels = "".join(f'<Channel name="c{i}" mode="Servo" min="3968" max="8000" homemode="Off" '
                           f'home="0" speed="0" acceleration="0" neutral="6000" range="1905" />' for i in range(6))
    return (f'<!--Pololu Maestro servo controller settings file, http://www.pololu.com/catalog/product/1350-->\n'
            f'<UscSettings version="1"><Channels ServosAvailable="6" ServoPeriod="156">{channels}</Channels>'
            f'<Sequences>{sequences}</Sequences><Script ScriptDone="false" /></UscSettings>').encode()


def read_text(sequences: str, channels: str | None = None, path: str = "robot.xml"):
    return maestro.read(settings(sequences, channels), path, ReadOptions())


def error(sequences: str, channels: str | None = None) -> str:
    with pytest.raises(ImportError_) as info:
        read_text(sequences, channels)
    return str(info.value)


def at_ms(track) -> list:
    return [k.at_ms for k in track.keys]


# ---- the two frame forms ---------------------------------------------------------

def test_both_frame_text_forms_give_the_same_targets_and_times():
    plain, speeds = read_fixture("wave_plain.xml"), read_fixture("wave_speeds.xml")
    assert plain.format == speeds.format == "maestro"
    assert plain.channels == speeds.channels
    assert [[(k.at_ms, k.targets, k.source) for k in t.keys] for t in plain.tracks] == \
        [[(k.at_ms, k.targets, k.source) for k in t.keys] for t in speeds.tracks]
    channel_speeds = {c.index: (c.speed_us_s or 0) for c in plain.channels}
    assert all(k.speeds == channel_speeds for t in plain.tracks for k in t.keys)     # no frame speeds there
    assert any(k.speeds != channel_speeds for t in speeds.tracks for k in t.keys)
    assert [t.name for t in plain.tracks] == ["Wave", "Blink twice"]
    assert plain.tracks[0].keys[0].targets == {0: 1500, 3: 1750}  # 3 is ServoMultiplied: a servo


def test_new_form_reads_targets_then_speeds_in_maestro_units():
    """A frame's own speeds (after `s`) are 0.25 µs per 10 ms each: 25 µs/s; its accelerations
    (after `a`) are not imported, with a note."""
    kf = read_text('<Sequence name="S"><Frame name="Frame 0" duration="100">'
                   '4000 5000 0 0 0 0 s 7 8 0 0 0 0 a 1 2 0 0 0 0</Frame></Sequence>')
    key = kf.tracks[0].keys[0]
    assert key.targets == {0: 1000, 1: 1250}
    assert key.speeds == {0: 175, 1: 200, 2: 0, 3: 0, 4: 0, 5: 0}
    assert {c.index: c.speed_us_s for c in kf.channels}[1] is None      # its channel speed 0: no limit
    faster = read_text('<Sequence name="S"><Frame name="Frame 0" duration="100">4000 s 20</Frame>'
                       '<Frame name="Frame 1" duration="100">6000</Frame></Sequence>',
                       '<Channel name="c0" mode="Servo" min="3968" max="8000" speed="10" />')
    assert faster.channels[0].speed_us_s == 500          # the fastest it is asked to go: its frame's 20
    assert [k.speeds for k in faster.tracks[0].keys] == [{0: 500}, {0: 250}]   # else its channel's 10
    assert any("accelerations" in n for n in kf.notes)


def test_all_zero_frame_accelerations_give_no_note():
    kf = read_text('<Sequence name="S"><Frame name="Frame 0" duration="100">'
                   '4000 0 0 0 0 0 s 3 0 0 0 0 0 a 0 0 0 0 0 0</Frame></Sequence>')
    assert not any("accelerations" in n for n in kf.notes)


# ---- channels ----------------------------------------------------------------------

def test_non_servo_channels_are_left_out_with_their_targets():
    kf = read_fixture("wave_plain.xml")
    assert [c.index for c in kf.channels] == [0, 1, 3, 5, 6, 7, 8, 9, 10, 11]
    for track in kf.tracks:
        for key in track.keys:
            assert not {2, 4} & set(key.targets)
    # Frame 0 sets the Output channel 2 to 8000, frame 1 the Input channel 4 to 1023: both dropped.
    assert kf.tracks[0].keys[0].targets == {0: 1500, 3: 1750}
    assert kf.tracks[0].keys[1].targets == {0: 1000, 1: 1250}
    assert any("2 (Output)" in n and "4 (Input)" in n for n in kf.notes)


def test_servo_and_servo_multiplied_channels_are_servos():
    """The spec: channels whose mode is `Servo` or `ServoMultiplied` are servos; the others are not."""
    kf = read_fixture("wave_plain.xml")
    assert 3 in {c.index for c in kf.channels}
    assert not any("ServoMultiplied" in n for n in kf.notes)


def test_targets_outside_a_channels_range_are_clamped_with_a_note():
    kf = read_text('<Sequence name="S"><Frame name="Frame 0" duration="100">'
                   '3000 9000 0 0 0 0</Frame></Sequence>')
    lo = {c.index: c.min_us for c in kf.channels}
    hi = {c.index: c.max_us for c in kf.channels}
    got = kf.tracks[0].keys[0].targets
    assert got[0] == max(750, lo[0] or 750) and got[1] == min(2250, hi[1] or 2250), (got, lo, hi)
    assert any("clamped" in n and "2 targets" in n for n in kf.notes), kf.notes


def test_a_home_outside_a_channels_range_is_clamped_with_a_note(tmp_path):
    """The Maestro clamps the start-up position as it clamps any target: 2250 µs on a channel of
    1000..2000 µs starts at 2000 µs, and the program has no limit error."""
    channels = ('<Channel name="a" mode="Servo" min="4000" max="8000" homemode="Goto" home="9000" />'
                '<Channel name="b" mode="Servo" min="4000" max="8000" homemode="Goto" home="3000" />')
    frames = '<Sequence name="S"><Frame name="Frame 0" duration="1000">6000 6000</Frame></Sequence>'
    kf = read_text(frames, channels)
    assert [c.home_us for c in kf.channels] == [2000, 1000]
    assert any("2 targets outside the channel's min..max clamped" in n and "first: home, channel 0" in n
               for n in kf.notes), kf.notes
    text, _, _, _ = _frames_of(tmp_path, settings(frames, channels))      # no error (no limit violation)
    assert "pose home { a: 1996us, b: 1004us }" in text                   # the limit's edges, on the grid


def test_channel_names_limits_and_home():
    by_index = {c.index: c for c in read_fixture("wave_plain.xml").channels}
    assert by_index[0] == Channel(0, "jaw", Fraction(992), Fraction(2000), Fraction(1500))   # Goto 6000
    assert by_index[1] == Channel(1, None, Fraction(1000), Fraction(2000), None)             # blank name, Off
    assert by_index[5].home_us is None                                                      # Ignore
    assert by_index[10] == Channel(10, "eyelid", Fraction(1000), Fraction(2000), Fraction(2000))
    assert by_index[11].min_us == 750 and by_index[11].max_us == 2250


def test_quarter_microseconds_are_kept_exact():
    key = read_fixture("wave_plain.xml").tracks[0].keys[3]
    assert key.targets[11] == Fraction(6001, 4)
    assert isinstance(key.targets[0], Fraction)


def test_missing_mode_is_servo_and_mode_case_is_ignored():
    channels = ('<Channel name="x" min="4000" max="8000" homemode="goto" home="6000" />'
                '<Channel name="y" mode="OUTPUT" min="4000" max="8000" homemode="Off" home="0" />')
    kf = read_text('<Sequence name="S"><Frame name="Frame 0" duration="10">5000 6000</Frame></Sequence>', channels)
    assert kf.channels == (Channel(0, "x", Fraction(1000), Fraction(2000), Fraction(1500)),)
    assert kf.tracks[0].keys[0].targets == {0: 1250}


def test_channel_speeds_are_read_and_accelerations_get_a_note():
    channels = {c.index: c for c in read_fixture("micro6.xml").channels}
    assert {i: c.speed_us_s for i, c in channels.items() if c.speed_us_s} == {0: 750}     # speed="30"
    assert any("acceleration limits" in n for n in read_fixture("micro6.xml").notes)
    assert not any("acceleration" in n for n in read_fixture("wave_plain.xml").notes)


# ---- keys --------------------------------------------------------------------------

def test_zero_means_keep_and_an_all_zero_frame_is_a_pause():
    wave = read_fixture("wave_plain.xml").tracks[0]
    assert 1 not in wave.keys[0].targets          # channel 1 is 0 in frame 0
    assert wave.keys[2].targets == {}             # Frame 2: all zero
    assert read_fixture("wave_plain.xml").tracks[1].keys[0].targets == {10: 1000}


def test_each_frame_starts_when_the_durations_before_it_have_passed():
    """The Maestro sets a frame's targets at its start; the next starts `duration` later."""
    kf = read_fixture("wave_plain.xml")
    assert at_ms(kf.tracks[0]) == [0, 500, 750, 1750]
    assert kf.tracks[0].length_ms == 2500
    assert at_ms(kf.tracks[1]) == [0, 100] and kf.tracks[1].length_ms == 200
    assert all(t.paced and not t.sampled for t in kf.tracks)


def test_a_zero_duration_frame_starts_and_ends_at_once():
    kf = read_fixture("micro6.xml")
    assert at_ms(kf.tracks[1]) == [0] and kf.tracks[1].length_ms == 0
    assert kf.tracks[1].keys[0].targets == {0: 500, 1: 1750}


def test_fewer_targets_than_channels_keep_the_rest():
    nod = read_fixture("micro6.xml").tracks[0]
    assert nod.keys[0].targets == {0: 1500, 1: 2000}
    assert at_ms(nod) == [0, 400]


def test_key_source_names_the_sequence_and_frame():
    kf = read_fixture("wave_plain.xml")
    assert kf.tracks[0].keys[1].source == "Wave frame 1"
    assert [k.source for k in kf.tracks[1].keys] == ["Blink twice frame 0 (closed)", "Blink twice frame 1 (open)"]


def test_source_has_no_line_breaks():
    kf = read_text('<Sequence name="two&#10;lines"><Frame name="a&#13;&#10;b" duration="10">4000</Frame></Sequence>')
    assert kf.tracks[0].keys[0].source == "two lines frame 0 (a b)"
    assert kf.tracks[0].name == "two\nlines"                       # the name itself is kept as written


# ---- sequences ---------------------------------------------------------------------

def test_repeated_sequence_names_are_made_distinct_and_empty_ones_kept():
    """Each <Sequence> becomes a sequence, one without frames too (an empty one)."""
    kf = read_fixture("micro6.xml")
    assert [t.name for t in kf.tracks] == ["Nod", "Nod (2)", "Empty"]
    assert kf.tracks[2].keys == ()


def test_unnamed_sequence_gets_a_number():
    kf = read_text('<Sequence><Frame name="Frame 0" duration="10">4000</Frame></Sequence>')
    assert kf.tracks[0].name == "Sequence 1"


def test_no_sequences_gives_no_tracks():
    kf = read_fixture("no_sequences.xml")
    assert kf.tracks == ()
    assert len(kf.channels) == 6
    assert any("no sequences" in n for n in kf.notes)


def test_script_is_mentioned_only_when_there_is_one():
    assert any("<Script>" in n for n in read_fixture("wave_speeds.xml").notes)
    assert not any("<Script>" in n for n in read_fixture("wave_plain.xml").notes)


def test_bom_and_utf16_files_are_read():
    data = fixture("micro6.xml")
    expected = maestro.read(data, "a.xml", ReadOptions())
    assert maestro.read(b"\xef\xbb\xbf" + data, "a.xml", ReadOptions()) == expected
    utf16 = ('<?xml version="1.0" encoding="utf-16"?>\r\n' + data.decode()).encode("utf-16")
    assert maestro.read(utf16, "a.xml", ReadOptions()) == expected


# ---- hostile XML -------------------------------------------------------------------

def test_billion_laughs_fails_fast_with_import_error():
    start = time.perf_counter()
    with pytest.raises(ImportError_, match="DOCTYPE") as info:
        maestro.read(fixture("billion_laughs.xml"), "billion_laughs.xml", ReadOptions())
    assert time.perf_counter() - start < 1.0
    assert "billion_laughs.xml" in str(info.value)


def test_external_entity_is_refused():
    with pytest.raises(ImportError_, match="DOCTYPE") as info:
        maestro.read(fixture("external_entity.xml"), "external_entity.xml", ReadOptions())
    assert "root:" not in str(info.value)


@pytest.mark.parametrize("doctype", [
    '<!DOCTYPE UscSettings SYSTEM "http://127.0.0.1:9/evil.dtd">',
    '<!DOCTYPE UscSettings [<!ENTITY % p SYSTEM "file:///etc/passwd"> %p;]>',
    '<!DOCTYPE UscSettings>',
])
def test_any_doctype_is_refused(doctype):
    data = settings('<Sequence name="S"><Frame name="Frame 0" duration="10">4000</Frame></Sequence>')
    data = data.replace(b"<UscSettings", doctype.encode() + b"<UscSettings", 1)
    with pytest.raises(ImportError_, match="DOCTYPE"):
        maestro.read(data, "evil.xml", ReadOptions())


def test_undeclared_entity_is_an_xml_error():
    with pytest.raises(ImportError_, match="evil.xml"):
        maestro.read(settings('<Sequence name="&xxe;" />'), "evil.xml", ReadOptions())


# ---- broken files ------------------------------------------------------------------

@pytest.mark.parametrize("data", [fixture("truncated.xml"), b"", b"not xml at all <<<", b"<UscSettings>",
                                  b'{"fps": 24}', b"\x00\x01\x02\xff"])
def test_unreadable_xml_is_an_import_error(data):
    with pytest.raises(ImportError_, match="truncated.xml"):
        maestro.read(data, "truncated.xml", ReadOptions())


def test_wrong_root_is_an_import_error():
    with pytest.raises(ImportError_, match="<Settings>"):
        maestro.read(b"<Settings><Channels /></Settings>", "x.xml", ReadOptions())


@pytest.mark.parametrize("channels", [None, "", "<Foo />"])
def test_no_channels_is_an_import_error(channels):
    body = (b'<UscSettings version="1"><Sequences /></UscSettings>' if channels is None
            else f'<UscSettings version="1"><Channels>{channels}</Channels></UscSettings>'.encode())
    with pytest.raises(ImportError_, match="Channel"):
        maestro.read(body, "x.xml", ReadOptions())


@pytest.mark.parametrize("frame, what", [
    ('<Frame name="Frame 0" duration="100">4000 abc</Frame>', "'abc'"),
    ('<Frame name="Frame 0" duration="100">4000 -4000</Frame>', "'-4000'"),
    ('<Frame name="Frame 0" duration="100">4000 65536</Frame>', "'65536'"),
    ('<Frame name="Frame 0" duration="100">4000 4000.5</Frame>', "'4000.5'"),
    ('<Frame name="Frame 0" duration="100">4000 4000 4000 4000 4000 4000 4000</Frame>', "only 6 channels"),
    ('<Frame name="Frame 0">4000</Frame>', "no duration"),
    ('<Frame name="Frame 0" duration="-5">4000</Frame>', "'-5'"),
    ('<Frame name="Frame 0" duration="12.5">4000</Frame>', "'12.5'"),
    ('<Frame name="Frame 0" duration="soon">4000</Frame>', "'soon'"),
    ('<Frame name="Frame 0" duration="70000">4000</Frame>', "'70000'"),
    ('<Frame name="Frame 0" duration="100">4000 a 0 s 0</Frame>', "targets s speeds"),
    ('<Frame name="Frame 0" duration="100">4000 s 0 s 0</Frame>', "targets s speeds"),
    ('<Frame name="Frame 0" duration="100">4000 s fast a 0</Frame>', "'fast'"),
])
def test_broken_frame_names_file_sequence_and_frame(frame, what):
    ok = '<Frame name="Frame 0" duration="100">4000</Frame>'
    message = error(f'<Sequence name="Wave">{ok}{frame.replace("Frame 0", "Frame 1")}</Sequence>')
    assert message.startswith("robot.xml: sequence 'Wave', frame 1 ('Frame 1')")
    assert what in message


@pytest.mark.parametrize("attributes, what", [
    ('mode="Stepper" homemode="Off"', "mode"),
    ('mode="Servo" homemode="Later"', "homemode"),
    ('mode="Servo" homemode="Off" min="abc"', "min"),
    ('mode="Servo" homemode="Goto" home="-1"', "home"),
    ('mode="Servo" homemode="Off" min="8000" max="4000"', "above max"),
])
def test_broken_channel_is_an_import_error(attributes, what):
    message = error("", f'<Channel name="a" {attributes} />')
    assert message.startswith("robot.xml: channel 0") and what in message


def test_errors_never_escape_as_other_exception_types():
    for data in [fixture("truncated.xml")[:n] for n in range(0, 1600, 37)]:
        with pytest.raises(ImportError_):
            maestro.read(data, "t.xml", ReadOptions())


# ---- sniff -------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["wave_plain.xml", "wave_speeds.xml", "micro6.xml", "no_sequences.xml"])
def test_sniff_knows_settings_files(name):
    assert maestro.sniff(fixture(name), name)


@pytest.mark.parametrize("data", [
    b'<UscSettings version="1"></UscSettings>',
    b'\xef\xbb\xbf  \r\n<?xml version="1.0" encoding="utf-8"?>\r\n<!--a comment-->\r\n<UscSettings version="1">',
    '<?xml version="1.0" encoding="utf-16"?><UscSettings version="1">'.encode("utf-16"),
    b"\n\n<UscSettings/>",
])
def test_sniff_true(data):
    assert maestro.sniff(data, "x.xml") is True


@pytest.mark.parametrize("data", [
    b'{"fps": 24, "frames": 48, "servos": {"0": {"name": "Bone", "positions": [1500, 1510]}}}',
    b"time_ms,ch0,ch1\n0,1500,1500\n20,1510,1490\n",
    b"<Settings><Channels/></Settings>",
    b"<UscSettingsOld/>",
    b"<!-- <UscSettings> -->\n<Other/>",
    b"",
    b"\x00\x01\xfe\xff",
    b"uscsettings",
])
def test_sniff_false(data):
    assert maestro.sniff(data, "x") is False


@hsettings(max_examples=200, deadline=None)
@given(st.binary(max_size=300))
def test_sniff_never_raises(data):
    assert maestro.sniff(data, "x") in (True, False)


# ---- the Maestro's own timing, end to end (Keyframes -> program -> the frames it sends) ----

def _frames_of(tmp_path, xml: bytes):
    """Import `xml` and plan the program: (the program's text, its plan, every frame's N per servo
    until the program ends, the import's warnings)."""
    from servoc import api
    from servoc.plan import expand
    src = tmp_path / "seq.xml"
    src.write_bytes(xml)
    imported = api.import_motion(str(src))
    out = tmp_path / "seq.servo"
    out.write_text(imported.text)
    source, reporter = api.load_source(str(out))
    fe = api.front_end(source, reporter)
    assert fe.plan is not None and not reporter.has_errors, [d.message for d in reporter.diagnostics]
    frames = [f.n for _, f in zip(range(fe.plan.total_frames), expand(fe.plan))]
    return imported.text, fe.plan, frames, imported.warnings


def _one_servo(frames: str, speed: int = 0, home: int = 6000) -> bytes:
    channel = (f'<Channel name="arm" mode="Servo" min="2000" max="10000" homemode="Goto" home="{home}" '
               f'speed="{speed}" acceleration="0" neutral="6000" range="1905" />')
    return settings(f'<Sequence name="S">{frames}</Sequence>', channel + channel.replace('"arm"', '"b"')
                    .replace('homemode="Goto"', 'homemode="Off"'))


def _n(us: int) -> int:
    from servoc.units import width_to_n
    return width_to_n(us)


def test_a_frame_reaches_its_target_in_the_servos_own_time_and_the_next_starts_a_duration_later(tmp_path):
    """The issue's rule: frame 1 (1000 ms) goes from 1500 to 2000 µs; at the servo's full speed
    (63 N x 2.467 ms = 155 ms) it is there within 155 ms plus a frame of its start, not at the
    frame's end; frame 2 starts 1000 ms after frame 1 started (to the nearest frame)."""
    text, plan, frames, warnings = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="500">6000</Frame>'
        '<Frame name="Frame 1" duration="1000">8000</Frame>'
        '<Frame name="Frame 2" duration="1000">6000</Frame>'))
    p = plan.period_us
    arm = [f[0] for f in frames]
    first_move = next(i for i, n in enumerate(arm) if n != _n(1500))      # frame 1's move begins
    reached = next(i for i, n in enumerate(arm) if n == _n(2000))
    home = first_move - round(500_000 / p)                # frames before the sequence: `home` takes one
    assert home == 1 and "home home" in text               # frame 1 starts on the frame nearest 500 ms
    assert (reached - first_move + 1) * p <= (_n(2000) - _n(1500)) * 2467 + p
    back = next(i for i in range(reached, len(arm)) if arm[i] != _n(2000))
    assert abs((back - first_move) * p - 1_000_000) <= p, (back, first_move, p)
    assert abs((len(arm) - home) * p - 2_500_000) <= p / 2   # the sequence lasts the sum of the durations
    assert warnings == ()


def test_a_channels_speed_paces_its_moves_and_becomes_the_servos_speed(tmp_path):
    """speed="10" is 250 µs/s: 63 N (504 µs) take 2.016 s; the servo is declared at that speed."""
    text, plan, frames, warnings = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="3000">8000</Frame><Frame name="Frame 1" duration="100">6000</Frame>',
        speed=10))
    p = plan.period_us
    arm = [f[0] for f in frames]
    reached = arm.index(_n(2000)) - 1                         # frames from the sequence's start (home: one)
    # 63 N (504 µs) at 250 µs/s: 2016 ms, to the next frame; a linear move's last step of one N comes
    # half a step (16 ms) before its end, by the Statements rule's rounding
    assert 2_016_000 - 16_000 <= (reached + 1) * p <= 2_016_000 + p, reached
    assert "servo arm = P1.0 speed 1s/23.125deg" in text     # 250 µs/s = 31.25 N/s = 23.125 deg/s
    assert len(warnings) == 1 and "S frame 1" in warnings[0] and "100 ms" in warnings[0]


def test_a_frames_own_speeds_are_used_and_zero_is_as_fast_as_the_servo_allows(tmp_path):
    text, plan, frames, _ = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="3000">8000 0 s 10 0</Frame>'
        '<Frame name="Frame 1" duration="1000">6000 0 s 0 0</Frame>', speed=10))
    p = plan.period_us
    arm = [f[0] for f in frames]
    reached = arm.index(_n(2000)) - 1
    assert 2_016_000 - 16_000 <= (reached + 1) * p <= 2_016_000 + p, reached
    back = len(arm) - next(i for i, n in enumerate(reversed(arm)) if n != _n(1500)) - 1     # at 1500 again
    # frame 1 starts at 3 s (on the nearest frame); its speed 0 is as fast as the servo allows: the
    # default servo's 63 N x 2.467 ms = 155 ms, so the servo is declared without a slower speed
    assert 3_155_400 - p / 2 <= back * p <= 3_155_400 + p + p / 2, back
    assert "servo arm = P1.0 limit" in text


def test_a_pause_frame_and_a_missing_home_keep_the_clock(tmp_path):
    """A servo with no position goes at once (one frame); a frame that sets nothing only waits."""
    text, plan, frames, _ = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="200">0 7000</Frame>'
        '<Frame name="pause" duration="400">0 0</Frame>'
        '<Frame name="Frame 2" duration="300">0 5000</Frame>'))
    p = plan.period_us
    b = [f[1] for f in frames]
    assert b[0] is None and b[1] == _n(1750)                  # home moves arm only; b at once, in frame 1
    left = next(i for i in range(1, len(b)) if b[i] != _n(1750)) - 1     # frames since the sequence began
    assert abs(left * p - 600_000) <= p / 2                   # frame 2 starts at 200 + 400 ms
    assert abs((len(b) - 1) * p - 900_000) <= p / 2


@pytest.mark.toolchain
def test_a_file_with_channel_and_frame_speeds_verifies_in_ucsim(tmp_path):
    """micro6.xml (a channel speed of 30, a zero-length frame) imported, compiled and run: every
    pulse as planned."""
    from servoc import api
    from servoc.plan import verify_frames
    src = tmp_path / "micro6.xml"
    src.write_bytes(fixture("micro6.xml"))
    out = tmp_path / "micro6.servo"
    out.write_text(api.import_motion(str(src)).text)
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None, [d.message for d in reporter.diagnostics if d.is_error]
    assert "speed 1s/69.375deg" in out.read_text()           # speed="30": 750 µs/s
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok and report.max_error_cycles == 0, report.mismatches[:5]


def test_a_frame_too_short_for_its_move_is_a_warning_on_stderr_naming_it(tmp_path, capsys):
    """The file is written and the exit is lint's (0 here); the warning names the file and the frame."""
    from servoc import cli
    src = tmp_path / "short.xml"
    src.write_bytes(_one_servo('<Frame name="Frame 0" duration="1000">8000</Frame>'
                               '<Frame name="flick" duration="20">4000</Frame>'))
    assert cli.main(["import", str(src), "-o", str(tmp_path / "short.servo")]) == 0
    out = capsys.readouterr()
    assert f"{src}: warning: S frame 1 (flick): its move needs" in out.err and "20 ms" in out.err
    assert "warning" not in out.out and (tmp_path / "short.servo").exists()


def test_a_frame_shorter_than_its_move_is_cut_where_the_next_frame_starts(tmp_path):
    """The spec: the next frame starts `duration` ms after this one started, as on the Maestro. At
    500 µs/s, 1500 to 2000 µs needs 1008 ms; frame 0 lasts 200 ms: there the Maestro has the servo
    at 1600 µs (N 137.5) and sets frame 1's target. The import cuts the move there (N 137, as far as
    the servo gets in the frames to frame 1's start) and frame 1 starts on the frame nearest 200 ms."""
    text, plan, frames, warnings = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="200">8000</Frame><Frame name="Frame 1" duration="1000">6000</Frame>',
        speed=20))
    arm = [f[0] for f in frames]
    assert max(arm) == 137 and arm[-1] == _n(1500)             # never on to 2000 µs (N 188)
    assert _starts(text, plan.period_us)["S frame 1"] == round_half_up(Fraction(200_000, plan.period_us))
    assert "  move S_0 in 196ms  # S frame 0: arm on the way as the next frame starts\n" in text
    assert len(warnings) == 1 and warnings[0].startswith("S frame 0: its move needs 1008 ms")
    assert "the next frame starts on time" in warnings[0]


def test_a_servo_cut_short_goes_on_to_its_target_unless_the_next_frame_sets_it(tmp_path):
    """Frame 1 sets only `b`: the Maestro leaves `arm`'s target, and it goes on to 2000 µs at its
    speed, there about 1008 ms after frame 0 started; `b` is set when frame 1 starts (200 ms)."""
    text, plan, frames, _ = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="200">8000</Frame><Frame name="Frame 1" duration="1500">0 7000</Frame>',
        speed=20))
    p = plan.period_us
    arm, b = [f[0] for f in frames], [f[1] for f in frames]
    assert abs((arm.index(_n(2000)) - 1) * p - 1_008_000) <= 16_000 + p     # frame 0 is `home`
    assert b.index(_n(1750)) - 1 == round_half_up(Fraction(200_000, p))
    assert "# S frame 1: arm there" in text


def test_the_last_frame_played_is_not_cut(tmp_path):
    """After the last frame of the last sequence nothing changes the targets: its move completes
    (with the warning, which says so)."""
    text, plan, frames, warnings = _frames_of(tmp_path, _one_servo(
        '<Frame name="Frame 0" duration="100">8000</Frame>', speed=20))
    assert frames[-1][0] == _n(2000)
    assert len(warnings) == 1 and "last frame played, so nothing changes the targets" in warnings[0]


def test_each_servo_of_a_frame_goes_at_its_own_speed(tmp_path):
    """Two channels, 500 µs/s and as fast as the servo allows, both told to go 504 µs: the fast one
    is there after its own travel (155 ms), the slow one after 1008 ms, each at constant speed."""
    channels = ('<Channel name="slow" mode="Servo" min="2000" max="10000" homemode="Goto" home="6000" speed="20" />'
                '<Channel name="fast" mode="Servo" min="2000" max="10000" homemode="Goto" home="6000" speed="0" />')
    text, plan, frames, warnings = _frames_of(tmp_path, settings(
        '<Sequence name="S"><Frame name="Frame 0" duration="2000">8000 8000</Frame></Sequence>', channels))
    p = plan.period_us
    slow, fast = [f[0] for f in frames], [f[1] for f in frames]
    fast_there, slow_there = fast.index(_n(2000)), slow.index(_n(2000))    # frame 0 is `home`
    assert 155_400 - 3_000 <= fast_there * p <= 155_400 + p, fast_there      # its last step comes early
    # the slow one passes one move boundary (the fast one's arrival), on a whole N: that can cost it
    # the time of one N at its speed (16 ms), never more
    assert 1_008_000 - 16_000 <= slow_there * p <= 1_008_000 + 16_000 + p, slow_there
    steps = [b - a for a, b in zip(slow[1:slow_there + 1], slow[2:slow_there + 1])]
    assert max(steps) <= 1 and sum(steps) > 0           # 500 µs/s is 0.33 N a frame: never two at once
    assert "slow there" in text and "fast there" in text and warnings == ()


@hsettings(max_examples=40, deadline=None)
@given(st.data())
def test_any_sequence_imports_to_a_program_without_errors(tmp_path_factory, data):
    """Whatever the channels' and frames' speeds, targets and durations, the moves the import writes
    are never faster than a servo may go: lint finds no error (no infeasible-speed) in the program.
    And each frame's moves start on the firmware frame nearest the frame's start time (`_starts`):
    a frame whose move needs longer than its duration is cut where the next one starts, so that
    one starts on time (a frame whose moves need a frame at least, with less than one frame to the
    next, makes the next start one frame late)."""
    from servoc import api
    from servoc.diagnostics import Reporter
    from servoc.source import SourceFile
    count = data.draw(st.integers(1, 4))
    channels = "".join(
        f'<Channel name="c{i}" mode="Servo" min="{data.draw(st.sampled_from([2000, 3968, 4000]))}" '
        f'max="{data.draw(st.sampled_from([8000, 10000]))}" homemode="{data.draw(st.sampled_from(["Goto", "Off"]))}" '
        f'home="{data.draw(st.sampled_from([0, 6000, 7000]))}" speed="{data.draw(st.sampled_from([0, 5, 20, 200]))}" />'
        for i in range(count))
    frames, durations = "", []
    for k in range(data.draw(st.integers(1, 5))):
        targets = " ".join(str(data.draw(st.sampled_from([0, 4000, 6000, 6001, 8000]))) for _ in range(count))
        speeds = data.draw(st.sampled_from(["", " s " + " ".join(str(data.draw(st.sampled_from([0, 3, 40])))
                                                                   for _ in range(count))]))
        durations.append(data.draw(st.sampled_from([0, 1, 40, 100, 300, 2500])))
        frames += f'<Frame name="F{k}" duration="{durations[-1]}">{targets}{speeds}</Frame>'
    src = tmp_path_factory.mktemp("maestro") / "any.xml"
    src.write_bytes(settings(f'<Sequence name="S">{frames}</Sequence>', channels))
    text = api.import_motion(str(src)).text
    source = SourceFile("any.servo", text)
    reporter = Reporter(source)
    fe = api.front_end(source, reporter)
    assert not [d.message for d in reporter.diagnostics if d.is_error], text
    starts, before = _starts(text, fe.plan.period_us), None
    for k in range(len(durations)):
        want = round_half_up(Fraction(sum(durations[:k]) * 1000, fe.plan.period_us))
        if f"S frame {k} (F{k})" in starts:
            start = starts[f"S frame {k} (F{k})"]
            assert want <= start <= max(want, -1 if before is None else before + 1), (k, want, start, text)
            before = start


def _starts(text: str, period_us: int) -> dict:
    """The frame (from the start of sequence S) at which each Maestro frame's first move starts, by
    the frame counts of the statements the import wrote (the Statements rule)."""
    import re
    from servoc.units import frames_for, move_frames
    body = text[text.index("sequence S {"):]
    body = body[:body.index("\n}")]
    starts, at = {}, 0
    for kind, ms, why in re.findall(r"^  (move \S+ in|hold) ([0-9.]+)ms  # (.*)$", body, re.M):
        if kind != "hold":
            starts.setdefault(why.split(":")[0], at)
        at += (frames_for if kind == "hold" else move_frames)(Fraction(ms) * 1000, period_us)
    return starts


def twenty_four(speeds: tuple, durations: tuple, count: int) -> bytes:
    """A Mini Maestro 24's settings: channel i at speeds[i % len], `count` frames of the durations in
    turn, each moving every channel (4000, 8000, 5000, 7000 quarter µs, shifted a channel a frame)."""
    channels = "".join(f'<Channel name="c{i}" mode="Servo" min="3968" max="8000" homemode="Goto" home="6000" '
                       f'speed="{speeds[i % len(speeds)]}" />' for i in range(24))
    frames = "".join(f'<Frame name="F{k}" duration="{durations[k % len(durations)]}">'
                     + " ".join(str((4000, 8000, 5000, 7000)[(i + k) % 4]) for i in range(24)) + "</Frame>"
                     for k in range(count))
    return settings(f'<Sequence name="S">{frames}</Sequence>', channels)


@pytest.mark.toolchain
def test_twenty_four_channels_of_four_speeds_verify_in_ucsim(tmp_path):
    """A Mini Maestro 24: channels at 4 speeds (0, 5, 20, 60), every frame moving all of them, some
    frames too short for their moves: each frame becomes a run of moves (one per arrival), the
    program lints clean and its firmware sends every planned pulse on three ports."""
    from servoc import api
    from servoc.plan import verify_frames
    src = tmp_path / "big.xml"
    src.write_bytes(twenty_four((0, 5, 20, 60), (300, 1200, 50), 4))
    imported = api.import_motion(str(src))
    out = tmp_path / "big.servo"
    out.write_text(imported.text)
    assert imported.moves_out > 2 * 4 and imported.warnings       # runs of moves; short frames warned
    source, reporter = api.load_source(str(out))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None, [d.message for d in reporter.diagnostics if d.is_error]
    report = api.verify(fe.plan, firmware, verify_frames(fe.plan))
    assert report.ok and report.max_error_cycles == 0 and report.pulses >= 24 * fe.plan.total_frames - 24, \
        report.mismatches[:5]


def test_an_import_whose_motion_needs_more_than_the_default_is_written_at_the_period_it_needs(tmp_path, monkeypatch):
    """Maestro frames start on the frames of the default period of a program on the same pins; a
    motion that needs more than that program (here a floor far too short for 24 servos) is written
    again from the period it needs: the program written holds its own frame and lints clean."""
    from servoc import api
    src = tmp_path / "big.xml"
    src.write_bytes(twenty_four((0, 20), (300, 600), 3))
    monkeypatch.setattr(api, "_default_period_on", lambda pins: 2000)
    text = api.import_motion(str(src)).text
    frame_us = round(Fraction(text.split("frame ", 1)[1].split("ms", 1)[0]) * 1000)
    assert frame_us > 2000 and api._shortest(text) <= frame_us
    out = tmp_path / "big.servo"
    out.write_text(text)
    source, reporter = api.load_source(str(out))
    fe = api.front_end(source, reporter)
    assert fe.plan is not None and not any(d.is_error for d in reporter.diagnostics), \
        [d.message for d in reporter.diagnostics if d.is_error]
    assert fe.plan.period_us == frame_us and fe.plan.min_period_us <= frame_us
