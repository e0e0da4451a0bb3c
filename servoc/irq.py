"""The interrupt frame engine: ports and target -> the edge handler's constants.

Every edge comes from the Timer0 handler (firmware_templates/irq.asm.j2): it
pads its entry to a fixed point with the TL0 it reads, and chains the
overflows by adding to the running timer, so each edge lands on its exact
cycle whatever the entry latency. The background sorts each port's N into
one buffer (frame_irq.asm.j2) between the previous port's rise and its own.
"""

from __future__ import annotations

from dataclasses import dataclass

from .target import Target

WINDOW_BITS = 5          # the entry pads over 2^5 latencies
STOP = 7                 # cycles Timer0 stands still in the exit's add
STEP = 7                 # the shortest step between two edges of a cluster
# Overflow to the edge: vector (PUSH PSW, PUSH ACC, LJMP: 6), MOV A,TL0 (1), the pad
# cascade (2 per bit + the NOPs), MOV PSW (2), PUSH DPL/DPH (4), MOV DPL/DPH (4),
# MOV A,R6 (1), JMP (2), the edge's MOV, INC/NOP, XRL (3). Measured: 57.
ENTRY = 57
# The last edge of a cluster to the end of its RETI, through the longest exit
# (step read and jump 4, LJMP 2, exit_far 32, MOV R6 1, the add 8, POPs 8, RETI 2).
EXIT = 57


@dataclass(frozen=True)
class Port:
    port: int
    pins: tuple[tuple[int, int, str], ...]   # (bit, CUR address, name), bit order


@dataclass(frozen=True)
class IrqEngine:
    target: Target
    ports: tuple[Port, ...]
    period: int               # frame period in machine cycles

    @property
    def split(self) -> int:
        """Edges this many cycles apart or more are separate handler entries."""
        return ENTRY + EXIT + 1

    @property
    def sled(self) -> int:
        return self.split - 1 - STEP

    @property
    def port_span(self) -> int:
        """Rise to the next port's rise: the longest pulse, then a new entry."""
        return self.target.width_cycles(250) + self.split

    def rise(self, k: int) -> int:
        return k * self.port_span

    def context(self) -> dict:
        from .codegen import SORTING_NETWORKS
        ports = []
        for k, p in enumerate(self.ports):
            last = k == len(self.ports) - 1
            ports.append({
                "port": p.port, "s": len(p.pins), "win": f"win_p{p.port}", "last": last,
                "next_port": self.ports[0 if last else k + 1].port,
                "next_win": f"win_p{self.ports[0 if last else k + 1].port}",
                "rnext": (self.period if last else self.rise(k + 1)) - self.rise(k),
                "pins": [{"i": i, "bit": b, "bit_mask": 1 << b, "cur": cur, "name": name}
                         for i, (b, cur, name) in enumerate(p.pins)],
            })
        sizes = sorted({len(p.pins) for p in self.ports})
        if self.target.grid:
            near_dn = -(-self.split // 8)
            ctime = ["MOV     B, #8                   ; t = C(N) = 500 + 8 N in B:A", "MUL     AB",
                     f"ADD     A, #<{self.target.width_cycles(0)}", "XCH     A, B",
                     f"ADDC    A, #>{self.target.width_cycles(0)}", "XCH     A, B"]
        else:
            div = self.target.div_cycles
            near_dn = next(d for d in range(1, 256) if int(d * div) >= self.split)
            ctime = ["MOV     DPTR, #ctab             ; t = C(N) from the table, in B:A", "MOV     B, A",
                     "MOVC    A, @A+DPTR", "XCH     A, B", "INC     DPH", "MOVC    A, @A+DPTR", "XCH     A, B"]
        return {
            "ctime": "\n".join("        " + line for line in ctime), "near_dn": near_dn,
            "most": max(sizes),
            "window_bits": WINDOW_BITS, "stop": STOP, "entry": ENTRY, "split": self.split,
            "sled": self.sled, "fall_off": self.sled, "exit_off": self.sled + 7,
            "exitn_off": self.sled + 10, "rise_off": self.sled + 13,
            "grid": self.target.grid, "c0": self.target.width_cycles(0),
            "ports": ports,
            "sorts": [{"s": s, "network": SORTING_NETWORKS[s]} for s in sizes],
        }
