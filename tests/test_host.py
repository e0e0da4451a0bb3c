"""`host ssc32`: the firmware speaks the SSC-32 protocol (docs/host-protocol.md) while `host` runs.

Each session here is run in ucsim and checked twice: by `servoc verify`'s model of the protocol
(servoc.ssc32), frame by frame and byte by byte, and by hand against values computed in the
comments (the replies' bytes, the widths a move reaches), so that a model wrong in the same way as
the firmware would still fail. A firmware changed to do something else fails verify.
"""

from __future__ import annotations

import re


import pytest

from conftest import build_text, front_end_text
from servoc import flow, ssc32
from servoc.model import host_channel
from test_verify_observes import problems, rebuilt, watch

pytestmark = pytest.mark.toolchain

ARM = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
input stop = P3.2
servo base = P1.0
servo shoulder = P1.1 limit 30deg..150deg
servo elbow = P1.2 reverse
servo grip = P1.3 channel 7 speed 0.4s/60deg trim 3
pose rest { base: 90deg, shoulder: 90deg, elbow: 90deg, grip: 45deg }
pose tuck { base: 90deg, shoulder: 40deg }
home rest
sequence wave {
  move tuck
  move rest
}
main {
  host until press stop
  move tuck
}
"""

_BUILT: dict[str, object] = {}


def built(text: str = ARM):
    if text not in _BUILT:
        _BUILT[text] = build_text(text)
    return _BUILT[text]


def session(scenario: str, frames: int, text: str = ARM):
    b = built(text)
    trace, report = watch(b, scenario, frames)
    assert report.ok, problems(report)
    return b, trace, report


def sent(trace) -> bytes:
    return bytes(b for _, b in trace.sent)


def widths(b, trace, port: int, bit: int) -> list[int]:
    """The pin's pulse widths in machine cycles, in order."""
    edges = trace.pin_edges(port, bit)
    return [fall - rise for (rise, up), (fall, _) in zip(edges, edges[1:]) if up == 1]


def n_of(b, cycles: int) -> int:
    """The N whose width is `cycles` at the program's clock."""
    target = b.plan.program.target
    return next(n for n in range(251) if target.width_cycles(n) == cycles)


def test_ver_q_and_qp_are_answered_and_a_group_moves_within_its_time():
    b, trace, report = session('0.2s "VER\\r"\n'
                               '0.3s "#0 P1000 T500\\r"\n'
                               '0.45s "Q\\r"\n'
                               '1.2s "q\\rqp0\\rQP 7\\rQP 31\\r"\n', 300)
    # VER; Q mid-move '+'; after it '.', QP0 = (500 + 8 x 63) / 10 = 100 (1000 us is N 62.5 -> 63);
    # QP7: grip, 45deg = N 61, trim 3: N 64, (500 + 512) / 10 = 101; channel 31 has no servo: 0
    assert sent(trace) == b"SSC32-servoc-0.1\r+.d\x65\x00"
    base = widths(b, trace, 1, 0)
    assert n_of(b, base[-1]) == 63 and n_of(b, base[0]) == 122       # 90deg is N 122
    # T500 at P: (500 x RT + 32768) >> 16 frames, RT = round(65536000 / P)
    p = b.plan.period_us
    f = (500 * ssc32.time_factor(p) + 32768) >> 16
    moving = [w for w in base if w not in (base[0], base[-1])]
    assert len(moving) == f - 1


