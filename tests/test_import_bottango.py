"""The reader for Bottango "export to code" files (servoc/imports/bottango.py).

The curves are checked against an evaluation written here from the definition of a cubic
Bézier (Bernstein form, exact integers, the parameter found by bisection to 2**-60), not
from the reader's de Casteljau code.
"""

from __future__ import annotations

import os
from fractions import Fraction

import pytest

from servoc.imports import bottango
from servoc.imports.keyframes import ImportError_, ReadOptions

HERE = os.path.join(os.path.dirname(__file__), "fixtures", "import", "bottango")
NEW = os.path.join(HERE, "GeneratedCodeAnimations.cpp")
OLD = os.path.join(HERE, "GeneratedCommandStreams.cpp")

SERVOS = {9: (1000, 2000, 1500), 10: (600, 2400, 1200)}      # pin: (min, max, start) µs, as in NEW
# The curves of NEW, written out again: pin, start, duration, startY, startCtrlX, startCtrlY, endY, endCtrlX, endCtrlY
CURVES = {
    "Wave Hello": [(9, 0, 800, 4096, 260, 0, 7000, -260, 0), (10, 0, 500, 3413, 170, 0, 6000, -170, 0),
                   (9, 800, 700, 7000, 230, -400, 1500, -230, 300), (10, 1200, 600, 6000, 200, 0, 2000, -150, 500),
                   (9, 1500, 1000, 1500, 333, 0, 4096, -333, 0), (10, 1800, 700, 2000, 233, 100, 3413, -233, 0)],
    "Nod": [(9, 0, 400, 4096, 130, -200, 8192, -130, 0), (9, 400, 400, 8192, 130, 600, 0, -130, 0),
            (10, 400, 600, 2731, 200, 0, 5461, -200, 0), (9, 800, 600, 0, 200, 0, 4096, -200, 0),
            (10, 1000, 1000, 5461, 333, 0, 2731, -333, 0)],
}
BITS = 60


def reference_y(t, duration, y0, cx0, cy0, y1, cx1, cy1) -> Fraction:
    """y at time t (ms from the curve's start), exactly, at s = k / 2**BITS where x(s) <= t < x(s + 2**-BITS)."""
    if t <= 0:
        return Fraction(y0)
    if t >= duration:
        return Fraction(y1)
    n = 1 << BITS
    x1, x2, x3 = cx0, duration + cx1, duration
    assert 0 <= x1 <= x2 <= x3, "x(s) must be monotonic for this reference"

    def x_scaled(k):                          # x(k / n) * n**3
        m = n - k
        return 3 * m * m * k * x1 + 3 * m * k * k * x2 + k ** 3 * x3

    lo, hi, goal = 0, n, t * n ** 3
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if x_scaled(mid) <= goal else (lo, mid)
    k, m = lo, n - lo
    ys = (y0, y0 + cy0, y1 + cy1, y1)
    return Fraction(m ** 3 * ys[0] + 3 * m * m * k * ys[1] + 3 * m * k * k * ys[2] + k ** 3 * ys[3], n ** 3)


def reference_us(pin, y) -> Fraction:
    lo, hi, _ = SERVOS[pin]
    return min(max(lo + (hi - lo) * y / 8192, Fraction(lo)), Fraction(hi))


def load(path=NEW):
    with open(path, "rb") as f:
        return bottango.read(f.read(), path, ReadOptions())


def read_text(text, path="broken.cpp"):
    return bottango.read(text.encode(), path, ReadOptions())


def test_channels_and_tracks():
    kf = load()
    assert kf.format == "bottango"
    assert [(c.index, c.name, c.min_us, c.max_us, c.home_us) for c in kf.channels] == \
        [(9, "pin_9", 1000, 2000, 1500), (10, "pin_10", 600, 2400, 1200)]
    assert [t.name for t in kf.tracks] == ["Wave Hello", "Nod"]
    assert [t.length_ms for t in kf.tracks] == [2500, 2000]
    for track in kf.tracks:
        assert track.keys == () and track.sampled and track.curve is not None
        assert isinstance(track.length_ms, Fraction)
        assert set(track.curve(Fraction(0))) == {9, 10}
    assert any("loop" in note and "Wave Hello" in note for note in kf.notes)


def test_every_ms_of_every_curve_matches_the_reference():
    kf = load()
    for track in kf.tracks:
        curves = CURVES[track.name]
        for pin, start, duration, *shape in curves:
            later = [c[1] for c in curves if c[0] == pin and c[1] > start]
            last = min(later + [start + duration])         # a later curve takes over at its start
            for t in range(start, last + 1):
                y = reference_y(t - start, duration, *shape)
                assert abs(bottango.bezier_y(t - start, duration, *shape) - y) < 1e-6, (track.name, pin, t)
                got = track.curve(Fraction(t))[pin]
                assert isinstance(got, Fraction)
                assert abs(got - reference_us(pin, y)) <= Fraction(1, 1000), (track.name, pin, t, float(got))


def test_fractional_times_and_clamping():
    nod = load().tracks[1]
    y = reference_y(Fraction(1, 3), 400, 8192, 130, 600, 0, -130, 0)   # bisection compares exactly, so a Fraction works
    assert abs(nod.curve(Fraction(1201, 3))[9] - reference_us(9, y)) <= Fraction(1, 1000)
    assert nod.curve(Fraction(410))[9] == 2000          # the curve overshoots 8192 there; the width stops at max
    assert bottango.bezier_y(10, 400, 8192, 130, 600, 0, -130, 0) > 8192


