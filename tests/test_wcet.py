"""servoc.wcet: cycle counts read from the generated assembly.

The cycle table must agree with the assembler's own (sdas8051 prints each
instruction's clocks in its listing); the path analysis must add up, take
the costlier branch, follow calls and returns, and refuse a loop that never
reaches a frame.
"""

from pathlib import Path

import pytest

from conftest import build_text, parse_listing, pose, servo_decls
from servoc import codegen, costs, wcet


@pytest.mark.toolchain
def test_cycle_table_matches_the_assembler_on_generated_firmware():
    pins = [(p, b) for p in range(3) for b in range(8)]
    names = [f"s{p}_{b}" for p, b in pins]
    text = (servo_decls(pins) + pose("a", {n: 10 for n in names}) + pose("b", {n: 200 for n in names})
            + pose("c", {names[0]: 40})
            + "sequence s { move b in 900ms ease in-out; hold 40ms }\n"
            + "main { move a in 1s; repeat 3 { play s; move c; move a } }\n")
    built = build_text(text)
    listed, _ = parse_listing(built.firmware.image.listing)
    ours = wcet.Code(built.firmware.unit.text).instrs
    assert len(ours) == len(listed) > 500
    wrong = [(o.op, o.args, o.cycles, l.cycles) for o, l in zip(ours, listed) if (o.op, o.cycles) != (l.op, l.cycles)]
    assert not wrong, wrong[:10]


def test_cycles_of_known_instructions():
    assert wcet.cycles_of("MOV", ("A", "R0")) == 1
    assert wcet.cycles_of("MOV", ("0x30", "0x31")) == 2
    assert wcet.cycles_of("MOV", ("R1", "0x31")) == 2
    assert wcet.cycles_of("MOV", ("0x20", "C")) == 2
    assert wcet.cycles_of("ANL", ("P1", "#0xFE")) == 2
    assert wcet.cycles_of("ANL", ("P1", "A")) == 1
    assert wcet.cycles_of("MUL", ("AB",)) == 4
    assert wcet.cycles_of("INC", ("DPTR",)) == 2
    with pytest.raises(wcet.WcetError):
        wcet.cycles_of("FOO", ())


SMALL = """
main:
        MOV     A, #1           ; 1
        LCALL   frame_io        ; 2
        JZ      skip            ; 2
        MUL     AB              ; 4
skip:   LCALL   work            ; 2
        SJMP    main            ; 2
work:   NOP                     ; 1
        RET                     ; 2
frame_io:
        RET
"""


def test_longest_path_takes_the_costlier_branch_and_follows_calls():
    code = wcet.Code(SMALL)
    cycles, start = code.between_frames()
    # behind LCALL frame_io: JZ 2 + MUL 4 + LCALL 2 + NOP 1 + RET 2 + SJMP 2 + MOV 1 + LCALL frame_io 2
    assert cycles == 16
    assert code.instrs[start].op == "JZ"


def test_a_loop_that_reaches_no_frame_is_an_error():
    looping = SMALL.replace("SJMP    main", "SJMP    skip")
    with pytest.raises(wcet.WcetError, match="reaches no frame"):
        wcet.Code(looping).between_frames()


def test_longest_path_between_labels():
    code = wcet.Code(SMALL)
    # from skip: LCALL work (2, then NOP 1 + RET 2) + SJMP 2, stopping at the label main
    assert code.longest("skip", {"main"}) == 7
    assert code.longest("work", set()) == 3
    with pytest.raises(wcet.WcetError, match="loop"):
        code.longest("skip", set())
    with pytest.raises(wcet.WcetError):
        code.longest("nowhere", set())


def test_counted_pad_loops_are_bounded():
    padded = SMALL.replace("work:   NOP", "work:   MOV     R7, #5\n        DJNZ    R7, .")
    # MOV 1 + DJNZ 2 x 5 instead of NOP 1
    assert wcet.Code(padded).between_frames()[0] == 16 - 1 + 1 + 10


