"""Which servos a move record names (wcet.Names): a path that reads a record is charged for the
servos that record names, not for every servo, and the firmware holds the shorter period that gives."""

import pytest

from conftest import assert_exact, build_text, front_end_text
from servoc import codegen, wcet

# After a frame: the record's flags (1), MOVB cleared (2), RMASK written (1: the fork); pin 0's
# set-up (JNB 2, MUL 4, its MOVB bit written 2) and pin 1's (JNB 2, MUL 4); then each pin's step
# where its MOVB bit is set (JNB 2, MUL 4), SJMP 2 and the LCALL frame_io 2.
NAMED = """
main:   LCALL   frame_io
        MOV     FLAGS, A
        MOV     MOVB+1, #0
        MOV     RMASK+1, A
        JNB     0x50, p0
        MUL     AB
        MOV     0x20, C
p0:     JNB     0x51, p1
        MUL     AB
p1:     JNB     0x20, s0
        MUL     AB
s0:     JNB     0x21, s1
        MUL     AB
s1:     SJMP    main
frame_io:
        RET
"""
BITS = ("0x50", "0x51") + (None,) * 6


def _names(*sets: int) -> wcet.Names:
    return wcet.Names(first="RMASK+1", rmask=(("RMASK+1", BITS),),
                      movb=(("MOVB+1", ("0x20", "0x21") + (None,) * 6),), sets=tuple((s,) for s in sets),
                      flags=(frozenset(),) * len(sets))


def test_a_record_is_charged_for_the_servos_it_names():
    """Pin 0 named: 4 + 8 (its set-up) + 2 (pin 1 skipped) + 6 (its step: its MOVB bit written, so
    not known) + 2 (pin 1's MOVB bit cleared and never set) + 4 = 26. Both named: 4 + 8 + 6 + 6 + 2
    + 4 = 30 (pin 1's step is still skipped: nothing set its bit). Without the fact every test goes
    both ways: 34."""
    assert wcet.Code(NAMED).between_frames()[0] == 34
    code = wcet.Code(NAMED, "FLAGS", frozenset(), frozenset(), None, _names(1, 3))
    by = code.by_record()
    assert by == {frozenset({wcet.WRITTEN, (wcet.REC, 0)}): 26, frozenset({wcet.WRITTEN, (wcet.REC, 1)}): 30}
    assert code.between_frames()[0] == 30
    assert wcet.Code(NAMED, "FLAGS", frozenset(), frozenset(), None, _names(1)).between_frames()[0] == 26


def test_a_bit_written_from_a_register_is_no_longer_known():
    """MOVB written whole from a register (not an immediate): every MOVB test goes both ways again."""
    text = NAMED.replace("MOV     MOVB+1, #0", "MOV     MOVB+1, R6")
    code = wcet.Code(text, "FLAGS", frozenset(), frozenset(), None, _names(1))
    assert code.between_frames()[0] == 26 + 4 + 0 and code.by_record()[frozenset({wcet.WRITTEN, (wcet.REC, 0)})] == 30


BIPED_11 = "target at89c52 clock 11.0592MHz\n"


def _biped(head: str) -> str:
    from pathlib import Path
    text = (Path(__file__).resolve().parent.parent / "examples" / "biped.servo").read_text()
    return head + "\n".join(line for line in text.splitlines() if not line.startswith(("target ", "frame ")))


def _min_without_names(text: str, monkeypatch) -> int:
    monkeypatch.setattr(codegen, "record_names", lambda *args: (None, {}))
    fe, _ = front_end_text(text)
    monkeypatch.undo()
    return fe.plan.min_period_us


def test_the_biped_at_11_0592_mhz_holds_the_shorter_period_names_give(monkeypatch):
    """The biped's records mostly name a few of its 8 servos: its one port's frame that starts a
    move is charged for those, so the reported minimum is at least 50 us shorter than with every
    servo charged, and the firmware verifies exactly there through the whole program (every move's
    first frame), with 1 us less refused."""
    before = _min_without_names(_biped(BIPED_11), monkeypatch)
    fe, diags = front_end_text(_biped(BIPED_11))
    plan = fe.plan
    assert plan is not None and not plan.compact, diags
    assert plan.min_period_us <= before - 50
    built = build_text(_biped(BIPED_11 + f"frame {plan.min_period_us}us\n"))
    assert built.plan.period_us == built.plan.min_period_us == plan.min_period_us
    assert_exact(built.verify(), "the biped at its minimum")
    _, diags = front_end_text(_biped(BIPED_11 + f"frame {plan.min_period_us - 1}us\n"))
    assert "period-too-short" in [d.code for d in diags]


def _scattered(period: int | None) -> str:
    """24 servos on three ports; poses that name scattered few (2, 3, 5 and 8 servos), some eased,
    some linear, in a loop: records that name different servos on each port, none all of them."""
    text = "target at89c52 clock 11.0592MHz\n" + (f"frame {period}us\n" if period else "")
    text += "".join(f"servo s{i} = P{i // 8}.{i % 8}\n" for i in range(24))
    picks = {"eight": (0, 3, 7, 9, 12, 17, 20, 22), "two": (3, 17), "three": (0, 9, 22), "five": (1, 5, 12, 18, 23)}
    for k, (pose_name, pins) in enumerate(picks.items()):
        text += f"pose {pose_name} {{ " + ", ".join(f"s{p}: {240 - 31 * k - 7 * j}" for j, p in enumerate(pins)) + " }\n"
    text += ("main {\n  move eight in 900ms\n  loop {\n    move two in 900ms ease in-out\n    move three in 600ms\n"
             "    move five in 700ms ease in\n    move eight in 800ms\n  }\n}\n")
    return text


