"""servoc.printer: canonical text that parses back to the same program."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servoc import nodes
from servoc.check import check
from servoc.diagnostics import Reporter
from servoc.printer import format_number, format_program
from servoc.source import SourceFile, Span
from servoc.syntax import parse

SPEC_EXAMPLE = Path(__file__).parent / "fixtures" / "spec_example.servo"


def parse_check(text: str):
    src = SourceFile("t.servo", text)
    rep = Reporter(src)
    tree = parse(src, rep)
    assert tree is not None, (text, [d.message for d in rep.diagnostics])
    prog = check(tree, rep, "t.servo")
    assert prog is not None, (text, [(d.code, d.message) for d in rep.diagnostics])
    return tree, prog


def assert_round_trip(text: str) -> str:
    tree, prog = parse_check(text)
    printed = format_program(tree)
    tree2, prog2 = parse_check(printed)
    assert prog2 == prog
    assert format_program(tree2) == printed
    return printed


@pytest.mark.parametrize("value,text", [
    (Fraction(0), "0"), (Fraction(1500), "1500"), (Fraction(1, 4), "0.25"), (Fraction(-2), "-2"),
    (Fraction(-3, 2), "-1.5"), (Fraction(11_0592, 10_000), "11.0592"), (Fraction(1, 1000), "0.001"),
    (Fraction(1, 3), "0.333333333333"),
])
def test_format_number(value, text):
    assert format_number(value) == text


def test_spec_example_round_trips():
    printed = assert_round_trip(SPEC_EXAMPLE.read_text())
    assert "servo ankle_l = P1.2 trim -2 limit 20deg..160deg\n" in printed
    assert "pose lean = stand with { ankle_l: 80deg }\n" in printed
    assert "    move lean in 300ms ease in-out\n" in printed
    assert "#" not in printed


def test_canonical_layout():
    text = ("frame 6ms;servo a=P1.0 reverse   trim +3\n\n\n\nservo b = P1.1 # c\npose p {\n a: 10,\n b: 2,\n}\n"
            "pose e {\n}\nmain { repeat 2 { play s } ; loop {} }\nsequence s { hold 1.50s; move p in 1s ease in }")
    printed = assert_round_trip(text)
    assert printed == (
        "frame 6ms\n"
        "\n"
        "servo a = P1.0 reverse trim 3\n"
        "servo b = P1.1\n"
        "\n"
        "pose p { a: 10, b: 2 }\n"
        "pose e {}\n"
        "\n"
        "main {\n"
        "  repeat 2 {\n"
        "    play s\n"
        "  }\n"
        "  loop {}\n"
        "}\n"
        "\n"
        "sequence s {\n"
        "  hold 1.5s\n"
        "  move p in 1s ease in\n"
        "}\n")


def test_printing_built_nodes():
    sp = Span(0, 0)
    q = lambda v, u="": nodes.Quantity(Fraction(v), u, sp)   # noqa: E731
    name = lambda t: nodes.Name(t, sp)                        # noqa: E731
    tree = nodes.Program((
        nodes.ServoDecl(name("a"), nodes.Pin("P2.7", sp), (nodes.TrimOption(q(-4), sp),), sp),
        nodes.PoseDecl(name("p"), None, (nodes.Entry(name("a"), q("7.4", "deg"), sp),), sp),
        nodes.MainDecl((nodes.MoveStmt(name("p"), q(2, "s"), "in-out", sp),), sp, sp),
    ), sp)
    printed = format_program(tree)
    assert printed == "servo a = P2.7 trim -4\n\npose p { a: 7.4deg }\n\nmain {\n  move p in 2s ease in-out\n}\n"
    _, prog = parse_check(printed)
    assert prog.servos[0].trim == -4
    assert prog.poses[0].targets[0].n == 10 - 4          # 7.4deg is N 10


# ---- (d): random valid programs print and parse back to an equal model ------

PINS = [f"P{p}.{b}" for p in range(3) for b in range(8)]


def _decimal(value: Fraction) -> str:
    return format_number(value)


@st.composite
def position_text(draw, n: int) -> str:
    """A way of writing position N: raw, degrees, microseconds, milliseconds, or off the grid."""
    form = draw(st.sampled_from(["raw", "deg", "us", "ms", "offgrid"]))
    if form == "raw":
        return str(n)
    if form == "deg":
        return _decimal(Fraction(74, 100) * n) + "deg"
    width = Fraction(500 + 8 * n)
    if form == "us":
        return _decimal(width) + "us"
    if form == "ms":
        return _decimal(width / 1000) + "ms"
    return _decimal(width + draw(st.sampled_from([1, 2, 3, -1, -2, -3]))) + "us"


DURATIONS = st.sampled_from(["0ms", "1ms", "20ms", "300ms", "0.5s", "1s", "1.25s", "12000us", "6.5ms"])


@st.composite
def programs(draw) -> str:
    seps = st.sampled_from(["\n", ";", " ; ", "\n\n", "  # note\n", ";\n"])
    blank = st.sampled_from(["", " ", "  "])

    def sep() -> str:
        return draw(seps)

    items: list[str] = []
    settings_: list[str] = []
    if draw(st.booleans()):
        settings_.append("frame " + draw(st.sampled_from(["5ms", "6ms", "6000us", "7.5ms", "0.02s"])))
    if draw(st.booleans()):
        chip = draw(st.sampled_from(["at89c52", "AT89C52", "at89s52", "stc89c52"]))
        clock = draw(st.sampled_from(["", " clock 12MHz", " clock 12000kHz"]))
        settings_.append(f"target {chip}{clock}")
    host = draw(st.booleans())
    if host:
        settings_ += ["serial 4800", "host ssc32"]

    # servos: (name, port, lo, hi)
    n_servos = draw(st.integers(0, 6))
    pins = draw(st.permutations(PINS))[:n_servos]
    channels = iter(draw(st.permutations(range(24, 32))))     # no pin's channel: never a conflict
    servos: list[tuple[str, int, int, int]] = []
    for i, pin in enumerate(pins):
        name = f"s{i}"
        options = []
        lo, hi = 0, 250
        if draw(st.booleans()):
            options.append("speed " + draw(st.sampled_from(["0.25s", "200ms", "150000us", "1s"])) + "/"
                           + draw(st.sampled_from(["60deg", "30deg", "45.5deg", "185deg"])))
        if draw(st.booleans()):
            t = draw(st.integers(-5, 5))
            options.append("trim " + draw(st.sampled_from([str(t), f"+{t}" if t >= 0 else str(t)])))
        if draw(st.booleans()):
            lo, hi = draw(st.integers(0, 100)), draw(st.integers(150, 250))
            options.append(f"limit {draw(position_text(lo))}..{draw(position_text(hi))}")
            # an off-grid bound may round to a neighbour: keep the entries well inside
            lo, hi = lo + 1, hi - 1
        if draw(st.booleans()):
            options.append("reverse")
        if draw(st.booleans()):
            options.append(f"channel {next(channels)}")
        options = draw(st.permutations(options))
        items.append(f"servo {name} = {pin}" + "".join(" " + o for o in options))
        servos.append((name, int(pin[1]), lo, hi))

    # groups: name -> servo indices
    groups: dict[str, set[int]] = {}
    if servos:
        for i in range(draw(st.integers(0, 3))):
            choices = [s[0] for s in servos] + list(groups)
            members = draw(st.lists(st.sampled_from(choices), min_size=1, max_size=4, unique=True))
            covered: set[int] = set()
            for m in members:
                covered |= groups[m] if m in groups else {int(m[1:])}
            groups[f"g{i}"] = covered
            items.append(f"group g{i} = " + ", ".join(members))

    # poses
    targets: dict[str, set[int]] = {s[0]: {i} for i, s in enumerate(servos)}
    targets.update(groups)
    for port in range(3):
        on_port = {i for i, s in enumerate(servos) if s[1] == port}
        if on_port:
            targets[f"P{port}"] = on_port
    poses: list[str] = []
    for i in range(draw(st.integers(0, 4))):
        order = draw(st.permutations(sorted(targets)))
        count = draw(st.integers(0, len(order)))
        covered: set[int] = set()
        entries = []
        for t in order[:count]:
            if targets[t] & covered:
                continue
            covered |= targets[t]
            low = max([5] + [servos[k][2] for k in targets[t]])
            high = min([245] + [servos[k][3] for k in targets[t]])
            n = draw(st.integers(low, high))
            entries.append(f"{t}:{draw(blank)}{draw(position_text(n))}")
        esep = draw(st.sampled_from([", ", ",", "\n", ",\n  ", " # c\n"]))
        body = esep.join(entries)
        if entries and draw(st.booleans()):
            body += draw(st.sampled_from([",", ",\n", "\n"]))
        head = f"pose p{i}"
        if poses and draw(st.booleans()):
            head += f" = {draw(st.sampled_from(poses))} with"
        items.append(f"{head} {{{draw(blank)}{body}{draw(blank)}}}")
        poses.append(f"p{i}")

    def statements(depth: int, sequences: list[str]) -> str:
        kinds = ["hold"] + (["move", "move"] if poses else []) + (["play"] if sequences else []) + \
            (["host"] if host else [])
        if depth < 3:
            kinds += ["repeat", "loop"]
        out = []
        for _ in range(draw(st.integers(0, 4))):
            kind = draw(st.sampled_from(kinds))
            if kind == "move":
                text = f"move {draw(st.sampled_from(poses))}"
                if draw(st.booleans()):
                    text += f" in {draw(DURATIONS)}"
                    ease = draw(st.sampled_from(["", "linear", "in", "out", "in-out"]))
                    if ease:
                        text += f" ease {ease}"
            elif kind == "hold":
                text = f"hold {draw(DURATIONS)}"
            elif kind == "play":
                text = f"play {draw(st.sampled_from(sequences))}"
            elif kind == "host":
                text = draw(st.sampled_from(["host", "host until \"s\""]))
            elif kind == "repeat":
                text = f"repeat {draw(st.integers(1, 5))} {{{statements(depth + 1, sequences)}}}"
            else:
                text = f"loop {{{statements(depth + 1, sequences)}}}"
            out.append(text)
        if not out:
            return draw(st.sampled_from(["", " ", "\n"]))
        inner = sep().join(out)
        return f"{sep()}{inner}{sep()}"

    sequences: list[str] = []
    for i in range(draw(st.integers(0, 3))):
        items.append(f"sequence q{i} {{{statements(1, list(sequences))}}}")
        sequences.append(f"q{i}")
    items.append(f"main {{{statements(1, sequences)}}}")

    items = draw(st.permutations(items))
    lead = draw(st.sampled_from(["", "\n", "# header\n\n"]))
    text = lead + "".join(s + sep() for s in settings_)
    return text + sep().join(items) + draw(st.sampled_from(["", "\n", "\n\n"]))


@settings(max_examples=150, deadline=None)
@given(programs())
def test_random_programs_round_trip(text):
    assert_round_trip(text)


@settings(max_examples=60, deadline=None)
@given(programs())
def test_random_programs_have_targets_in_range(text):
    _, prog = parse_check(text)
    for pose in prog.poses:
        names = [t.servo for t in pose.targets]
        assert names == sorted(names, key=[s.name for s in prog.servos].index)
        for t in pose.targets:
            assert 0 <= t.n <= 250