def test_counted_loops_take_k_passes_of_the_longest_pass():
    """`MOV Rn,#k` right before the loop's label, `DJNZ Rn,label` at its end: k passes, each as
    long as the costlier way through it (calls followed)."""
    looped = SMALL.replace("work:   NOP", "work:   MOV     R3, #6\nwl:     JZ      wn\n        MUL     AB\n"
                                          "wn:     LCALL   leaf\n        DJNZ    R3, wl")
    looped += "leaf:   NOP\n        RET\n"
    # MOV 1 + 6 x (JZ 2 + MUL 4 + LCALL 2 + NOP 1 + RET 2 + DJNZ 2) instead of NOP 1
    assert wcet.Code(looped).between_frames()[0] == 16 - 1 + 1 + 6 * 13
    assert wcet.Code(looped).longest("work", set()) == 1 + 6 * 13 + 2


@pytest.mark.parametrize("inside,what", [("MOV     R3, A", "R3"), ("LCALL   frame_io", "a frame inside"),
                                         ("CLR     KIND", "KIND"), ("MOV     FLAGS, A", "FLAGS")])
def test_a_counted_loop_that_could_run_on_is_an_error(inside, what):
    """Its counter written in a pass, a frame in it, or the record's flags written: not bounded."""
    looped = SMALL.replace("work:   NOP", f"work:   MOV     R3, #6\nwl:     NOP\n        {inside}\n        DJNZ    R3, wl")
    with pytest.raises(wcet.WcetError, match=what):
        wcet.Code(looped, "FLAGS", frozenset({"KIND"})).between_frames()


def test_generated_code_budget_names_its_start():
    from servoc.api import plan as make_plan
    from conftest import front_end_text
    fe, _ = front_end_text(servo_decls([(1, 0), (1, 1)]) + pose("a", {"s1_0": 1, "s1_1": 2})
                           + pose("b", {"s1_0": 100, "s1_1": 3}) + "main { loop { move a in 1s; move b in 1s } }\n")
    unit = codegen.generate(fe.plan)
    b = unit.budget
    assert b.work and b.lines == (2,) and len(b.sorts) == len(b.rises) == 1
    # one port: the pulses alone, or the sort, the work and the handler's load in one frame
    load = b.rises[0] + (costs.SPLIT - 1) * 2
    assert b.spans == (costs.port_span(fe.plan.program.target, 100, b.steps),)     # its lines reach N 100 at the most
    assert unit.min_period_us == max(b.spans[0], b.sorts[0] + b.work + load)
    assert unit.work_from
    assert make_plan(fe.plan.program, None).min_period_us == unit.min_period_us


FLAGGED = """
main:
        LCALL   frame_io        ; 2
        MOV     FLAGS, A        ; 1  a record's flags
        JB      KIND, heavy     ; 2
        MUL     AB              ; 4  light records: 4 here ...
        SJMP    two             ; 2
heavy:  NOP                     ; 1
two:    JNB     KIND, cheap     ; 2
        MUL     AB              ; 4  ... heavy ones: 4 here
        MUL     AB              ; 4
        MUL     AB              ; 4
cheap:  SJMP    main            ; 2
frame_io:
        RET
"""


def test_a_flag_bit_tested_twice_goes_the_same_way_both_times():
    """A path that found the bit clear at the first test finds it clear at the second: light
    records 1 + 2 + 4 + 2 + 2 + 2, heavy 1 + 2 + 1 + 2 + 12 + 2, each with the LCALL frame_io (2)."""
    followed = wcet.Code(FLAGGED, "FLAGS", frozenset({"KIND"})).between_frames()[0]
    assert followed == max(1 + 2 + 4 + 2 + 2 + 2, 1 + 2 + 1 + 2 + 12 + 2) + 2
    # not followed, both costlier ways are counted on one path
    assert wcet.Code(FLAGGED).between_frames()[0] == 1 + 2 + 4 + 2 + 2 + 12 + 2 + 2
    # the byte written again in between: the second test goes both ways
    rewritten = FLAGGED.replace("two:    JNB", "two:    MOV     FLAGS, A\n        JNB")
    assert wcet.Code(rewritten, "FLAGS", frozenset({"KIND"})).between_frames()[0] == 1 + 2 + 4 + 2 + 1 + 2 + 12 + 2 + 2


