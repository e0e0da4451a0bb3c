"""servoc.vcd: the simulated pin waveforms as a VCD, read back and checked.

A small VCD reader below parses the written file on its own (header,
scopes, variables, value changes) so that the checks do not trust the
writer's library. The dump is compared with the trace it came from, edge
for edge, and with the plan: every high pulse of a servo's wire lasts
500 + 8 N us of the golden frame it belongs to.
"""

from __future__ import annotations

import io
import itertools
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from servoc import api
from servoc.plan import expand
from servoc.plot import MissingExtra
from servoc.sim import PortWrite, SimTrace
from servoc.units import BASE_US, DIV_US
from servoc.verify import cycles_needed, first_pulse_frame
from servoc.vcd import render_vcd, write_vcd

from conftest import build_text, front_end_text

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

# Three ports, moves in both directions, a reversed servo, one declared but never moved.
LINEAR = """\
frame 12ms
servo a = P0.2
servo b = P1.0
servo c = P1.7 reverse
servo d = P2.5
servo idle = P2.6
pose p0 { a: 0, b: 250, c: 17, d: 125 }
pose p1 { a: 30, b: 220, c: 17, d: 140 }
main {
  move p0
  move p1 in 84ms
  hold 24ms
  move p0 in 96ms
}
"""


# ============================================================ a small VCD reader

@dataclass
class Dump:
    timescale: str = ""
    comment: str = ""
    vars: dict[str, tuple[str, int]] = field(default_factory=dict)      # full name -> (id, size)
    changes: dict[str, list[tuple[int, int]]] = field(default_factory=dict)   # id -> [(time, value)]
    times: list[int] = field(default_factory=list)                   # every `#t`, in file order

    def waves(self, name: str) -> list[tuple[int, int]]:
        return self.changes[self.vars[name][0]]


def read_vcd(text: str) -> Dump:
    """Parse VCD text: declarations, `$dumpvars`, scalar (`0!`) and vector (`b101 !`) changes."""
    dump = Dump()
    tokens = iter(text.split())
    scopes: list[str] = []
    time: int | None = None

    def until_end() -> list[str]:
        words = []
        for tok in tokens:
            if tok == "$end":
                return words
            words.append(tok)
        raise AssertionError("unterminated section")

    for tok in tokens:
        if tok == "$timescale":
            dump.timescale = " ".join(until_end())
        elif tok == "$comment":
            dump.comment = " ".join(until_end())
        elif tok in ("$date", "$version"):
            until_end()
        elif tok == "$scope":
            kind, name = until_end()
            assert kind == "module"
            scopes.append(name)
        elif tok == "$upscope":
            assert until_end() == []
            scopes.pop()
        elif tok == "$var":
            kind, size, ident, name, *rest = until_end()
            assert kind == "wire" and not rest
            full = ".".join(scopes + [name])
            assert full not in dump.vars
            dump.vars[full] = (ident, int(size))
            dump.changes[ident] = []
        elif tok == "$enddefinitions":
            assert until_end() == [] and not scopes
        elif tok in ("$dumpvars", "$end"):
            assert time is not None
        elif tok.startswith("#"):
            time = int(tok[1:])
            dump.times.append(time)
        elif tok.startswith("b"):
            ident = next(tokens)
            assert time is not None and ident in dump.changes
            dump.changes[ident].append((time, int(tok[1:], 2)))
        else:
            assert tok[0] in "01" and time is not None, tok
            dump.changes[tok[1:]].append((time, int(tok[0])))
    assert not scopes
    return dump


