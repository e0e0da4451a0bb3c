"""Select shapes far beyond the examples: every program lint accepts compiles and assembles.

The jumps the templates emit have a reach (a short jump 127 bytes, a conditional
branch the same), so the size of a construct is a resource like RAM: these
programs put 1 to 16 byte branches in one select, mix inputs and bytes, add
`after`, nest selects 1 to 6 deep, and make bodies from empty to hundreds of
bytes of code. Each must lint without error and then compile (sdas8051 and
sdld included); a sample runs in ucsim under bytes at random phases.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import build_text, front_end_text
from test_serial import run

pytestmark = pytest.mark.toolchain

HEAD = """\
serial 4800
servo x = P1.1 speed 0.0001s/60deg
servo y = P1.6 speed 0.0001s/60deg
servo z = P2.0 speed 0.0001s/60deg
input i0 = P3.2
input i1 = P3.3 high
input i2 = P3.4
input i3 = P3.5
pose p0 { x: 0, y: 250, z: 10 }
pose p1 { x: 125, y: 3, z: 200 }
pose p2 { x: 250, y: 120, z: 90 }
sequence wiggle { move p1 in 20ms; move p0 in 20ms }
"""
BYTES = "abcdefghijklmnopqrstuvwxyz"


def body(rng: random.Random, size: int) -> str:
    """`size` statements: moves, sends between frames, holds and plays (size 0: empty)."""
    out = []
    for k in range(size):
        kind = rng.choice(["move", "move", "send", "hold", "play"])
        if kind == "send" and (not out or out[-1].startswith("send")):
            kind = "move"
        out.append({"move": f"move p{rng.randrange(3)} in {rng.choice([6, 30, 100])}ms",
                    "send": f'send "{rng.choice(BYTES)}"', "hold": f"hold {rng.choice([6, 50])}ms",
                    "play": "play wiggle"}[kind])
    return "; ".join(out)


def select(rng: random.Random, n_bytes: int, n_inputs: int, after: bool, depth: int, size: int) -> str:
    """A select with `n_bytes` byte `on`s and `n_inputs` input `on`s in a random order, maybe an
    `after`; its first branch holds a select one level less deep."""
    events = [f'"{b}"' for b in BYTES[:n_bytes]] + [f"i{k}" for k in range(n_inputs)]
    rng.shuffle(events)
    branches = []
    for k, ev in enumerate(events):
        inner = body(rng, size)
        if k == 0 and depth > 1:
            inner = (inner + "; " if inner else "") + select(rng, max(1, n_bytes // 2), min(1, n_inputs), after,
                                                             depth - 1, size)
        branches.append(f"on {ev} {{ {inner} }}")
    if after:
        branches.append(f"after {rng.choice([0, 30, 200])}ms {{ {body(rng, size)} }}")
    return "select { " + " ".join(branches) + " }"


def program(seed: int, n_bytes: int, n_inputs: int, after: bool, depth: int, size: int) -> str:
    rng = random.Random(seed)
    sel = lines(select(rng, n_bytes, n_inputs, after, depth, size))
    return HEAD + f"main {{\n  move p0\n  loop {{\n    {sel}\n    move p2 in 30ms\n  }}\n}}\n"


def lines(text: str) -> str:
    """Each branch of a select on a line of its own."""
    return text.replace("} on", "}\n    on").replace("} after", "}\n    after")


def lints(text: str) -> bool:
    fe, diags = front_end_text(text)
    return fe.plan is not None and not any(d.is_error for d in diags)


SHAPES = [(n, i, a, d, s) for n in (1, 4, 5, 8, 16) for i in (0, 2) for a in (False, True)
          for d, s in ((1, 0), (1, 12), (3, 3), (6, 1))]


@pytest.mark.parametrize("n_bytes,n_inputs,after,depth,size", SHAPES)
def test_every_select_shape_that_lints_compiles(n_bytes, n_inputs, after, depth, size):
    text = program(n_bytes * 1000 + depth * 10 + size, n_bytes, n_inputs, after, depth, size)
    assert lints(text), text
    build_text(text)        # fails the test on any error, an assembler error included


def test_a_select_with_every_byte_and_a_long_body_compiles():
    # 64 byte branches, each with a body of 40 statements: thousands of bytes between a select's
    # look and its last branch
    rng = random.Random(7)
    ons = lines(" ".join(f'on {b} {{ {body(rng, 40)} }}' for b in range(64)))
    text = "target stc89c58rd   # 32 KB of code\n" + HEAD + \
        f"main {{\n  move p0\n  loop {{\n    select {{ {ons} }}\n  }}\n}}\n"
    assert lints(text), text
    built = build_text(text)
    assert built.firmware.hex_text


def test_the_issue_program_with_five_byte_branches_compiles_and_verifies():
    text = ("serial 4800\nservo a = P1.0\n" + "".join(f"pose p{k} {{ a: {10 + 30 * k}deg }}\n" for k in range(5))
            + "main {\n  move p0\n  loop {\n    select {\n"
            + "".join(f'      on "{c}" {{ move p{k} in 700ms; send "{c.upper()}" }}\n' for k, c in enumerate("abcde"))
            + "    }\n  }\n}\n")
    plan, trace, evs, report = run(text, '500ms "c"\n1.4s "e"\n2.3s "z" "a"\n', 700)
    assert report.ok, (report.summary(), [str(m) for m in report.mismatches[:4]])
    assert "".join(chr(b) for _, b in trace.sent) == "CEA"


@settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(st.integers(1, 16), st.integers(0, 3), st.booleans(), st.integers(1, 4), st.integers(0, 4),
       st.lists(st.tuples(st.floats(0, 1), st.sampled_from(BYTES[:16])), min_size=1, max_size=6))
def test_a_sample_verifies_under_bytes_at_random_phases(n_bytes, n_inputs, after, depth, size, sends):
    text = program(n_bytes + 100 * depth, n_bytes, 0, after, depth, size)
    if not lints(text):
        return
    scenario = "".join(f'{round(300 + 400 * k + 5.3 * phase, 3)}ms "{b}"\n' for k, (phase, b) in enumerate(sends))
    plan, trace, evs, report = run(text, scenario, 500)
    assert report.ok, (text, scenario, report.summary(), [str(m) for m in report.mismatches[:4]])


@pytest.mark.parametrize("clock", ["clock 11.0592MHz", "clock 12MHz", "clock 20MHz mode 6T"])
def test_the_runtime_at_its_largest_assembles(clock):
    # Every template at its largest: 24 servos on three ports, two speed classes (frames-needed
    # tables), eased and undated moves, the serial line, inputs, an 11.0592 MHz crystal (the
    # edge-time table) and a select with every kind of branch
    servos = "".join(f"servo s{p}{b} = P{p}.{b}{' speed 0.3s/60deg' if b % 2 else ''}\n"
                     for p in range(3) for b in range(8))
    text = (f"target stc89c52rc {clock}\nserial 4800\n"
            + "input go = P3.2\ninput stop = P3.3 high\n" + servos
            + "pose lo { P0: 10, P1: 10, P2: 10 }\npose hi { P0: 240, P1: 240, P2: 240 }\n"
            + "main {\n  move lo\n  loop {\n    select {\n      on go { move hi in 2s ease in-out; send \"G\" }\n"
            + "      on stop { move lo }\n      on \"a\" { move hi; move lo in 3s ease in }\n"
            + "      after 500ms { move lo in 3s ease out }\n    }\n  }\n}\n")
    assert lints(text), text
    built = build_text(text)
    assert built.plan.program.target.grid is (clock == "clock 12MHz")     # else the C(N) table is in


@pytest.mark.parametrize("name", ["biped", "hexapod_serial", "serial_arm", "stc_board"])
def test_the_rom_breakdown_adds_up(name, capsys):
    from pathlib import Path
    from servoc.cli import main
    path = Path(__file__).resolve().parent.parent / "examples" / f"{name}.servo"
    built = build_text(path.read_text(encoding="utf-8"))
    fw = built.firmware
    assert fw.startup_bytes + fw.runtime_bytes + fw.program_bytes + fw.data_bytes == fw.rom_bytes
    assert min(fw.startup_bytes, fw.runtime_bytes, fw.program_bytes, fw.data_bytes) > 0