# `fr` takes a frame and then, while PLAY is set (called from `seq`), reads (MUL x 3, then a record's
# flag byte written whole, then one more MUL unless PLAY is still set); main calls it with PLAY clear
# and has heavy work (MUL x 5) behind that call.
PLAYED = """
main:   LCALL   fr              ; 2
        MUL     AB              ; 4 x 5
        MUL     AB
        MUL     AB
        MUL     AB
        MUL     AB
        LCALL   frame_io        ; 2
        LCALL   seq             ; 2
        SJMP    main            ; 2
seq:    SETB    PLAY            ; 1
        LCALL   fr              ; 2
        CLR     PLAY            ; 1
        LCALL   frame_io        ; 2
        RET                     ; 2
fr:     LCALL   frame_io        ; 2
        JNB     PLAY, fr_r      ; 2
        MUL     AB              ; 4 x 3
        MUL     AB
        MUL     AB
        MOV     FLAGS, A        ; 1
        JB      PLAY, fr_r      ; 2
        MUL     AB              ; 4
fr_r:   RET                     ; 2
frame_io:
        RET
"""


def test_a_state_bit_stays_known_through_the_flag_byte_and_bars_returns():
    """Behind fr's frame: with PLAY set, JNB 2 + 12 + MOV 1 + JB 2 (+ MUL 4 unless PLAY is still
    known) + RET 2; then behind main's call MUL x 5 + LCALL 2 (22), behind seq's CLR + LCALL 2 (3).
    With PLAY clear: JNB 2 + RET 2, then the same."""
    assert wcet.Code(PLAYED).between_frames()[0] == 23 + 22
    assert wcet.Code(PLAYED, "FLAGS", frozenset({"PLAY"})).between_frames()[0] == 23 + 22   # forgotten
    assert wcet.Code(PLAYED, "FLAGS", frozenset(), frozenset({"PLAY"})).between_frames()[0] == 19 + 22
    barred = wcet.Code(PLAYED, "FLAGS", frozenset(), frozenset({"PLAY"}), ("PLAY", (("main", "seq"),)))
    # PLAY set: fr returns behind seq's call only (19 + 3); PLAY clear: behind main's (4 + 22)
    assert barred.between_frames()[0] == 4 + 22


def test_same_cycles_vouches_only_for_immediates_that_no_loop_counts():
    """`wcet.same_cycles` lets code generation skip measuring the code laid out again for its
    spans: it must hold only where the cycles surely do not change."""
    text = "loop:   MOV     A, #<24445          ; a rise\n        MOV     R7, #3\n        DJNZ    R7, .\n        RET\n"
    assert wcet.same_cycles(text, text.replace("24445", "26875").replace("a rise", "another"))
    assert not wcet.same_cycles(text, text.replace("#3", "#4"))             # a pad loop's count
    assert not wcet.same_cycles(text, text.replace("MOV     A, #<", "ADD     A, #<"))
    assert not wcet.same_cycles(text, text + "        NOP\n")
    assert [i.cycles for i in wcet.Code(text).instrs] == [i.cycles for i in wcet.Code(text.replace("24445", "1")).instrs]


ONCE = """\
start:  SETB    F0
        MOV     R3, #6
ol:     JNB     F0, on
        LCALL   once
        MUL     AB
on:     NOP
        DJNZ    R3, ol
        JNB     F0, oe
        LCALL   once
oe:     RET
once:   CLR     F0
        MUL     AB
        MUL     AB
        MUL     AB
        RET
"""


def test_a_call_that_clears_the_flag_guarding_it_is_charged_once_per_loop():
    """The emit's `rins` (irq_stagger.asm.j2): a routine that starts with CLR F0, called only where
    JNB F0 falls through, with no SETB F0 in the loop, runs in one pass at most; F0 is followed
    past the loop, so the call after it is charged only where the loop made none. Passes: 5 cycles
    without the call (JNB 2, NOP 1, DJNZ 2), 26 with it (LCALL 2, the routine 15, MUL 4)."""
    code = wcet.Code(ONCE)
    in_loop = 1 + 1 + 5 * 5 + 26 + 2 + 2                  # SETB, MOV, the loop, JNB and RET after it
    after = 1 + 1 + 6 * 5 + 2 + 2 + 15 + 2                 # no call in the loop: the one after it
    assert code.longest("start", set()) == max(in_loop, after) == 57