def test_records_that_name_scattered_servos_on_three_ports_hold_their_minimum(monkeypatch):
    """Three ports, records naming 2, 3, 5 and 8 of the 24 servos, eased and linear: the work
    charged is less than with every servo named (by 15 cycles for each of the 16 servos the
    largest record does not name, at least), and at the reported minimum every pulse is exact in ucsim
    through two passes of the loop (every move's first frame twice), with 1 us less refused."""
    fe, diags = front_end_text(_scattered(None))
    plan = fe.plan
    assert plan is not None and not [d for d in diags if d.is_error], diags
    unit = codegen.generate(plan)
    monkeypatch.setattr(codegen, "record_names", lambda *args: (None, {}))
    assert codegen.generate(plan).budget.work >= unit.budget.work + 15 * (24 - 8)
    monkeypatch.undo()
    built = build_text(_scattered(plan.min_period_us))
    assert built.plan.period_us == built.plan.min_period_us == plan.min_period_us
    assert_exact(built.verify(2 * sum(m.frames for m in built.plan.moves) + 10), "scattered records at the minimum")
    _, diags = front_end_text(_scattered(plan.min_period_us - 1))
    assert "period-too-short" in [d.code for d in diags]


STILL = ("servo x = P1.0\nservo y = P1.1\nservo z = P1.2\nservo w = P1.3\n"
         "pose a { x: 10, y: 20, z: 30, w: 40 }\npose b { x: 10, y: 100, z: 30, w: 40 }\n"
         "pose c { x: 10, y: 200, z: 30, w: 40 }\npose m { x: 90, y: 30 }\n"
         "main {\n  move a in 300ms\n  loop {\n    move b in 400ms\n    move c in 400ms\n  }\n}\n")


def test_a_record_leaves_out_the_servos_at_its_pose_wherever_the_move_starts():
    """`move b` starts after `move a` and after `move c`: x, z and w are at b's N at both, so b's
    record, the first of the loop's list, names y only; `move a` starts from no target at all and
    names every servo. After a select's meanwhile body cut by a press, where a line can
    be anywhere between the N it passes, a move leaves none out."""
    from servoc.flow import at_start
    from servoc.steps import MoveStep, steps
    fe, diags = front_end_text(STILL)
    plan = fe.plan
    moves = {st.pose: st for st in steps(plan) if isinstance(st, MoveStep)}
    start = at_start(plan)
    assert start[id(moves["b"])].still == start[id(moves["c"])].still == {0, 2, 3} and not start[id(moves["a"])].still
    assert start[id(moves["a"])].off == {0, 1, 2, 3} and start[id(moves["b"])].on == {0, 1, 2, 3}
    unit = codegen.generate(plan)
    assert unit.text.count("3 already there") == 2        # b (by at_start) and c (by the record before)
    built = build_text(STILL)
    assert_exact(built.verify(4 * sum(m.frames for m in built.plan.moves)), "records without the servos already there")
    cut = STILL.replace("main {\n  move a in 300ms\n  loop {", "input k = P3.2\nmain {\n  move a in 300ms\n  loop {\n"
                        "    select { on press k { move m in 300ms } meanwhile { loop { move c in 400ms; move b in 400ms } } }")
    fe, diags = front_end_text(cut)
    plan = fe.plan
    assert plan is not None, diags
    moves = [st for st in steps(plan) if isinstance(st, MoveStep) and st.pose == "m"]
    assert moves and not at_start(plan)[id(moves[0])].still


# After a frame: flags (1), MOVB cleared (2), RMASK written (1: the fork), pin 0 named (JNB 2); its
# ACT bit copied to the carry (1), the set-up called (2): a servo with a target moves (JC 2, MUL 4
# x 2, RET 2), one without is set at once (JC 2, RET 2); SETB 1, SJMP 2, LCALL frame_io 2.
ACTED = """
main:   LCALL   frame_io
        MOV     FLAGS, A
        MOV     MOVB+1, #0
        MOV     RMASK+1, A
        JNB     0x50, p0
        MOV     C, 0x08
        LCALL   setup
        SETB    0x08
p0:     SJMP    main
setup:  JC      has
        RET
has:    MUL     AB
        MUL     AB
        RET
frame_io:
        RET
"""


def _acted(on: int, off: int) -> wcet.Names:
    return wcet.Names(first="RMASK+1", rmask=(("RMASK+1", BITS),), movb=(("MOVB+1", ("0x20",) + (None,) * 7),),
                      sets=((1,),), flags=(frozenset(),), act=(("ACT+1", ("0x08",) + (None,) * 7),),
                      acts=(((on, off),),))


def test_a_servo_without_a_target_at_every_start_is_charged_as_set_at_once():
    """The record's move starts where pin 0 has no target (its ACT bit clear): 18 cycles; where it
    has one: 26; where it can be either: 26. An instruction that may write the carry between the
    copy and the test (ADD, 1 cycle) leaves the carry unknown: 27 both ways."""
    def cycles(text: str, on: int, off: int) -> int:
        return wcet.Code(text, "FLAGS", frozenset(), frozenset(), None, _acted(on, off)).between_frames()[0]
    assert (cycles(ACTED, 0, 1), cycles(ACTED, 1, 0), cycles(ACTED, 0, 0)) == (18, 26, 26)
    added = ACTED.replace("setup:  JC      has", "setup:  ADD     A, #1\n        JC      has")
    assert cycles(added, 0, 1) == cycles(added, 1, 0) == 27
    kept = ACTED.replace("setup:  JC      has", "setup:  MOV     A, R0\n        INC     DPTR\n        JC      has")
    assert cycles(kept, 0, 1) == 18 + 1 + 2