def high_pulses(wave: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """(rise, width) of every complete high pulse; the high level from reset is not a pulse."""
    assert wave and wave[0] == (0, 1)
    pulses, rise = [], None
    for t, level in wave[1:]:
        if level == 1:
            rise = t
        elif rise is not None:
            pulses.append((rise, t - rise))
            rise = None
    return pulses


def golden_widths(plan, channel, frames: int) -> list[tuple[int, bool]]:
    """(500 + 8 N, N on the language's curve) of `channel` in the first `frames` frames from the first pulse."""
    lead = first_pulse_frame(plan)
    out = []
    for fr in itertools.islice(expand(plan), lead, lead + frames):
        n = fr.n[channel.index]
        if n is not None:
            out.append((BASE_US + DIV_US * n, n == fr.curve[channel.index]))
    return out


def check_against_trace(dump: Dump, plan, trace: SimTrace) -> None:
    """Each servo wire has exactly the trace's pin edges, each latch exactly its port's writes."""
    for s in plan.program.servos:
        assert dump.waves(f"servoc.P{s.port}.{s.name}") == [(0, 1)] + trace.pin_edges(s.port, s.bit)
    for port in {s.port for s in plan.program.servos}:
        latch, value = [(0, 0xFF)], 0xFF
        for w in trace.port_writes(port):
            if w.value != value:
                latch.append((w.cycle, w.value))
                value = w.value
        assert dump.waves(f"servoc.P{port}.latch") == latch


def check_header(dump: Dump, plan, trace: SimTrace) -> None:
    assert dump.timescale in ("1 us", "1us")
    assert dump.times[0] == 0
    assert all(a < b for a, b in zip(dump.times, dump.times[1:]))     # strictly increasing
    assert dump.times[-1] == trace.cycles
    servos = {f"servoc.P{s.port}.{s.name}" for s in plan.program.servos}
    latches = {f"servoc.P{p}.latch" for p in {s.port for s in plan.program.servos}}
    assert set(dump.vars) == servos | latches
    assert all(dump.vars[n][1] == 1 for n in servos) and all(dump.vars[n][1] == 8 for n in latches)
    assert len({ident for ident, _ in dump.vars.values()}) == len(dump.vars)


# ============================================================ a hand-made trace (no simulator)

def test_hand_made_trace_gives_exact_changes(tmp_path):
    fe, _ = front_end_text(LINEAR)
    plan = fe.plan
    trace = SimTrace(writes=(
        PortWrite(2, 0, 0xFB),      # a low
        PortWrite(4, 1, 0x7E),      # b, c low
        PortWrite(6, 2, 0x9F),      # d, idle low
        PortWrite(100, 0, 0xFF),    # a high
        PortWrite(600, 0, 0xFB),    # a low: a 500 us pulse
        PortWrite(700, 1, 0xFF),    # b, c high
        PortWrite(700 + 2500, 1, 0xFE),
        PortWrite(700 + 2500 + 1, 1, 0xFE),     # a write that changes nothing
        PortWrite(4000, 1, 0x7E),   # c low
        PortWrite(4000, 3, 0x00),   # P3 is not a servo port
    ), cycles=5000)
    out = tmp_path / "hand.vcd"
    write_vcd(plan, trace, str(out), "hand.servo")
    assert sorted(os.listdir(tmp_path)) == ["hand.vcd"]
    text = out.read_text(encoding="ascii")
    dump = read_vcd(text)
    check_header(dump, plan, trace)
    check_against_trace(dump, plan, trace)
    assert dump.waves("servoc.P0.a") == [(0, 1), (2, 0), (100, 1), (600, 0)]
    assert dump.waves("servoc.P1.b") == [(0, 1), (4, 0), (700, 1), (3200, 0)]
    assert dump.waves("servoc.P1.c") == [(0, 1), (4, 0), (700, 1), (4000, 0)]
    assert dump.waves("servoc.P2.idle") == [(0, 1), (6, 0)]
    assert dump.waves("servoc.P1.latch") == [(0, 0xFF), (4, 0x7E), (700, 0xFF), (3200, 0xFE), (4000, 0x7E)]
    assert high_pulses(dump.waves("servoc.P0.a")) == [(100, 500)]
    assert "hand.servo" in dump.comment and "12000 us" in dump.comment
    assert "$date" not in text                                  # same trace, same bytes
    assert render_vcd(plan, trace, "hand.servo") == text


def test_pyvcd_reader_accepts_the_file():
    from vcd.reader import TokenKind, tokenize

    fe, _ = front_end_text(LINEAR)
    trace = SimTrace(writes=(PortWrite(3, 1, 0x7E), PortWrite(50, 1, 0xFF), PortWrite(600, 1, 0x7E)), cycles=1000)
    text = render_vcd(fe.plan, trace, "x.servo")
    kinds = [tok.kind for tok in tokenize(io.BytesIO(text.encode("ascii")))]
    assert TokenKind.ENDDEFINITIONS in kinds
    assert kinds.count(TokenKind.VAR) == 8       # 5 servos and the latches of P0, P1, P2


def test_missing_pyvcd_raises_missing_extra(tmp_path, monkeypatch):
    fe, _ = front_end_text(LINEAR)
    monkeypatch.setitem(sys.modules, "vcd", None)
    out = tmp_path / "x.vcd"
    with pytest.raises(MissingExtra) as info:
        write_vcd(fe.plan, SimTrace((), 10), str(out), "x.servo")
    assert isinstance(info.value, ImportError)
    assert "pip install 'servoc[vcd]'" in str(info.value)
    assert not out.exists()


# ============================================================ firmware in ucsim

def simulate(plan, firmware, frames: int) -> SimTrace:
    return api.simulate(firmware.hex_text, cycles_needed(plan, frames))


@pytest.mark.toolchain
def test_biped_vcd_matches_the_plan(tmp_path):
    source, reporter = api.load_source(str(EXAMPLES / "biped.servo"))
    fe, fw = api.build(source, reporter)
    assert fw is not None
    plan = fe.plan
    frames = 30
    trace = simulate(plan, fw, frames)
    out = tmp_path / "biped.vcd"
    write_vcd(plan, trace, str(out), "biped.servo")
    dump = read_vcd(out.read_text(encoding="ascii"))
    check_header(dump, plan, trace)
    names = [n.split(".")[-1] for n in dump.vars if not n.endswith(".latch")]
    assert names == ["hip_l", "knee_l", "ankle_l", "foot_l", "hip_r", "knee_r", "ankle_r", "foot_r"]
    assert all(n.startswith("servoc.P1.") for n in dump.vars)
    check_against_trace(dump, plan, trace)
    for ch in plan.channels:
        pulses = high_pulses(dump.waves(f"servoc.P1.{ch.name}"))
        want = golden_widths(plan, ch, frames)
        assert len(pulses) >= frames
        assert [w for _, w in pulses[:frames]] == [w for w, _ in want], ch.name
        rises = [r for r, _ in pulses[:frames]]
        assert {b - a for a, b in zip(rises, rises[1:])} <= set(range(plan.period_us - 2, plan.period_us + 3))


@pytest.mark.toolchain
def test_linear_program_vcd_every_frame(tmp_path):
    built = build_text(LINEAR)
    plan = built.plan
    frames = plan.total_frames + 3
    trace = simulate(plan, built.firmware, frames)
    out = tmp_path / "linear.vcd"
    write_vcd(plan, trace, str(out), "linear.servo")
    dump = read_vcd(out.read_text(encoding="ascii"))
    check_header(dump, plan, trace)
    check_against_trace(dump, plan, trace)
    assert set(dump.vars) == {"servoc.P0.a", "servoc.P0.latch", "servoc.P1.b", "servoc.P1.c", "servoc.P1.latch",
                              "servoc.P2.d", "servoc.P2.idle", "servoc.P2.latch"}
    seen = set()
    for ch in plan.channels:
        pulses = high_pulses(dump.waves(f"servoc.P{ch.port}.{ch.name}"))
        want = golden_widths(plan, ch, frames)
        assert all(exact for _, exact in want)
        assert [w for _, w in pulses[:frames]] == [w for w, _ in want], ch.name
        seen.update(w for w, _ in want)
    assert {500, 2500, 500 + 8 * 233} <= seen and len(seen) > 20
    # the servo that is never moved is driven low after reset and stays low
    assert dump.waves("servoc.P2.idle") == [(0, 1), (trace.first_low(2, 6), 0)]
    assert trace.first_low(2, 6) <= 20