@pytest.mark.parametrize("change,passes", [
    ("on:     NOP", "on:     SETB    F0"),                 # the flag set again in the loop
    ("ol:     JNB     F0, on", "ol:     NOP\n        NOP"),    # the call not guarded by it
])
def test_a_call_in_a_loop_is_charged_every_pass_unless_it_surely_runs_once(change, passes):
    code = wcet.Code(ONCE.replace(change, passes))
    assert code.longest("start", set()) >= 1 + 1 + 6 * 26 - 6


ITEMS = """\
start:  SETB    F0
        MOV     R7, #5
ip:     MOV     A, @R0
        INC     R0
        JNB     F0, ir
        LCALL   once
ir:     CJNE    A, #0xFF, iw
        DEC     R0
        SJMP    ix
iw:     LCALL   fall
ix:     DJNZ    R7, ip
        RET
once:   CLR     F0
        MUL     AB
        RET
fall:   MUL     AB
        MUL     AB
        RET
"""


def test_a_counted_loops_passes_are_read_with_and_without_the_calls_named():
    """The passes of stagger_emit.asm.j2's loop over a port's pairs (`codegen._unread`): the read
    and the flag's test (4 cycles), the call made once (LCALL 2, the routine 7), the end mark's
    branch (CJNE 2, DEC 1, SJMP 2) or a fall's (CJNE 2, LCALL 2, the routine 10), the DJNZ (2)."""
    code = wcet.Code(ITEMS)
    assert code.passes("ip", {"fall"}) == (5, 4 + 9 + 14 + 2, 4 + 14 + 2, 4 + 5 + 2, 4 + 9 + 5 + 2)
    assert code.passes("ip", set()) == (5, 29, 20, 20, 29)         # no call barred: the longest passes again
    assert code.longest("start", set()) == 1 + 1 + 4 * 20 + 29 + 2 == 113        # SETB, MOV, the loop, RET


def test_same_cycles_knows_a_loop_count_from_any_other_register_immediate():
    """A `MOV Rn,#k` is a count only right before `DJNZ Rn,.` or before the label of a `DJNZ Rn,label`
    (wcet's counted loops): other register immediates (a rise's time, an N compared with) may
    change, so a build laid out again for its spans is not measured twice. A byte written whole
    (`MOV direct,#k`) may not: the analysis follows what some such writes say (RMASK, MOVB)."""
    text = ("f:      MOV     R4, #7\n        MOV     R7, #5\nhead:   MOV     A, @R0\n        INC     R0\n"
            "        CJNE    A, #48, next\nnext:   DJNZ    R7, head\n        MOV     R5, #<884\n"
            "        MOV     MOVB+1, #0x03\n        RET\n")
    changed = text.replace("#7", "#9").replace("#48", "#123").replace("#<884", "#<1478")
    assert wcet.same_cycles(text, changed)
    assert wcet.Code(text).longest("f", set()) == wcet.Code(changed).longest("f", set())
    assert not wcet.same_cycles(text, text.replace("R7, #5", "R7, #6"))            # a counted loop's count
    assert not wcet.same_cycles(text, text.replace("#0x03", "#0x07"))              # a byte written whole


ENGINE = """
        LJMP    main
frame_io:
        MOV     A, #1
        LCALL   sort
        RET
sort:   NOP
{extra}        RET
engine_end:
main:
        LCALL   frame_io
        MOV     A, B
        LCALL   {call}
        SJMP    main
work:   MUL     AB
        RET
"""


def test_the_work_between_frames_is_read_without_the_engine_and_shared_by_texts_that_differ_only_there():
    """`frames_code`: the text with the engine's code (frame_io up to engine_end) left out gives the
    whole text's longest work between frames, and two texts whose engines differ share it; the
    index it gives back is the whole text's (the resume point after the engine moves with it)."""
    one, two = ENGINE.format(extra="", call="work"), ENGINE.format(extra="        NOP\n        NOP\n", call="work")
    (a, index_a), (b, index_b) = wcet.frames_code(one), wcet.frames_code(two)
    assert a is b and a.instrs is not wcet.Code(one).instrs     # one analysis, of the text without the engine
    for text, index in ((one, index_a), (two, index_b)):
        whole = wcet.Code(text)
        work, at = a.between_frames()
        assert (work, index(at)) == whole.between_frames() == (1 + 2 + 4 + 2 + 2 + 2, whole.labels["main"] + 1)