def test_servo_holds_between_curves_and_before_its_first():
    wave, nod = load().tracks
    held = 600 + Fraction(1800 * 6000, 8192)            # pin 10 ends its first curve at y=6000 (500 ms)
    for t in (500, 501, 750, 1199):
        assert wave.curve(Fraction(t))[10] == held
    assert wave.curve(Fraction(1201))[10] != held
    for t in (0, 1, 399):
        assert nod.curve(Fraction(t))[10] == 1200        # no curve yet: its start µs from rSVPin
    assert nod.curve(Fraction(2000))[10] == 600 + Fraction(1800 * 2731, 8192)
    assert nod.curve(Fraction(5000))[9] == 1500          # after its last curve (y=4096)


def test_older_export_names_and_other_effectors():
    kf = load(OLD)
    assert [c.index for c in kf.channels] == [3]
    assert [t.name for t in kf.tracks] == ["Arm Up", "Rest"]
    arm, rest = kf.tracks
    assert arm.length_ms == 1000 and rest.length_ms == 0
    assert arm.curve(Fraction(1000))[3] == 2100 and arm.curve(Fraction(1200))[3] == 2100   # loop stream ignored
    assert rest.curve(Fraction(0))[3] == 1500


def test_bare_commands_sync_bundles_and_instant_curves():
    kf = read_text("rSVPin,4,1000,2000,3000,1000\n"
                   "sSY,sC,4,0,100,0,30,0,8192,-30,0;4,100,100,8192,30,0,0,-30,0\n"
                   "sCI,4,4096\n", "moves.txt")
    (track,) = kf.tracks
    assert track.name == "moves" and track.length_ms == 200
    assert track.curve(Fraction(100))[4] == 1500      # sCI at the start of the last timed curve (100 ms) wins
    assert track.curve(Fraction(50))[4] == 1000 + 1000 * reference_y(50, 100, 0, 30, 0, 8192, -30, 0) / 8192


SETUP = 'const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,2000,3000,1500\\n";\n'


def anim(commands):
    return SETUP + f'// animation 0, "A"\nconst char ANIM_0_DATA0[] PROGMEM = "{commands}";\n'


@pytest.mark.parametrize("text, words", [
    (anim("sC,9,0,500,4096,100,0,8192,-100\\n"), ["truncated", "line 3"]),
    (anim("sC\\n"), ["truncated"]),
    ('const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,2000\\n";\n', ["truncated", "line 1", "rSVPin"]),
    (anim("sC,12,0,500,4096,100,0,8192,-100,0\\n"), ["'12'", "rSVPin"]),
    (anim("sC,9,0,5x0,4096,100,0,8192,-100,0\\n"), ["not a whole number"]),
    ('const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1000,abc,3000,1500\\n";\n', ["not a whole number"]),
    ('const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,1500,1500,3000,1500\\n";\n', ["min and max are both 1500"]),
    (anim("sC,9,0,-5,4096,100,0,8192,-100,0\\n"), ["negative duration"]),
    (anim("sC,9,-5,500,4096,100,0,8192,-100,0\\n"), ["negative start"]),
    (anim("zz,9,0\\n"), ["unknown command"]),
    (SETUP + SETUP.replace("SETUP_DATA_0", "SETUP_DATA_1"), ["twice"]),
    ('const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,500,4096,100,0,8192,-100,0\\n";\n', ["no rSVPin"]),
    (SETUP, ["no animation"]),
])
def test_broken_inputs(text, words):
    with pytest.raises(ImportError_) as caught:
        read_text(text)
    message = str(caught.value)
    assert message.startswith("broken.cpp")
    for word in words:
        assert word in message


def test_sniff():
    for path in (NEW, OLD):
        with open(path, "rb") as f:
            assert bottango.sniff(f.read(), path)
    assert bottango.sniff(b"rSVPin,9,1000,2000,3000,1500\nsC,9,0,100,0,30,0,8192,-30,0\n", "x.txt")
    maestro = (b'<?xml version="1.0"?>\n<UscSettings version="1">'
               b'<Channels><Channel name="" min="3968" /></Channels></UscSettings>')
    blender = b'{"fps": 30, "frames": 2, "positions": {"arm": [1500, 1600]}}'
    csv = b"time_ms,a,b\n0,1500,1500\n500,1600,1400\n"
    as_json = b'[{"Setup": {"Controller Setup Commands": "rSVPin,9,1000,2000,3000,1500\\n"}}]'  # not this reader's
    for data in (maestro, blender, csv, as_json, b"", b"\xff\xfe\x00"):
        assert not bottango.sniff(data, "other")


def test_an_inverted_servo_runs_from_min_at_y_0_to_max_at_y_8192():
    """`rSVPin` with min above max (a servo set up inverted in Bottango): y = 0 is the first width."""
    text = ('const char SETUP_DATA_0[] PROGMEM = "rSVPin,9,2000,1000,3000,1500\\n";\n'
            'const char ANIM_0_DATA0[] PROGMEM = "sC,9,0,1000,0,100,0,8192,-100,0\\n";\n')
    kf = read_text(text)
    (channel,) = kf.channels
    assert (channel.min_us, channel.max_us) == (1000, 2000)
    curve = kf.tracks[0].curve
    assert curve(Fraction(0)) == {9: 2000} and curve(Fraction(1000)) == {9: 1000}
    assert 1000 < curve(Fraction(500))[9] < 2000