def test_top_speed_and_s_limit_a_group():
    # base 122 -> 250 (P2500): 128 DAV at 2.467 ms each = 315.7 ms; asked for T100: the servo's own time
    b, trace, report = session('0.2s "#0P2500T100\\r"\n', 200)
    p = b.plan.period_us
    need = -(-128 * 7400 // (3 * p))         # ceil(128 x 7400/3 us / P)
    base = widths(b, trace, 1, 0)
    assert len([w for w in base if w not in (base[0], base[-1])]) == need - 1
    # S100 us/s: 128 N (1024 us) at 100 us/s is 10.24 s: F = ceil(10,240,000 us / P), the whole
    # frames that last it; frame k of it is 122 + floor(128 k / F + 1/2)
    b, trace, report = session('0.2s "#0P2500S100\\r"\n', 300)
    f = -(-128 * 8_000_000 // (100 * p))
    ns = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    k = len(ns) - next(i for i, n in enumerate(ns) if n != 122) - 1 + -(-f // 256)   # N moves first at k = F / 256
    assert (f - 1) * p < 10_240_000 <= f * p and ns[-1] == 122 + (2 * 128 * k + f) // (2 * f)


def _leaves(d: int, f: int) -> int:
    """The k at which a move of d N over F frames first leaves N0: floor(d k / F + 1/2) >= 1."""
    return -(-f // (2 * d))


def _lands(d: int, f: int) -> int:
    """The k at which it first commands N1: floor(d k / F + 1/2) >= d."""
    return -(-(2 * d - 1) * f // (2 * d))


def test_the_group_lasts_its_slowest_s_whichever_servo_has_it():
    # line 1: base 122 -> 63 (59 N, 472 us) at S200: 2.36 s; shoulder 122 -> 125 (3 N) at S20:
    # 1.2 s: the first entry's S sets F = ceil(2,360,000 us / P). Line 2: base 63 -> 125 (62 N)
    # at S1000: 0.496 s; shoulder 125 -> 50 (75 N, 600 us) at S400: 1.5 s: the second's sets it.
    b, trace, report = session('0.2s "#0P1000S200#1P1500S20\\r"\n'
                               '3.0s "#0P1500S1000#1P900S400\\r"\n', 820)
    p = b.plan.period_us
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    for f, (n0, n1), (m0, m1) in ((-(-2_360_000 // p), (122, 63), (122, 125)),
                                  (-(-1_500_000 // p), (63, 125), (125, 50))):
        start = base.index(n0)
        one = next(i for i in range(start, len(base)) if base[i] != n0) - _leaves(abs(n1 - n0), f) + 1
        assert base.index(n1, one) == one + _lands(abs(n1 - n0), f) - 1          # frame k is one + k - 1
        assert shoulder.index(m1, one) == one + _lands(abs(m1 - m0), f) - 1


def test_a_move_slower_than_65535_frames_takes_65535():
    # base 122 -> 250 at S1: 1024 us at 1 us/s would be 1024 s, past 65535 frames: F = 65535, and
    # frame k commands 122 + floor(128 k / 65535 + 1/2): N 123 first at k = 256, so frame 1 of
    # the move, 255 frames before it, comes within 2 P of the CR's stop bit (10 bytes at 9600 baud)
    b, trace, report = session('0.2s "#0P2500S1\\r"\n', 420)
    assert ssc32.frames_s(128, 1, b.plan.period_us) == 65535
    target = b.plan.program.target
    period = target.cycles(b.plan.period_us)
    edges = trace.pin_edges(1, 0)
    rises = [c for c, level in edges if level == 1]
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    first = rises[base.index(123) - 255]
    stop_bit = target.cycles(200_000) + 10 * 10 * 96            # 10 bytes, 96 machine cycles a bit
    assert stop_bit < first <= stop_bit + 2 * period


def test_lines_right_after_ver_are_read_while_its_answer_goes_out():
    # VER's 17-byte answer takes 17 byte times to send; the group line, Q and QP sent right behind
    # it are read meanwhile (none lost); the Q's and QP's answers wait for VER's, in order
    b, trace, report = session('0.2s "VER\\r#0P2000S500#1P1000#2P1700T300\\rQ\\rQP1\\r"\n', 200)
    assert not [r for r in trace.observation.received if not r.queued]
    out = sent(trace)
    assert out[:len(ssc32.VERSION_REPLY)] == ssc32.VERSION_REPLY and out[len(ssc32.VERSION_REPLY):][:1] == b"+"
    assert len(out) == len(ssc32.VERSION_REPLY) + 2


def test_every_kind_of_line_end_does_what_the_model_says():
    # the line end takes one path per kind of line (a command, a line ending in '#' c, one ending
    # in a word of an open entry): each kind, and bad lines of each, against verify's model
    lines = ["#5", "#0P1100#5", "#0P1200S900", "#0PO5#1", "#1P1300T100", "Q", "QP 0", "P1500", "T500",
             "#0", "", "#0P1400#7", "#7PO-5#2PO3", "#0P1500Q", "Q#0", "STOP 0", "VER", "#2P1600 S 300 T 50"]
    scenario = "".join(f'{0.2 + 0.12 * i:.2f}s "{line}\\r"\n' for i, line in enumerate(lines))
    b, trace, report = session(scenario, 450)
    assert not [r for r in trace.observation.received if not r.queued]
    assert len(sent(trace)) == 2 + len(ssc32.VERSION_REPLY)          # Q, QP 0 and VER answered


HOST_AND_A_SELECT = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
input stop = P3.2
input go = P3.3
servo a = P1.0
pose mid { a: 90deg }
pose low { a: 60deg }
home mid
sequence dip {
  select {
    on press go { move low }
    meanwhile { move mid in 1s; move low in 1s }
  }
  move mid
}
main {
  host until press stop
  move low
}
"""


def test_pl_plays_a_sequence_with_a_select_an_input_ends_and_the_host_reads_meanwhile():
    # `dip` plays: its meanwhile body holds `a` at mid (N 122) until go is pressed, then `a` goes to
    # low (60 deg: N 81) and back; the Q read while the select waits is answered '+' (the select
    # leaves the host's bytes alone), the frame the press cuts the body is read too, and the group
    # after the sequence moves `a` to 1000 us (N 63); `stop` ends `host`
    from servoc.steps import host_playable
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.5s "Q\\r"\n0.7s go active\n0.8s go inactive\n'
                               '1.0s "#0P1000\\r"\n1.6s stop active\n', 400, HOST_AND_A_SELECT)
    assert host_playable(b.plan.program) == ("dip",)
    assert sent(trace) == b"+"
    a = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    low = a.index(81)
    press = round(0.7e6 / b.plan.period_us)
    assert all(n == 122 for n in a[:press - 2]) and press - 2 < low < press + 30
    assert 122 in a[low:] and a.index(63) > low + a[low:].index(122)
    reads = [round((c - trace.observation.hosts[0].start) / b.plan.program.target.cycles(b.plan.period_us))
             for c, _, _ in trace.observation.hosts[0].frames]
    assert len(set(reads)) == len(reads) and max(reads) - min(reads) + 1 - len(reads) <= 1


HOST_PLAYS_AND_MEANWHILE = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
input go = P3.3
input stop = P3.2
servo s0 = P1.0
servo s1 = P1.1
pose mid { s0: 90deg, s1: 90deg }
pose low { s0: 60deg, s1: 60deg }
pose high { s0: 120deg, s1: 120deg }
home mid
sequence q0 {
  hold 200ms
  move mid
}
sequence q1 {
  send "b"
  select {
    on "x" {
      select {
        on press go {
          hold 50ms
          hold 200ms
        }
        on "x" {
          move mid
          hold 50ms
        }
      }
    }
    after 500ms { move mid }
    meanwhile {
      repeat 3 {
        hold 10ms
        hold 200ms
      }
      select {
        on press stop {
          move mid in 1000ms
          move mid in 100ms
        }
        on press go {
          move mid in 300ms
        }
        after 100ms { move mid }
      }
    }
  }
  host until release go
}
main {
  play q1
  select {
    on press go {
      host until release go
    }
    on press stop {
      move high
    }
    after 500ms { move mid }
  }
  hold 50ms
  send "a"
}
"""


def test_a_frame_call_wrapped_twice_fits_the_stack_it_counts():
    # `PL` can play `q0`, and a select has a meanwhile body: the program's frame call is frame_h
    # around frame_w, 2 bytes deeper than either alone (costs.WRAP_STACK: it once made the code
    # generator fail on its own stack bound); it builds and verifies a session that plays q0
    b, trace, report = session('0.1s "#0P1000S800#1P2000T300\\r"\n0.3s "Q\\r"\n0.4s "PL 0 SQ 0\\r"\n'
                               '0.9s "QP 0\\r"\n1.2s stop active\n', 300, HOST_PLAYS_AND_MEANWHILE)
    assert len(sent(trace)) == 2


def test_an_offset_line_read_while_a_sequence_plays_sets_its_offsets_and_the_reading_goes_on():
    # the wave plays for over a second; the offset line read meanwhile sets its offset in the
    # frame it is read, and the reading goes on: the Q after it is answered '+' while the wave
    # plays (a firmware that waited for the wave's end read it after, and answered '.'); the
    # offset counts in the group line after the wave
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.4s "#0PO-40\\r"\n0.45s "Q\\r"\n2.5s "#0P1500\\r"\n'
                               '3.0s "QP0\\r"\n', 650)
    # 1500 - 40 = 1460 us: N = (1460 - 500 + 4) // 8 = 120; QP0 answers (500 + 960) // 10 = 146
    assert sent(trace) == b"+" + bytes([146])


def test_limits_reverse_trim_and_clamps():
    # shoulder: limit 30..150 deg = N 41..203; P3000 clamps to 2500 (N 250), then to 203
    # elbow reversed: P600 is N 13 (12.5 rounded up), reversed 237
    # channel 99 and channel 5 have no servo: ignored; T70000 saturates at 65535 ms
    b, trace, report = session('0.2s "#1P3000#2P600#99P1500#5P900T10\\r"\n'
                               '1.5s "#1 P 1500 T 70000\\r"\n', 330)
    assert n_of(b, widths(b, trace, 1, 1)[255]) == 203
    assert n_of(b, widths(b, trace, 1, 2)[255]) == 237
    assert n_of(b, widths(b, trace, 1, 1)[-1]) > 190          # 65.5 s to N 125: barely on its way


def test_off_and_set_at_once_and_offsets():
    # P0 stops the base's pulses; the next P sets it at once; an offset of -40 us moves 1500 to 1460
    b, trace, report = session('0.2s "#0P0\\r"\n'
                               '0.5s "#0PO-40\\r"\n'
                               '0.7s "#0P1500\\r"\n'
                               '1.0s "QP0\\r"\n', 200)
    edges = trace.pin_edges(1, 0)
    assert sent(trace) == bytes([(500 + 8 * 120) // 10])     # (1460 - 500 + 4) >> 3 = 120
    gaps = [b2 - a for (a, _), (b2, _) in zip(edges, edges[1:])]
    assert max(gaps) > 0.3 * 11_059_200 / 12                  # no pulse for 0.3 s at least


def test_stop_and_escape_and_bad_lines():
    b, trace, report = session('0.2s "#0P2500T2000\\r"\n'
                               '0.5s "STOP 0\\r"\n'
                               '0.7s "#1P900T300 #2P\\x1b"\n'          # ESC drops it
                               '0.8s "#1P900 X\\r"\n'                   # a bad line
                               '0.9s "#2 P1200 T200\\r"\n'
                               '1.0s "STOP\\r"\n'
                               '1.3s "Q\\r"\n', 250)
    base = widths(b, trace, 1, 0)
    assert base[-1] == base[-30] and n_of(b, base[-1]) < 200        # stopped on its way to 250
    assert widths(b, trace, 1, 1)[-1] == widths(b, trace, 1, 1)[0]  # the shoulder never moved
    assert sent(trace) == b"."


def test_q_answers_plus_only_while_a_servo_is_on_its_way():
    # a move of the base alone: '+'; STOP 0 ends the base's part, the only servo on its way: '.'
    # although the move's 2 s have frames to come; a move of base and shoulder, the shoulder
    # stopped: the base still goes, '+'; a group whose servo is already there, and one that
    # switches the base off: no servo on its way, '.'
    b, trace, report = session('0.2s "#0P2500T2000\\r"\n0.3s "Q\\r"\n0.4s "STOP 0\\r"\n0.5s "Q\\r"\n'
                               '0.7s "#0P900#1P900T1500\\r"\n0.8s "STOP 1\\r"\n0.9s "Q\\r"\n'
                               '2.5s "#0P900T1000\\r"\n2.6s "Q\\r"\n2.8s "#0P0T1000\\r"\n2.9s "Q\\r"\n', 580)
    assert sent(trace) == b"+.+.."


def test_a_sequence_plays_and_an_input_ends_host():
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n'
                               '2s stop active\n', 500)
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    assert 54 in shoulder           # tuck: 40deg = N 54, then back to rest and, after the stop, tuck again
    assert shoulder[-1] == 54 and shoulder.count(122) > 10


def test_back_to_back_commands_lose_nothing():
    cmds = "".join(f"#0P{1000 + 40 * i}#1P{1900 - 30 * i}#2P{1200 + 20 * i}#7P{1500 + 10 * i}T50\\r" for i in range(12))
    b, trace, report = session(f'0.2s "{cmds}Q\\r"\n', 400)
    assert sent(trace) in (b"+", b".")
    obs = trace.observation
    assert sum(len(got) for h in obs.hosts for _, _, got in h.frames) == len(bytes(cmds, "ascii").decode(
        "unicode_escape")) + 2


def test_a_firmware_that_times_differently_fails_verify():
    b = built()
    asm = b.firmware.unit.text
    rt = ssc32.time_factor(b.plan.period_us)
    head, commit = asm.split("host_commit:")
    # RT's high byte one more: RT + 256, so T900 takes 900 x 256 / 65536 = 3.5 frames more
    wrong = commit.replace(f"MOV     B, #0x{rt >> 8:02X}", f"MOV     B, #0x{(rt >> 8) + 1:02X}")
    assert wrong.count(f"#0x{(rt >> 8) + 1:02X}") >= 2
    trace, report = watch(b, '0.2s "#0P1000T900\\r"\n', 200, rebuilt(b, head + "host_commit:" + wrong))
    assert not report.ok and "width off" in problems(report)


# ---------------------------------------------------------------- any session

def _line(draw) -> bytes:
    st_ = __import__("hypothesis").strategies
    kind = draw(st_.sampled_from(["group", "group", "group", "q", "qp", "ver", "stop", "pl", "po", "junk"]))
    if kind == "group":
        out = b""
        for _ in range(draw(st_.integers(1, 4))):
            ch = draw(st_.sampled_from([0, 1, 2, 3, 7, 9, 40]))
            out += b"#%d P%d" % (ch, draw(st_.sampled_from([0, 400, 500, 999, 1500, 2000, 2500, 3100, 65535])))
            if draw(st_.booleans()):
                out += b" S%d" % draw(st_.sampled_from([0, 5, 16, 100, 700, 2047, 2048, 4000, 70000]))
        if draw(st_.booleans()):
            out += b" T%d" % draw(st_.sampled_from([0, 1, 50, 300, 1000, 70000]))
    elif kind == "q":
        out = b"Q"
    elif kind == "qp":
        out = b"QP %d" % draw(st_.sampled_from([0, 2, 7, 8, 31, 300]))
    elif kind == "ver":
        out = b"ver"
    elif kind == "stop":
        out = draw(st_.sampled_from([b"STOP", b"STOP 0", b"stop 7", b"STOP 99"]))
    elif kind == "pl":
        out = b"PL 0 SQ %d" % draw(st_.sampled_from([0, 1]))
    elif kind == "po":
        out = b"#%d PO %+d" % (draw(st_.sampled_from([0, 7, 2])), draw(st_.sampled_from([-150, -40, 0, 25, 100])))
    else:
        out = draw(st_.sampled_from([b"#0P15X00", b"#1P1200\x1b#1P900", b"PP", b"\xff\x00", b"T500", b"#0P1500 T", b"Q5"]))
    return out + draw(st_.sampled_from([b"\r", b"\n", b"\r\n"]))


def _scenario(draw) -> tuple[str, float]:
    st_ = __import__("hypothesis").strategies
    t = 0.2
    text = ""
    for _ in range(draw(st_.integers(1, 6))):
        line = _line(draw)
        if line.upper().startswith(b"PL"):
            line = b"PL 0 SQ 1\r"      # no sequence 1: while a sequence plays the firmware reads
                                       # nothing (docs/host-protocol.md), and the bytes would pile up
        text += f'{t:.6f}s "' + "".join(chr(b) if 32 <= b < 127 and b not in (34, 92) else f"\\x{b:02x}"
                                        for b in line) + '"\n'
        t += len(line) * 0.0011 + draw(st_.sampled_from([0.0, 0.002, 0.03, 0.2, 0.6]))
    return text, t


def _ucsim_examples(count: int):
    """A hypothesis test of `count` examples drawn with `data` (derandomized, no shrinking: each
    example runs ucsim)."""
    from hypothesis import HealthCheck, Phase, given, settings, strategies as st_
    return lambda check: settings(max_examples=count, deadline=None, derandomize=True,
                                  phases=[Phase.explicit, Phase.generate],
                                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])(
        given(st_.data())(check))


def test_any_session_verifies():
    @_ucsim_examples(12)
    def check(data):
        scenario, end = _scenario(data.draw)
        b = built()
        frames = int((end + 2.5) * 1e6 / b.plan.period_us)
        trace, report = watch(b, scenario, frames)
        assert report.ok, scenario + "\n" + problems(report)
        dropped = [r for r in trace.observation.received if not r.queued]
        assert not dropped, scenario
    check()


@pytest.mark.parametrize("head, baud", [("target at89c52 clock 12MHz", 4800),
                                        ("target stc89c52rc clock 11.0592MHz mode 6T", 9600),
                                        ("target stc89c52rc clock 22.1184MHz", 9600)])
def test_sessions_hold_at_other_clocks_and_in_6t_mode(head, baud):
    text = (f"{head}\nserial {baud}\nhost ssc32\nservo pan = P1.0\nservo tilt = P2.5 channel 3\n"
            "pose mid { pan: 122, tilt: 122 }\nhome mid\nmain {\n  host\n}\n")
    b, trace, report = session('0.1s "VER\\r"\n'
                               '0.2s "#0P1000S500#3P2000S300T400\\r"\n'
                               '0.3s "Q\\r"\n'
                               '5.5s "Q\\rQP0\\rQP3\\r"\n', int(6.0e6 / 5300), text)
    # mid is N 122 (1476 us); 1000 us is N 63, 2000 us N 188: QP 100 and 200
    assert sent(trace) == b"SSC32-servoc-0.1\r+.d\xc8"
    # S300: tilt's 66 N (528 us) take 1.76 s, longer than T400 and than pan's 59 N (472 us) at
    # S500, 0.944 s: the move lasts F = ceil(1,760,000 us / P) frames
    p = b.plan.period_us
    f = -(-66 * 8_000_000 // (300 * p))
    tilt = widths(b, trace, 2, 5)
    first = next(i for i, w in enumerate(tilt) if w != tilt[0])
    last = next(i for i, w in enumerate(tilt) if w == tilt[-1])
    step = [(2 * 66 * k + f) // (2 * f) for k in range(f + 1)]      # frame k moves floor(66 k / F + 1/2) N
    assert n_of(b, tilt[-1]) == 188 and last - first == step.index(66) - step.index(1)


def test_a_firmware_that_reads_late_fails_verify():
    b = built()
    asm = b.firmware.unit.text
    head, loop = asm.split("hr_frame:")
    passes = int(loop.split("MOV     R7, #", 1)[1].split()[0])
    slow = loop.replace(f"MOV     R7, #{passes}", "MOV     R7, #1", 1)      # one byte a frame
    trace, report = watch(b, '0.2s "#0P1000T300\\r"\n', 150, rebuilt(b, head + "hr_frame:" + slow))
    assert not report.ok and "left" in problems(report) and "unread" in problems(report)


def test_q_is_answered_while_a_sequence_plays_and_an_offset_line_counts_after_it():
    # the wave (tuck, then rest): Q at 0.25 s answers '+', and so does QP (the shoulder on its way
    # down from 90deg); STOP 1 holds the shoulder for the rest of the wave; an offset line sent
    # meanwhile sets its offset: the group after the wave moves the base by 2000 - 40 us
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n'
                               '0.25s "Q\\r"\n'
                               '0.3s "QP 1\\r"\n'
                               '0.35s "STOP 1\\r"\n'
                               '0.45s "#0PO-40\\r"\n'
                               '1.5s "#0P2000\\r"\n'
                               '4.0s "Q\\r"\n', 800)
    out = sent(trace)
    assert out[0:1] == b"+" and 54 * 8 + 500 < 10 * out[1] < 1476 and out[2:] == b"."
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    assert base[-1] == 183                                   # (1960 - 500 + 4) >> 3


def test_answers_waiting_go_on_in_the_frame_before_a_sequence_pl_starts():
    """Two `VER` lines while a sequence `PL` started plays (the second's answer waits), then two `PL`
    lines, each read in a frame of the sequence, each starting it again: the frame before the
    sequence's first frame reads nothing, and it used to send nothing either, so the second
    answer came more than 2 P after the first (verify: "more than 2 P"). In 6T mode at 19200
    baud, where a frame brings 5 bytes."""
    text = ARM.replace("clock 11.0592MHz", "clock 11.0592MHz mode 6T").replace("serial 9600", "serial 19200")
    _, trace, _ = session('0.2s "PL 0 SQ 0\\r"\n0.3s "VER\\nVER\\r"\n0.312s "PL 0 SQ 0\\nPL 0 SQ 0\\r"\n', 120, text)
    assert sent(trace) == 2 * ssc32.VERSION_REPLY


@pytest.mark.parametrize("clock", ["11.0592MHz", "11.0592MHz mode 6T", "22.1184MHz"])
def test_a_group_or_pl_line_read_while_a_sequence_plays_replaces_it(clock):
    # the wave (tuck, then rest: the shoulder 90deg -> 40deg -> 90deg) from 0.2 s; a group for the
    # base at 0.42 s, while the shoulder is on its way back up: the wave ends where the shoulder is
    # as the line's end is read (the bytes are read as they come while a sequence plays too), and
    # the base's move starts in the next frame, at most 2 P after the CR; later `PL` twice: the
    # second replaces the first, which plays again from where the servos are and ends at rest
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}")
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.42s "#0P2000\\r"\n1.5s "Q\\r"\n'
                               '2.0s "PL 0 SQ 0\\r"\n2.15s "PL 0 SQ 0\\r"\n', round(3e6 / built(text).plan.period_us), text)
    assert sent(trace) == b"."
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    assert min(shoulder[frame(0.2):frame(0.42)]) == 54      # the wave's tuck was reached
    cr = 0.42 + len("#0P2000\r") * 10 / 9600             # the CR's stop bit
    moved = next(i for i in range(frame(0.3), len(base)) if base[i] != 122)
    assert frame(0.42) < moved <= frame(cr) + 2, (moved, frame(cr))     # 2 P at the most after the CR
    cut = moved + 1
    still = shoulder[cut:frame(1.9)]
    assert len(set(still)) == 1 and 54 < still[0] < 122, sorted(set(still))   # never back to rest
    assert base[frame(1.9)] == 188 and shoulder[-1] == 122 and base[-1] == 122


def test_stop_ends_a_sequence_pl_started_where_the_servos_are():
    # STOP at 0.45 s, in the wave's first move (the shoulder on its way from 90deg to 40deg): the
    # wave ends there, the shoulder stays where that frame had it, Q answers '.', and the group
    # after it moves the base at once (it waits for no sequence)
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.45s "STOP\\r"\n0.5s "Q\\r"\n'
                               '0.7s "#0P2000\\r"\n1.5s "Q\\r"\n', 330)
    assert sent(trace) == b".."
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    assert shoulder[frame(0.2)] == 122 and shoulder[frame(0.4)] < 122
    still = shoulder[frame(0.5):]
    assert len(set(still)) == 1 and still[0] > 55              # stopped half-way (40deg is N 55)
    assert base[frame(0.7) + 3] != 122 and base[-1] == 188


def test_stop_ends_a_sequence_pl_started_while_its_select_waits():
    # `dip` plays and waits in its select; STOP ends it there: the press of go after it finds no
    # select waiting (`a` stays at mid), and the group after it moves `a`
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.4s "STOP\\r"\n0.5s "Q\\r"\n0.7s go active\n'
                               '0.8s go inactive\n1.0s "#0P1000\\r"\n1.6s stop active\n', 400, HOST_AND_A_SELECT)
    assert sent(trace) == b"."
    a = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    assert all(n == 122 for n in a[:frame(1.0)]) and a[frame(1.5)] == 63 and a[-1] == 81   # `move low` after `host`


def test_a_sequence_ended_while_its_select_waits_can_play_again():
    # `dip` waits in its select (its meanwhile body moving `a`); STOP ends it, PL plays it again,
    # a PL line replaces it while its select waits, and a group line replaces that one: verify
    # follows each select the host ended (it once took a select reached again for one still
    # waiting); the press of go at the end finds no select waiting, and `a` goes where the group
    # sends it
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.4s "STOP\\r"\n0.6s "PL 0 SQ 0\\r"\n'
                               '0.9s "PL 0 SQ 0\\r"\n1.2s "#0P1000\\r"\n1.8s go active\n1.9s go inactive\n',
                               400, HOST_AND_A_SELECT)
    a = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    assert set(a[:frame(1.2)]) == {122}                       # the meanwhile body's first move: to mid
    assert a[frame(1.7)] == 63 and a[-1] == 63


def test_a_line_of_any_length_is_read_byte_by_byte():
    # 40 entries (the 4 channels named ten times each: the last entry of each wins), 400 bytes
    entries = "".join(f"#{ch} P{1000 + 10 * k + 100 * i} " for k in range(10) for i, ch in enumerate((0, 1, 2, 7)))
    b, trace, report = session(f'0.2s "{entries}T200\\r"\n'
                               '1.0s "QP0\\rQP1\\rQP2\\rQP7\\r"\n', 250)
    # the last entries: #0 P1090, #1 P1190, #2 P1290, #7 P1390 -> N 74, 86, 99, 111 (rounded half up)
    # elbow is reversed: N 151 is its output; grip's trim is 3: N 114
    assert sent(trace) == bytes((500 + 8 * n) // 10 for n in (74, 86, 151, 114))


HOST_IN_LOOP = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
input mode = P3.2
servo a = P1.0
servo b = P1.1
pose rest { a: 90deg, b: 90deg }
home rest
sequence obey {
  host until release mode
}
main {
  loop {
    select {
      on mode { play obey }
      after 200ms { move rest }
    }
  }
}
"""


def test_host_in_a_sequence_inside_a_loop_runs_and_ends_again_and_again():
    b, trace, report = session('0.3s mode active\n'
                               '0.5s "#0P900T100\\r"\n'
                               '0.8s mode inactive\n'
                               '1.4s mode active\n'
                               '1.6s "#1P2100\\r"\n'
                               '1.9s mode inactive\n', 450, HOST_IN_LOOP)
    a = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    bb = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    assert 50 in a and 200 in bb                 # each run of `host` moved its servo
    assert a[-1] == 122 and bb[-1] == 122        # and `after` moved them back to rest


@pytest.mark.parametrize("head, baud, count", [("target at89c52 clock 12MHz", 4800, 8),
                                               ("target stc89c52rc clock 11.0592MHz", 9600, 8),
                                               ("target stc89c52rc clock 22.1184MHz", 9600, 8),
                                               ("target stc89c52rc clock 11.0592MHz mode 6T", 9600, 8)])
def test_the_shortest_period_holds_under_the_heaviest_lines_and_a_microsecond_less_is_refused(head, baud, count):
    servos = "".join(f"servo s{i} = P1.{i} limit 10deg..170deg{' reverse' if i % 2 else ''} trim {i - 2}\n"
                     for i in range(count))
    text = (f"{head}\nserial {baud}\nhost ssc32\n{servos}pose p {{ "
            + ", ".join(f"s{i}: {40 + 20 * i}" for i in range(count)) + " }\nhome p\nmain {\n  host\n}\n")
    b = built(text)
    reported = b.plan.min_period_us     # below the 5.3 ms default floor, from the code built for 5.3 ms:
    if reported < b.plan.period_us:     # the least P whose own code holds it (api._least_period)
        text = re.sub(r"host ssc32\n", f"host ssc32\nframe {reported}us\n", text)
        b = built(text)
    assert b.plan.period_us == b.plan.min_period_us == reported      # it runs at the shortest reported
    # every servo named with S in every line (the commit's longest path), lines back to back, with Q
    # and QP between them, and PO lines that stop the reading
    body = ""
    for k in range(12):
        body += "".join(f"#{i}P{600 + (k * 370 + i * 190) % 1900}S{300 + 97 * k + i}" for i in range(count))
        body += f"T30\\rQ\\rQP{k % count}\\r" + (f"#{k % count}PO{k - 8}\\r" if k % 5 == 0 else "")
    b, trace, report = session(f'0.2s "{body}"\n', int(3.5e6 / b.plan.period_us), text)
    assert len(sent(trace)) == 24                                       # every Q and QP answered
    shorter = re.sub(r"host ssc32\n(frame \d+us\n)?", f"host ssc32\nframe {b.plan.min_period_us - 1}us\n", text)
    _, diags = front_end_text(shorter)
    assert any(d.code == "period-too-short" for d in diags), [d.code for d in diags]


HOST_BOARDS = (("target at89c52 clock 12MHz", 4800), ("target stc89c52rc clock 11.0592MHz", 9600),
               ("target stc89c52rc clock 11.0592MHz mode 6T", 9600), ("target stc89c52rc clock 22.1184MHz", 9600))
REFUSALS = {"host-ram", "serial-too-fast", "period-too-short", "too-deep", "program-too-big", "rom-overflow"}


def _host_program(draw) -> tuple[str, list[int]]:
    """A host program on a board of HOST_BOARDS: one or two ports of servos with random options
    (limits, reverse, trim, channel, speed), a sequence `PL` can play, `host until` an input.
    Returns its text and the channels of its servos."""
    st_ = __import__("hypothesis").strategies
    head, baud = draw(st_.sampled_from(HOST_BOARDS))
    ports = draw(st_.sampled_from([(1,), (1,), (2,), (1, 2), (0, 1)]))
    servos, channels, free = [], [], list(range(24, 32))
    for port in ports:
        for bit in sorted(draw(st_.sets(st_.integers(0, 7), min_size=1, max_size=8))):
            opts = ""
            if draw(st_.booleans()):
                opts += f" limit {draw(st_.integers(10, 55))}deg..{draw(st_.integers(95, 170))}deg"
            opts += " reverse" if draw(st_.booleans()) else ""
            opts += f" trim {draw(st_.integers(-5, 5))}" if draw(st_.booleans()) else ""
            opts += " speed 0.3s/60deg" if draw(st_.booleans()) else ""
            channel = {1: bit, 2: 8 + bit, 0: 16 + bit}[port]
            if draw(st_.booleans()) and free:
                channel = free.pop(0)
                opts += f" channel {channel}"
            servos.append(f"servo s{port}{bit} = P{port}.{bit}{opts}\n")
            channels.append(channel)
    names = [line.split()[1] for line in servos]
    text = (f"{head}\nserial {baud}\nhost ssc32\ninput stop = P3.2\n" + "".join(servos)
            + "pose mid { " + ", ".join(f"{n}: 90deg" for n in names) + " }\n"
            + "pose low { " + ", ".join(f"{n}: 60deg" for n in names) + " }\nhome mid\n"
            + "sequence dip {\n  move low\n  move mid\n}\nmain {\n  host until press stop\n  move low\n}\n")
    return text, channels


def test_any_host_program_lint_accepts_compiles_and_verifies_under_heavy_lines():
    # every program lint accepts compiles, and verifies in ucsim at its own period under group lines
    # that name every servo with S (the commit's longest path), back to back, with Q, QP and PL
    @_ucsim_examples(10)
    def check(data):
        text, channels = _host_program(data.draw)
        _, diags = front_end_text(text)
        errors = {d.code for d in diags if d.is_error}
        assert errors <= REFUSALS, (errors, text)
        if errors:
            return
        b = built(text)
        body = ""
        for k in range(4):
            body += "".join(f"#{c}P{600 + (k * 370 + i * 190) % 1900}S{150 + 211 * k + 7 * i}"
                            for i, c in enumerate(channels))
            body += f"T{40 * k}\\rQ\\rQP{channels[k % len(channels)]}\\r"
        body += "PL 0 SQ 0\\r"
        frames = int(3.0e6 / b.plan.period_us)
        trace, report = watch(b, f'0.2s "{body}"\n', frames)
        assert report.ok, problems(report) + "\n" + text
        assert len(sent(trace)) == 8, text                  # every Q and QP answered
    check()


def _statement(r, depth: int, seqs: list[str]) -> list[str]:
    """A random statement of a host program (the lines of its text): moves, holds, repeats, selects
    on inputs, bytes and time with meanwhile bodies, plays, sends and `host until`."""
    kinds = ["move", "move", "hold", "repeat", "select", "play", "host", "send"] if depth < 3 else ["move", "hold"]
    k = r.choice(kinds)
    if k == "move":
        return [f"move {r.choice(['mid', 'low', 'high'])}" + (f" in {r.choice([100, 300, 1000])}ms" if r.random() < .5 else "")]
    if k == "hold":
        return [f"hold {r.choice([10, 50, 200])}ms"]
    if k == "send":
        return [f'send "{r.choice("abc")}"']
    if k == "play" and seqs:
        return [f"play {r.choice(seqs)}"]
    if k == "host":
        return [r.choice(["host until press stop", "host until release go"])]
    if k == "repeat":
        body = [line for _ in range(r.randint(1, 2)) for line in _statement(r, depth + 1, seqs)]
        return [f"repeat {r.randint(1, 3)} {{"] + ["  " + line for line in body] + ["}"]
    if k == "select":
        out = ["select {"]
        for event in r.sample(["press go", "release go", '"x"', "press stop"], r.randint(1, 2)):
            body = [line for _ in range(r.randint(0, 2)) for line in _statement(r, depth + 1, seqs)]
            out += [f"  on {event} {{"] + ["    " + line for line in body] + ["  }"]
        if r.random() < .4:
            out += [f"  after {r.choice([100, 500])}ms {{ move mid }}"]
        if r.random() < .5:
            body = [line for _ in range(r.randint(1, 2)) for line in _statement(r, depth + 1, seqs)]
            out += ["  meanwhile {"] + ["    " + line for line in body] + ["  }"]
        return out + ["}"]
    return ["move mid"]


def _structured_host_program(seed: int) -> str:
    """A host program with sequences and selects around and inside `host`, on one of four boards."""
    import random
    r = random.Random(seed)
    head = r.choice(["target at89c52 clock 12MHz\nserial 4800", "target stc89c52rc clock 11.0592MHz\nserial 9600",
                     "target stc89c52rc clock 22.1184MHz\nserial 9600",
                     "target stc89c52rc clock 11.0592MHz mode 6T\nserial 9600"])
    names = [f"s{i}" for i in range(r.randint(1, 5))]
    text = f"{head}\nhost ssc32\ninput go = P3.3\ninput stop = P3.2\n" + "".join(f"servo {n} = P1.{n[1:]}\n" for n in names)
    text += "".join(f"pose {p} {{ " + ", ".join(f"{n}: {v}deg" for n in names) + " }\n"
                    for p, v in (("mid", 90), ("low", 60), ("high", 120))) + "home mid\n"
    seqs: list[str] = []
    for q in range(r.randint(0, 3)):
        body = [line for _ in range(r.randint(1, 3)) for line in _statement(r, 1, seqs)]
        text += f"sequence q{q} {{\n" + "".join(f"  {line}\n" for line in body) + "}\n"
        seqs.append(f"q{q}")
    body = [line for _ in range(r.randint(1, 4)) for line in _statement(r, 0, seqs)]
    if not any("host" in line for line in body):
        body.insert(0, "host until press stop")
    return text + "main {\n" + "".join(f"  {line}\n" for line in body) + "}\n"


def test_any_structured_host_program_lint_accepts_builds_and_verifies():
    # selects, meanwhile bodies, sequences and sends around and inside `host`, 16 programs: the
    # front end never fails (a program error is a diagnostic); every program lint accepts builds,
    # and a session of group lines, Q, QP, PL, STOP and STOP c while a sequence may play, bytes and input
    # edges verifies (seed 33 once stopped the code generator on its own stack bound)
    scenario = ('0.1s "#0P1000S800#1P2000T300\\r"\n0.3s "Q\\r"\n0.4s "PL 0 SQ 0\\r"\n0.45s "STOP 0\\r"\n'
                '0.6s go active\n0.7s "x"\n'
                '0.9s go inactive\n1.1s "PL 0 SQ 1\\r"\n1.2s "STOP\\r"\n1.3s "QP 0\\r"\n1.6s stop active\n'
                '1.9s stop inactive\n'
                '2.2s go active\n')
    verified = 0
    for seed in range(33, 49):
        text = _structured_host_program(seed)
        _, diags = front_end_text(text)
        if any(d.is_error for d in diags):
            continue
        b = built(text)
        trace, report = watch(b, scenario, int(2.8e6 / b.plan.period_us))
        assert report.ok, problems(report) + "\n" + text
        verified += 1
    assert verified >= 8, verified


def test_the_receive_queue_holds_exactly_two_frames_of_bytes_and_two():
    """The receive queue is a ring of its size and one slot, of any size: at 9600 baud and 11.0592
    MHz (a byte every 934 cycles from a host 2 % fast) one port of 8 servos with `host` runs at
    its shortest period, some 8.5 ms: two frames bring 17 or 18 bytes at most, and the queue holds
    two more (not the 32 of a power of two) in a slot more of RAM."""
    from servoc import costs
    from servoc.flow import HOST_VARS, host_queue, host_ram
    text = ("target stc89c52rc clock 11.0592MHz\nserial 9600\nhost ssc32\n"
            + "".join(f"servo s{i} = P1.{i}\n" for i in range(8))
            + "pose p { " + ", ".join(f"s{i}: 122" for i in range(8)) + " }\nhome p\nmain { host }\n")
    b = built(text)
    cycles = b.plan.program.target.cycles(b.plan.period_us)
    assert b.plan.period_us == b.plan.min_period_us and 8000 < b.plan.period_us < 9000
    queue = host_queue(b.plan)
    assert queue == -(-2 * cycles // costs.rx_gap(960)) + 2 and 16 < queue < 32
    assert host_ram(b.plan) == HOST_VARS + 5 * 8 + queue - costs.QUEUE
    equ = {m[1]: m[2] for m in re.finditer(r"^(\w+)\s+=\s+0x([0-9A-F]+)\s+;(.*)$", b.firmware.unit.text, re.M)}
    assert "RXQ" in equ and f"The receive ring: {queue + 1} slots at RXQ" in b.firmware.unit.text


def test_a_host_until_whose_select_does_not_fit_names_the_select():
    """With two ports of 4 servos at 4800 baud, the RAM the firmware allocates leaves the stack room
    for a plain `host` but not for the counters `host until` keeps while it runs: too-deep points at
    that select, not at a repeat the program does not have."""
    from servoc.source import SourceFile
    pins = [(p, b) for b in range(4) for p in (1, 2)]
    head = ("target at89c52 clock 11.0592MHz\nserial 4800\nhost ssc32\ninput stop = P3.2\n"
            + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p, b in pins)
            + "pose p { " + ", ".join(f"s{p}{b}: 122" for p, b in pins) + " }\nhome p\n")
    _, diags = front_end_text(head + "main {\n  host\n}\n")
    assert not [d for d in diags if d.is_error], [d.message for d in diags if d.is_error]
    text = head + "main {\n  host until press stop\n}\n"
    _, diags = front_end_text(text)
    (d,) = [d for d in diags if d.is_error]
    assert d.code == "too-deep" and "this `select`'s counters" in d.message and "repeat" not in d.message.split(";")[1]
    assert SourceFile("x", text).snippet(d.span).startswith("host until press stop")


def test_stop_c_while_a_sequence_plays_holds_that_servo_until_the_sequence_ends():
    # STOP 1 at 0.28 s, in the wave's first move (the shoulder on its way from 90deg to 40deg): the
    # shoulder stops where that frame has it and stays there for the rest of the wave (its `move
    # rest` leaves it: a compiled move can then never be too fast for it), while the base goes on
    # to 60deg and back; Q answers '+' while the wave plays; after it the shoulder goes on with the
    # host from where it is held
    text = ARM.replace("pose tuck { base: 90deg, shoulder: 40deg }", "pose tuck { base: 60deg, shoulder: 40deg }")
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.28s "STOP 1\\r"\n0.33s "Q\\r"\n'
                               '1.5s "Q\\r"\n1.7s "#1P2000\\r"\n', 500, text)
    assert sent(trace) == b"+."
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    assert shoulder[frame(0.25)] < 122
    still = shoulder[frame(0.33):frame(1.7)]
    assert len(set(still)) == 1 and 59 < still[0] < 122, sorted(set(still))   # held on its way down
    assert min(base[frame(0.2):frame(1.5)]) == 81 and base[frame(1.5)] == 122  # the base did the wave
    assert shoulder[-1] == 188                                                # then the host's line


def test_a_servo_stop_c_held_is_let_go_when_an_event_cuts_the_sequence():
    # STOP 1 holds the shoulder in the wave; the stop button then cuts `host` (and the wave in it):
    # the program's `move tuck` moves the shoulder again, from where it was held, to 40deg (N 54)
    text = ARM.replace("pose tuck { base: 90deg, shoulder: 40deg }", "pose tuck { base: 60deg, shoulder: 40deg }")
    b, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.28s "STOP 1\\r"\n0.45s stop active\n', 300, text)
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    held = shoulder[frame(0.33)]
    assert 59 < held < 122 and shoulder[frame(0.43)] == held
    assert shoulder[-1] == 54


def test_what_host_carries_on_one_two_and_three_ports_is_what_the_docs_say():
    # docs/host-protocol.md at 9600 baud and 11.0592 MHz: without XRAM one port carries all 8
    # servos, two ports 7 with `main { host }` (6 with `host until`, whose select keeps its
    # counters), three none; an STC89 keeps the host's per-servo state in XRAM: two ports 16
    def errors(pins, main="main { host }", chip="at89c52"):
        text = (f"target {chip} clock 11.0592MHz\nserial 9600\nhost ssc32\ninput stop = P3.2\n"
                + "".join(f"servo s{p}{b} = P{p}.{b}\n" for p, b in pins)
                + "pose p { " + ", ".join(f"s{p}{b}: 122" for p, b in pins) + " }\nhome p\n" + main + "\n")
        _, diags = front_end_text(text)
        return [d.code for d in diags if d.is_error]
    two = [(1 + i % 2, i // 2) for i in range(16)]
    assert errors([(1, b) for b in range(8)]) == []
    assert errors(two[:7]) == [] and errors(two[:8]) == ["host-ram"]
    assert errors(two[:6], "main { host until press stop }") == []
    assert errors(two[:7], "main { host until press stop }") == ["host-ram"]
    assert errors([(1, 0), (2, 0), (0, 0)]) == ["host-ram"]
    assert errors(two, "main { host until press stop }", "stc89c52rc") == []
    assert errors(two + [(0, 0)], chip="stc89c58rd") == []

def test_pl_reaches_any_of_many_sequences():
    # 40 sequences `PL` can play: the dispatch grows with them past a short jump's reach (it used
    # to end in an assembler error at 13); the last one plays from the host
    seqs = "".join(f"sequence seq{k} {{\n  move q in {700 + 10 * k}ms\n  move p in 700ms\n}}\n" for k in range(40))
    text = ("target stc89c52rc clock 11.0592MHz\nserial 9600\nhost ssc32\nservo a = P1.0\n"
            "pose p { a: 100 }\npose q { a: 130 }\nhome p\n" + seqs + "main { host }\n")
    b, trace, report = session('0.1s "PL 0 SQ 39\\rQ\\r"\n', int(2.2e6 / built(text).plan.period_us), text)
    assert sent(trace) == b"+"                       # the sequence plays
    w = [n_of(b, c) for c in widths(b, trace, 1, 0)]
    assert max(w) == 130 and w[-1] == 100            # to q and back


def test_too_deep_through_a_sequence_pl_plays_names_the_statement_past_the_limit():
    # two ports of an AT89C52 (an eased move too): the stack has room for 2 levels; `host until press stop` keeps its
    # edge's sample (a level), `PL` plays `w` (a level), and w's select keeps its `after` counter
    # while it waits: that select is level 3, and too-deep names it (not `main`)
    text = ("target at89c52 clock 11.0592MHz\nserial 9600\nhost ssc32\ninput stop = P3.2\n"
            + "".join(f"servo s{i} = P{1 + i % 2}.{i // 2}\n" for i in range(5))
            + "pose a { " + ", ".join(f"s{i}: {60 + 20 * i}" for i in range(5)) + " }\n"
            + "pose c { " + ", ".join(f"s{i}: {200 - 25 * i}" for i in range(5)) + " }\nhome a\n"
            + "sequence w {\n  move c\n  select {\n    on stop { move a }\n    after 300ms { move a in 600ms ease in-out }\n"
            + "  }\n}\nsequence two {\n  move a\n  hold 100ms\n}\nmain {\n  host until press stop\n  move a\n}\n")
    fe, diags = front_end_text(text)
    deep = [d for d in diags if d.code == "too-deep"]
    assert len(deep) == 1 and "this `select`'s counters, kept while it waits, reach level 3" in deep[0].message
    assert "(`host`'s `PL` plays `w` on the way)" in deep[0].message
    assert text[deep[0].span.start:].startswith("select {")


def test_no_path_between_two_frames_reads_the_host_twice():
    # a frame inside a sequence `PL` started reads the host's bytes (frame_h); the analysis must not
    # join that reading to `host`'s own one (host_read) or to main's code: PLAYH and the barred
    # returns leave the longest work between frames below the two readings together
    from servoc import wcet
    b = built()
    text = b.firmware.unit.text
    code = wcet.Code(text)
    twice = code.longest("host_read", set()) + code.longest("play_read", set()) + code.longest("host_step", set())
    assert b.firmware.unit.budget.work < twice
    # without the facts the analysis finds such a path: a sequence's reading, then host's and its step
    blind = wcet.Code(text, "FLAGS", frozenset())
    assert blind.between_frames()[0] > twice


def test_the_barred_returns_keep_a_sequence_reading_out_of_main():
    # `q0` can be played by `PL` and by main; with PLAYH alone, a reading in q0's frames could run on
    # into main's selects and moves (q1's looks) before a frame: the fact that no RET goes back into
    # main or an unplayable sequence while PLAYH is set keeps the bound below that
    from servoc import codegen, layout, wcet
    b = built(HOST_PLAYS_AND_MEANWHILE)
    text = b.firmware.unit.text
    flags = frozenset(f.name for f in layout.RECORD_FLAGS if f.in_record)
    barred = codegen._pl_barred(b.plan, [{"label": codegen._seq_label(b.plan, q.name), "name": q.name}
                                         for q in b.plan.program.sequences])
    assert barred is not None and ("main", barred[1][0][1]) == barred[1][0]
    with_fact = wcet.Code(text, "FLAGS", flags, frozenset({"PLAYH"}), barred).between_frames()[0]
    without = wcet.Code(text, "FLAGS", flags, frozenset({"PLAYH"})).between_frames()[0]
    assert with_fact == b.firmware.unit.budget.work < without


@pytest.mark.parametrize("clock", ["11.0592MHz", "11.0592MHz mode 6T"])
def test_q_lines_back_to_back_through_a_whole_sequence_keep_every_frame_exact(clock):
    # at the arm's shortest period: `PL 0 SQ 0`, then `Q` lines back to back at 9600 baud for longer
    # than the wave plays, so that every frame of the sequence, those that start its moves too,
    # reads as many bytes as a frame's reading reads; verify finds every pulse and the period exact,
    # every Q is answered, '+' while the wave plays and '.' after it
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}")
    # the shortest period, with `frame` at it (the reading's size follows P: lint's shortest for the
    # program at one P can be shorter than that P; go down to where it is P itself)
    plain, shortest = text, built(text).plan.min_period_us
    for _ in range(4):
        text = plain.replace("host ssc32\n", f"host ssc32\nframe {shortest / 1000}ms\n")
        b = built(text)
        if b.plan.min_period_us == shortest:
            break
        shortest = b.plan.min_period_us
    assert b.plan.period_us == shortest == b.plan.min_period_us
    _, diags = front_end_text(plain.replace("host ssc32\n", f"host ssc32\nframe {(shortest - 1) / 1000}ms\n"))
    assert "period-too-short" in {d.code for d in diags}          # 1 us less is refused
    count = 300                                     # 300 x 2 bytes: 0.625 s at 9600 baud
    _, trace, report = session('0.2s "PL 0 SQ 0\\r"\n0.22s "' + "Q\\r" * count + '"\n',
                               round(1.2e6 / b.plan.period_us), text)
    out = sent(trace)
    assert len(out) == count and out[0:1] == b"+" and out[-1:] == b"."
    assert out == b"+" * out.count(b"+") + b"." * out.count(b".")     # '+' until the wave ends, then '.'


@pytest.mark.parametrize("clock, baud", [("11.0592MHz", 9600), ("11.0592MHz mode 6T", 19200)])
def test_a_byte_lost_to_a_full_queue_spoils_its_line_so_no_line_is_read_with_bytes_missing(clock, baud):
    """Group lines of two entries (9 bytes), each followed by a `T` line (bad), back to back at
    `frame 12ms`, where a frame brings 11.5 bytes at 9600 baud (23 at 19200 baud in 6T mode,
    where the host's state is in XRAM): after a group line the reading stops before the end of
    the `T` line (a T alone, no line that joins), so a
    frame reads one group line, and the receive queue fills: bytes are lost. The serial handler makes the newest byte queued 0xFF when one is lost, so
    every line the parser reads whole (without 0xFF) is a line the host sent: none is spliced
    from two (each line's channels and widths go together, so `#0P1#1P` and `4` and CR would be no
    line sent). verify passes the run."""
    text = (ARM.replace("clock 11.0592MHz", f"clock {clock}").replace("serial 9600", f"serial {baud}")
            .replace("\nhost ssc32\n", "\nhost ssc32\nframe 12ms\n", 1))
    assert "frame 12ms" in text
    lines = ["#0P1#1P2\r", "T\r", "#2P3#7P4\r", "T\r"] * 60
    scenario = "0.3s " + " ".join('"' + ln.replace("\r", "\\r") + '"' for ln in lines) + "\n"
    b, trace, report = session(scenario, round(1.6e6 / built(text).plan.period_us), text)
    read = b"".join(bytes(got) for h in trace.observation.hosts for _, _, got in h.frames)
    assert 0xFF in read                                   # bytes were lost
    whole = [ln for ln in read.replace(b"\n", b"\r").split(b"\r")[:-1] if 0xFF not in ln]
    assert whole and set(whole) <= {ln.rstrip("\r").encode() for ln in lines}, whole
    assert sum(1 for w in report.warnings if "was lost" in w and "dropped as a bad line" in w) >= 1


TWO = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
servo s0 = P1.0
servo s1 = P1.1
pose rest { s0: 90deg, s1: 90deg }
home rest
main {
  host
}
"""


def test_verify_runs_until_the_bytes_sent_are_through_and_every_answer_is_checked(tmp_path, capsys):
    """One events line of 1250 `Q` lines (2.6 s of bytes at 9600 baud): verify runs until the last
    byte is through and checks every answer, not only those of the 2 s after the line began; a run
    asked shorter than the bytes is refused, as an event after its end is."""
    from test_verify_observes import cli_verify
    scenario = '0.1s "' + "Q\\r" * 1250 + '"\n'
    rc, data = cli_verify(tmp_path, capsys, TWO, scenario)
    assert rc == 0 and data["ok"] and not data["partial"], data
    assert data["bytes_sent"] == 1250 and data["span_s"] > 2.7, data["bytes_sent"]
    assert not [w for w in data["warnings"] if "still queued" in w], data["warnings"]
    rc, err = cli_verify(tmp_path, capsys, TWO, scenario, "--frames", "300")
    assert rc == 2 and "the bytes sent go on until 2.704 s" in err, err


def test_bytes_sent_before_the_firmware_listens_are_a_usage_error(tmp_path, capsys):
    """A byte whose start bit comes before serial_init turns the UART's receiver on would be missed
    or misread by a chip (and ucsim holds it back, shifting every answer after it): verify refuses
    such events and says from when on bytes may come; a byte from then on is received."""
    from test_verify_observes import cli_verify
    rc, err = cli_verify(tmp_path, capsys, TWO, '50us 0x0D\n300ms "Q\\r"\n')
    assert rc == 2 and "before the firmware's serial line receives" in err, err
    on = float(re.search(r"send them from ([\d.]+) ms on", err).group(1))
    rc, data = cli_verify(tmp_path, capsys, TWO, f'{on}ms 0x0D\n300ms "Q\\r"\n500ms "QP0\\r"\n')
    assert rc == 0 and data["ok"] and data["bytes_sent"] == 2, data


def test_the_mean_period_counts_a_line_switched_off_with_p0_by_its_frames(tmp_path, capsys):
    """`#0P0` switches s0's pulses off for a while: the mean period verify reports is still P, not
    s0's first-to-last rise over its pulses (which spans the frames without one)."""
    from test_verify_observes import cli_verify
    rc, data = cli_verify(tmp_path, capsys, TWO, '0.1s "#0P0\\r"\n1.0s "#0P1500\\r"\n')
    assert rc == 0 and data["ok"], data
    assert data["period_us"]["min"] == data["period_us"]["max"] == data["period_us"]["mean"] == pytest.approx(5299.479)


@pytest.mark.parametrize("clock", ["11.0592MHz", "11.0592MHz mode 6T"])
def test_a_group_line_after_answers_that_wait_moves_within_2_p(clock):
    """`VER` (17 bytes back), `Q` and a group line back to back: VER's answer fills the transmit
    queue, so Q's answer waits (in HAQ, with room for three), and the reading goes on: the group
    line's move starts at most 2 P after its CR, not once the answers are out. Then `VER` twice and
    a group line: the second VER's answer waits behind the first, and the move is as quick. Every
    answer goes out whole, in the order of the lines."""
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}")
    b, trace, report = session('0.1s "VER\\rQ\\r#0P2000\\r"\n0.5s "VER\\rVER\\r#1P2000\\r"\n',
                               round(1.2e6 / built(text).plan.period_us), text)
    ver = b"SSC32-servoc-0.1\r"
    assert sent(trace) == ver + b"." + ver + ver
    frame = lambda s: round(s * 1e6 / b.plan.period_us)      # noqa: E731
    base = [n_of(b, w) for w in widths(b, trace, 1, 0)]
    shoulder = [n_of(b, w) for w in widths(b, trace, 1, 1)]
    cr = 0.1 + len("VER\rQ\r#0P2000\r") * 10 / 9600
    moved = next(i for i in range(frame(0.05), len(base)) if base[i] != 122)
    assert frame(0.1) < moved <= frame(cr) + 2, (moved, frame(cr))
    cr = 0.5 + len("VER\rVER\r#1P2000\r") * 10 / 9600
    moved = next(i for i in range(frame(0.45), len(shoulder)) if shoulder[i] != 122)
    assert frame(0.5) < moved <= frame(cr) + 2, (moved, frame(cr))


@pytest.mark.parametrize("clock, baud, tail", [("11.0592MHz", 9600, ""), ("11.0592MHz mode 6T", 19200, "S10000T500")])
def test_one_channel_lines_back_to_back_lose_no_byte(clock, baud, tail):
    """One-channel group lines back to back, each longer than a frame brings (8 bytes at 9600
    baud, where a frame brings 5.5; 18 at 19200 baud in 6T mode, where it brings 10.4) and than a
    frame's reading takes (7 and 17 bytes). After a group line the reading goes on into the next
    line, up to its CR, so every frame carries out a line and reads on: no byte is lost, every
    byte is read, verify passes the run, and the last line's servo ends at its width. (When a
    group line stopped the frame's reading, each line cost a frame's reading, and these lines
    filled the receive queue.)"""
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}").replace("serial 9600", f"serial {baud}")
    plan = built(text).plan
    brings = plan.period_us * baud / 10 / 1e6 * 1.02
    lines = [f"#{c}P{1000 + (97 * i) % 900}{tail}\r" for i, c in enumerate([0, 1, 2, 7] * 40)]
    assert all(len(ln) > max(brings, flow.host_passes(plan)) for ln in lines), brings
    scenario = '0.3s "' + "".join(ln.replace("\r", "\\r") for ln in lines) + '"\n'
    b, trace, report = session(scenario, round((1.2 + len("".join(lines)) * 10 / baud) * 1e6 / plan.period_us), text)
    read = b"".join(bytes(got) for h in trace.observation.hosts for _, _, got in h.frames)
    assert read == "".join(lines).encode()
    assert not [w for w in report.warnings if "lost" in w]
    # each line's move ends the one before where it is (verify checks every frame of them); the
    # last line's servo, the grip (channel 7 on P1.3), goes all the way
    s = next(c.servo for c in b.plan.channels if host_channel(c.servo) == 7)
    servo = ssc32.Servo(7, *(s.limit or (0, 250)), s.reverse, s.trim, s.t_dav_us)
    assert n_of(b, widths(b, trace, 1, 3)[-1]) == ssc32.target_n(servo, int(lines[-1][3:7]), 0)


@pytest.mark.parametrize("clock, baud", [("11.0592MHz", 9600), ("11.0592MHz mode 6T", 19200)])
def test_one_channel_lines_shorter_than_a_frame_brings_lose_none(clock, baud):
    """One-channel lines back to back of 5 and 4 bytes (`#0P9` and CR: a width clamped to 500 us,
    set at once; `#0P` and CR: P0, the pulses off), shorter than a frame brings (b, 5.4 at the arm
    and 4.7 at 19200 baud in 6T mode): two lines end in some frames' reading, and the second
    joins the first. No byte is lost, every byte is read, verify passes. (When
    the reading stopped at the next line's end after a group line, such lines filled the receive
    queue.)"""
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}").replace("serial 9600", f"serial {baud}")
    plan = built(text).plan
    brings = plan.period_us * baud / 10 / 1e6 * 1.02
    lines = [f"#{c}P{'' if i % 3 == 2 else i % 10}\r" for i, c in enumerate([0, 1, 2, 7] * 60)]
    assert max(len(ln) for ln in lines) < brings, brings
    scenario = '0.3s "' + "".join(ln.replace("\r", "\\r") for ln in lines) + '"\n'
    b, trace, report = session(scenario, round((0.8 + len("".join(lines)) * 10 / baud) * 1e6 / plan.period_us), text)
    readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames if got]
    assert b"".join(readings) == "".join(lines).encode()
    assert not [w for w in report.warnings if "lost" in w]
    assert sum(1 for r in readings if r.count(b"\r") >= 2) >= 10      # frames whose lines joined


OVERFLOWED = """\
target at89c52 clock 11.0592MHz
serial 9600
host ssc32
servo s0 = P1.0 trim -2
servo s1 = P1.1 reverse trim 1
servo s2 = P1.2
servo s3 = P1.3 trim 2
pose p { s0: 40, s1: 53, s2: 66, s3: 79 }
pose q { s0: 200, s1: 171, s2: 142, s3: 113 }
home p
main {
  move q in 800ms
  host
}
"""


def test_a_receive_queue_overflowing_during_a_move_leaves_its_frames_exact():
    """100 bytes come while a compiled move runs and nothing reads them: the receive queue fills,
    and each byte after that finds it full. The serial handler, which saves no PSW when it takes a
    byte, then marks the newest byte queued without touching a flag: a compare there (CJNE) set
    the carry of the move's arithmetic it interrupted, and a servo stopped short of its pose.
    verify passes the run, every frame of the move exact."""
    b, trace, report = session('0.5s "' + "Q\\r" * 50 + '"\n', round(1.6e6 / built(OVERFLOWED).plan.period_us),
                               OVERFLOWED)
    assert any("was lost" in w for w in report.warnings)           # the queue did fill
    assert [n_of(b, widths(b, trace, 1, bit)[-1]) for bit in range(4)] == [198, 250 - 171 + 1, 142, 115]


QUEUED = """\
target stc89c52rc clock 11.0592MHz
serial 9600
host ssc32
frame 20ms
servo s0 = P1.0
servo s1 = P1.1
servo s2 = P1.2
servo s3 = P1.3
pose p { s0: 100, s1: 100, s2: 100, s3: 100 }
home p
main {
  hold 200ms
  host
}
"""


def test_group_lines_read_in_one_frame_join_into_one_move():
    """Lines queued before `host` runs, so that the first frame's reading has them all: a group
    line with T, a one-channel line with its own T, the LF of a CR LF, a line naming a channel
    with no servo, and a one-channel line; then a Q, read too (a frame of 20 ms brings more than a group line and a Q line:
    flow.reads_answers), whose answer waits for the group's commit: `+`. The group
    lines join: s0, s1 and s3 start in the same frame and arrive together, after the last T given
    (T200: 10 frames at 20 ms), not the first (T600). As the model says (verify checks every
    pulse)."""
    lines = b"#0P1460T600\r#1P1140T200\r\n#9P7\r#3P1500\rQ\r"        # 40 bytes: the queue holds 41
    scenario = '0.05s "' + lines.decode().replace("\r", "\\r").replace("\n", "\\n") + '"\n'
    b, trace, report = session(scenario, 30, QUEUED)
    readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames if got]
    assert readings[0] == lines and flow.reads_answers(b.plan), readings
    assert sent(trace) == b"+"
    n = {bit: [n_of(b, w) for w in widths(b, trace, 1, bit)] for bit in range(4)}
    target = {0: 120, 1: 80, 3: 125}                   # (w - 500 + 4) // 8, from 100: the top
                                                       # speed takes 4 frames at most
    assert n[2] == [100] * len(n[2])
    starts = {bit: next(k for k, v in enumerate(n[bit]) if v != 100) for bit in (0, 1, 3)}
    ends = {bit: n[bit].index(target[bit]) for bit in (0, 1, 3)}
    assert len(set(starts.values())) == 1 and len(set(ends.values())) == 1, (starts, ends)
    assert ends[0] - starts[0] + 1 == 10, (starts, ends)



@pytest.mark.parametrize("bad", [b"#2X\r", b"#2P1500 Q\r"])
def test_a_bad_line_after_a_group_line_stops_the_reading_and_drops_nothing_of_it(bad):
    """Lines queued before `host` runs: a group line, a bad line (bad before its CR, or only at
    it), a group line. The bad line's end is read and drops it; the group stays and moves s0, and
    the reading stops there until it is committed: the last line is read in the next frame, a
    move of its own (s0 stops where it is)."""
    lines = b"#0P1460T200\r" + bad + b"#3P1500\r"
    scenario = '0.05s "' + lines.decode().replace("\r", "\\r") + '"\n'
    b, trace, report = session(scenario, 30, QUEUED)
    readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames if got]
    assert readings == [b"#0P1460T200\r" + bad, b"#3P1500\r"], readings
    n = {bit: [n_of(b, w) for w in widths(b, trace, 1, bit)] for bit in range(4)}
    assert n[2] == [100] * len(n[2])
    first0 = next(k for k, v in enumerate(n[0]) if v != 100)
    first3 = next(k for k, v in enumerate(n[3]) if v != 100)
    assert first3 == first0 + 1 and n[0][-1] == n[0][first0] and n[3][-1] == 125, (n[0][first0 - 1:first0 + 3], first0, first3)


@pytest.mark.parametrize("holds", [True, False])
def test_after_a_group_line_the_reading_stops_before_a_control_byte_or_a_second_entry(holds, monkeypatch):
    """Lines queued before `host` runs: a group line, a TAB and a one-channel line, a line of two
    entries. The first frame's reading stops after the group line, before the TAB (a control
    byte); the second reads the TAB and the next group line, and on into the line after it:
    with the holds (a frame of 20 ms brings 19 bytes) to its end, its first entry held at the
    '#' of its second and that at its end; without them up to that '#', and the third reads the
    rest. As the model says (verify checks it both ways)."""
    from servoc import layout
    if not holds:
        monkeypatch.setattr(flow, "HOLDS_IRAM", 0)
    b = build_text(QUEUED)
    assert bool(layout.host_holds(b.plan)) == holds
    trace, report = watch(b, '0.05s "#0P2000\\r\\t#1P900\\r#2P1400#3P1600\\r"\n', 30)
    assert report.ok, problems(report)
    readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames if got]
    if holds:
        assert readings == [b"#0P2000\r", b"\t#1P900\r#2P1400#3P1600\r"], readings
    else:
        assert readings == [b"#0P2000\r", b"\t#1P900\r#2P1400", b"#3P1600\r"], readings