def test_the_work_between_frames_is_read_from_the_whole_text_where_the_engine_is_not_apart():
    """An engine that calls a routine outside it (its call sites are paths between frames), or code
    outside that names one of its labels (but frame_io's calls): the whole text's Code. Code that
    runs into the engine from the instruction before it: the shared analysis fails there rather
    than count what it left out, and code generation reads the whole text."""
    for apart in (ENGINE.replace("LCALL   sort", "LCALL   work", 1).format(extra="", call="work"),
                  ENGINE.format(extra="", call="sort")):
        code, index = wcet.frames_code(apart)
        assert code.instrs is wcet.Code(apart).instrs and index(5) == 5
    falls = ENGINE.replace("        LJMP    main\nframe_io:", "pre:    NOP\nframe_io:").format(extra="", call="pre")
    code, _ = wcet.frames_code(falls)
    assert code.instrs is not wcet.Code(falls).instrs
    with pytest.raises(wcet.WcetError, match="indirect jump"):
        code.between_frames()
    # MOV A,B; LCALL pre; NOP, into frame_io's body: MOV A,#1; LCALL sort (NOP; RET); RET; SJMP; LCALL frame_io
    assert wcet.Code(falls).between_frames()[0] == 1 + 2 + 1 + 1 + 2 + 1 + 2 + 2 + 2 + 2


@pytest.mark.parametrize("example", ["hexapod", "serial_arm", "ssc32_arm", "sweep_until_pressed", "biped"])
def test_every_build_reads_the_work_between_frames_of_its_whole_text(example, monkeypatch):
    """Every text code generation reads the work between frames from (each build of each period
    the period stage tries) gets from `frames_code` what its whole text gives: the cycles, where
    they start and the longest path by record; with the engine left out (none of these engines
    calls out of itself), and shared by builds."""
    seen = []
    real = wcet.frames_code

    def spy(text, *facts):
        got = real(text, *facts)
        seen.append((text, facts, got))
        return got
    monkeypatch.setattr(wcet, "frames_code", spy)
    built = build_text((Path(__file__).parent.parent / "examples" / f"{example}.servo").read_text(), f"{example}.servo")
    assert built.firmware is not None and len({text for text, _, _ in seen}) >= 2
    for text, facts, (code, index) in seen:
        whole = wcet.Code(text, *facts)
        assert code.instrs is not whole.instrs
        work, at = code.between_frames()
        assert (work, whole.label_at(index(at)), code.by_record()) == (
            *(lambda w, a: (w, whole.label_at(a)))(*whole.between_frames()), whole.by_record())
    assert len({id(code) for _, _, (code, _) in seen}) < len({text for text, _, _ in seen})


LATE_ONCE = """\
start:  SETB    F0
        MOV     R7, #5
fe1_p:  MOV     A, @R0
        INC     R0
        CJNE    A, #0xFF, iw
        JNB     F0, ie
        LCALL   once
ie:     DEC     R0
        SJMP    ix
iw:     LCALL   efall
ix:     DJNZ    R7, fe1_p
        RET
once:   CLR     F0
        MUL     AB
        MUL     AB
        MUL     AB
        RET
efall:  MUL     AB
        RET
"""


def test_passes_that_read_only_the_end_mark_are_charged_less_but_not_the_one_with_the_call_made_once():
    """`codegen._unread` on a port's loop whose call made once comes only on the end mark's path: a
    pass 4 cycles (the read and CJNE), then the end mark's 5 (JNB, DEC, SJMP) and the call's 17, or a
    fall's 8 (LCALL efall), and the DJNZ (2). With one N every pass reads the end mark, the first
    with the call: 28 + 4 x 11 between SETB, MOV and RET, which the charge gives exactly; taking the
    end mark's saving from all five passes would charge 3 cycles less than that."""
    from servoc import codegen

    code = wcet.Code(LATE_ONCE)
    assert code.passes("fe1_p", {"efall"}) == (5, 28, 14, 11, 28)
    worst = 1 + 1 + 28 + 4 * 11 + 2
    assert code.longest("start", set()) - codegen._unread(code, 1, 1) == worst == 76
    assert codegen._unread(code, 1, 6) == 0                 # five more N: every pass writes a fall
