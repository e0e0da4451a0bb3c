"""Prototype: Timer0-interrupt edge engine, one port P1, 12 MHz, fixed N, in ucsim."""
import sys
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
from servoc import toolchain, sim

S = 29          # sled NOPs per kind
G = int(sys.argv[1]) if len(sys.argv) > 1 else 100   # gaps >= G: a new interrupt
HOLD = int(sys.argv[2]) if len(sys.argv) > 2 else 0   # background holds EA off this many NOP cycles
STOP = int(sys.argv[3]) if len(sys.argv) > 3 else 9
E_EXIT = 12
P = 3000
NS = [0, 1, 2, 10, 11, 100, 101, 250]

def width(n): return 500 + 8 * n

# code layout of the window
kinds = ["fall", "rise"]
code_kind = {"fall": "ANL", "rise": "ORL"}
STEP_BYTES = 1 + 1 + 2 + 1 + 1 + 1
offs = {}
o = 0
for k in kinds:
    offs[k] = o          # sled start; entry for sled length s is offs[k] + S - s
    o += S + STEP_BYTES
offs["exit"] = o
o += 28
offs["exitf"] = o

def step(kind, gap, mask):
    s = gap - 7
    assert 0 <= s <= S, (kind, gap)
    return [offs[kind] + S - s, mask]

def schedule():
    ev = [(0, "rise", 0xFF)]
    byn = {}
    for b, n in enumerate(NS):
        byn.setdefault(width(n), 0)
        byn[width(n)] |= 1 << b
    for t in sorted(byn):
        ev.append((t, "fall", 0xFF & ~byn[t]))
    out = []
    prev_t = None
    cstart = 0
    for t, kind, mask in ev:
        if prev_t is None:
            out += step(kind, 7, mask)      # cluster start: no sled (entry fixed)
        else:
            gap = t - prev_t
            if gap < G:
                while gap - 7 > S:
                    g1 = min(S + 7, gap - 7)
                    out += step("fall", g1, 0xFF)
                    gap -= g1
                out += step(kind, gap, mask)
            else:
                rl = (65536 - (t - cstart) + STOP) & 0xFFFF
                cstart = t
                out += [offs["exit"], rl & 0xFF, rl >> 8]
                out += step(kind, 7, mask)
        prev_t = t
    rl = (65536 - (P - cstart) + STOP) & 0xFFFF
    out += [offs["exitf"], rl & 0xFF, rl >> 8]
    return out

sched = schedule()
BUF = 0x40
hold = ""
if HOLD:
    hold = "        CLR EA\n" + "        NOP\n" * HOLD + "        SETB EA\n"

def sled(kind):
    return "        NOP\n" * S + f"""        MOV A, @R0
        INC R0
        {code_kind[kind]} P1, A
        MOV A, @R0
        INC R0
        JMP @A+DPTR
"""

NOP4="        NOP\n"*4
NOP8="        NOP\n"*8
NOP16="        NOP\n"*16
asm = f"""        .module proto
        .area CSEG (ABS,CODE)
        .org 0x0000
        ANL P1, #0x00
        LJMP start
        .org 0x000B
        PUSH PSW
        PUSH ACC
        LJMP t0isr
        .org 0x0030
start:  MOV SP, #0xC0
        MOV DPTR, #sched
        MOV R0, #{BUF}
        MOV R2, #{len(sched)}
cp:     CLR A
        MOVC A, @A+DPTR
        MOV @R0, A
        INC DPTR
        INC R0
        DJNZ R2, cp
        MOV 0x08, #{BUF}       ; bank-1 R0
        MOV 0x09, #{BUF}       ; bank-1 R1: buffer start
        MOV TMOD, #0x01
        MOV TL0, #0xF0
        MOV TH0, #0xFF
        SETB TR0
        SETB ET0
        SETB EA
bg:     MOV A, #37
        MOV B, #5
        MUL AB
        MOV R2, A
        DIV AB
        INC DPTR
        NOP
        MOV R3, #3
d:      DJNZ R3, d
{hold}        MOV A, R2
        CJNE A, #0x55, bg
        SJMP bg

t0isr:  MOV A, TL0
        JB ACC.0, c0
        NOP
c0:     JB ACC.1, c1
        NOP
        NOP
c1:     JB ACC.2, c2
{NOP4}c2:     JB ACC.3, c3
{NOP8}c3:     JB ACC.4, c4
{NOP16}c4:     MOV PSW, #0x08
        PUSH DPL
        PUSH DPH
        MOV DPTR, #win
        MOV A, @R0
        INC R0
        JMP @A+DPTR

        .org 0x0200
win:
{sled("fall")}{sled("rise")}exit:   CLR TR0
        MOV A, TL0
        ADD A, @R0
        MOV TL0, A
        INC R0
        MOV A, TH0
        ADDC A, @R0
        MOV TH0, A
        INC R0
        SETB TR0
        POP DPH
        POP DPL
        POP ACC
        POP PSW
        RETI
        .org 0x0200 + {offs["exitf"]}
exitf:  CLR TR0
        MOV A, TL0
        ADD A, @R0
        MOV TL0, A
        INC R0
        MOV A, TH0
        ADDC A, @R0
        MOV TH0, A
        INC R0
        SETB TR0
        MOV A, R1
        MOV R0, A
        POP DPH
        POP DPL
        POP ACC
        POP PSW
        RETI
sched:  .db {", ".join(str(b) for b in sched)}
"""
img = toolchain.assemble(asm, "proto")
assert img.symbols.get("exit", None) is None or True
tr = sim.run(img.hex_text, 40000, ports=(1,))
ws = {w: width(n) for w, n in zip(range(8), NS)}
rises = None
errs = []
for b, n in enumerate(NS):
    ps = tr.pulses(1, b)
    if b == 0:
        rises = [r for r, _ in ps]
    errs.append(sorted({w - width(n) for _, w in ps[1:]}))
print("sched bytes", len(sched), "G", G, "HOLD", HOLD)
print("rise diffs", sorted({b - a for a, b in zip(rises[1:], rises[2:])}))
print("width errors per line", errs)