@pytest.mark.parametrize("clock, baud, frame", [("11.0592MHz", 9600, "20ms"), ("11.0592MHz mode 6T", 19200, "10ms"),
                                                ("22.1184MHz", 19200, "8ms")])
def test_in_internal_ram_two_servo_lines_back_to_back_at_a_long_frame_lose_no_byte(clock, baud, frame, monkeypatch):
    """The arm with its state in internal RAM, at a frame that brings more bytes than a two-entry
    line (`#0P1234#1P1234` and CR, 15 bytes): lines that set two servos, back to back for 3 s.
    After a group line the reading holds each entry a '#' ends (and, while one is held, a line's
    last) rather than stopping before the line's second entry (layout.host_holds): every byte
    read, none lost, verify passes. Built without the holds, the reading gets through a line a
    frame and the same lines lose bytes (at 20 ms, 9600 baud)."""
    from servoc import layout
    text = ARM.replace("clock 11.0592MHz", f"clock {clock}").replace("serial 9600", f"serial {baud}\nframe {frame}")
    chans = (0, 1, 2, 7)
    lines = "".join(f"#{chans[n % 4]}P{1000 + n * 37 % 900}#{chans[(n + 1) % 4]}P{1100 + n * 53 % 900}\\r"
                    for n in range(3 * baud // 150))
    sent = len(lines.replace("\\r", "\r"))

    def run(b):
        trace, report = watch(b, f'0.2s "{lines}"\n', int((1.0 + sent * 10 / baud) * 1e6 / b.plan.period_us))
        assert report.ok, problems(report)
        readings = [bytes(got) for h in trace.observation.hosts for _, _, got in h.frames]
        return sent - sum(1 for r in trace.observation.received if r.queued), readings

    b = build_text(text)
    assert layout.host_holds(b.plan) == flow.HOLDS_IRAM and not flow.host_xram(b.plan)
    lost, readings = run(b)
    assert lost == 0
    assert sum(1 for got in readings if got.count(b"\r") >= 2) > 5         # a line joined a group
    if frame == "20ms":
        monkeypatch.setattr(flow, "HOLDS_IRAM", 0)
        b = build_text(text)
        assert not layout.host_holds(b.plan)
        assert run(b)[0] > 100


def test_in_internal_ram_the_holds_are_built_only_where_a_frame_brings_more_than_a_two_entry_line():
    """Without holds the reading gets through a line a frame at least, so it keeps up with lines no
    shorter than a frame's bytes: where no line that does something is shorter (flow.CUT_LINE),
    the holds' cycles would buy nothing, and the firmware has none (the arm at its own period).
    At a frame that brings more, it has them, and its shortest period is longer by their cost."""
    from servoc import layout
    b = built()
    assert flow.frame_bytes(b.plan) <= flow.CUT_LINE and not layout.host_holds(b.plan)
    assert "HHO" not in b.firmware.unit.text
    long = build_text(ARM.replace("serial 9600", "serial 9600\nframe 12ms"))
    assert flow.frame_bytes(long.plan) > flow.CUT_LINE and layout.host_holds(long.plan) == flow.HOLDS_IRAM
    assert "HHO" in long.firmware.unit.text and long.plan.min_period_us > b.plan.min_period_us


def test_in_internal_ram_a_program_short_only_by_the_holds_is_built_without_them():
    # servos on P1 of an AT89C52 at `frame 20ms` (the holds wanted: 19 bytes a frame): up to 6
    # they fit with the holds' 12 bytes, 7 fit only without them (lint accepts, compile builds,
    # a session verifies), 8 are host-ram either way
    from servoc import layout

    def prog(n: int) -> str:
        return ("target at89c52 clock 11.0592MHz\nserial 9600\nframe 20ms\nhost ssc32\n"
                + "".join(f"servo s{b} = P1.{b}\n" for b in range(n)) + "main { host }\n")
    plans = {}
    for n in (6, 7, 8):
        fe, diags = front_end_text(prog(n))
        plans[n] = (fe.plan, [x.code for x in diags if x.is_error])
    assert not plans[6][1] and layout.host_holds(plans[6][0]) == flow.HOLDS_IRAM
    assert not plans[7][1] and not plans[7][0].holds and not layout.host_holds(plans[7][0])
    assert plans[8][1] == ["host-ram"] and not plans[8][0].holds    # (it says what is short without them)
    b = build_text(prog(7))
    assert "HHO" not in b.firmware.unit.text
    trace, report = watch(b, '0.5s "#0P1000#1P1200\\r#0P1100#1P900\\r"\n', int(1.5e6 / b.plan.period_us))
    assert report.ok, problems(report)
