"""The background's stretches measured in ucsim, beside the parts of the budget that charge them.

    .venv/bin/python benchmarks/background.py            # the goal program at 12 MHz, 6.985 ms
    .venv/bin/python benchmarks/background.py --period 6727

The program is `engine_terms.goal_source` (24 servos over the full range, an eased move and a
linear one), built with rises among falls at the given period and run in ucsim over every move
instance once and 10 frames more. Probes (ucsim breakpoints, `servoc.sim.run`) mark, for every
port, where frame_io starts its sort (`fs`), where the sort is done and the wait for the handler
begins (`fi`), where the port's items start once the wait is over (`ft`), where frame_io returns
(`fi_done`), and every run of the edge handler (its vector's second instruction and its RETI).
Each stretch of the background is then measured twice: its wall time, and that time less the
handler's runs within it (the background's own cycles). Printed, per part, the most over all
frames, beside what the budget charges for it (`costs.Budget`, read from the generated code):

- W: from frame_io's return to its next call;
- each port's sort (`fs` to `fi`) and its items (`ft` to the next port's `fs`, or the return);
- the work after the last sort: from the end of the wait before the last port's items to the
  end of the first port's items in the next frame, wall time and the handler's runs in it,
  beside the budget's term for it from its start: the last port's items, W, the first port's
  sort and items, and the handler's loads of the last two ports in it; and the same to where
  the first port's header is written (the loop of its items, `fe`: all its handover reads),
  its items charged up to there (`Budget.head`). The first must end ENTRY before that port's
  first edge, the second ENTRY before its rise (`costs._frame_cycles`).

A run of the handler is measured from its vector's call: the cycles before it, in which the
background's instruction under way ends (1 or 2 in ucsim), are the background's. The budget
charges an entry from the timer's overflow (`costs.ENTRY`, the same whatever the latency: the
handler pads itself to it) and the longest exit.
"""

from __future__ import annotations

import argparse
import bisect
import re
import sys

from budget import build_unchecked
from engine_terms import goal_source
from servoc import api, costs, sim
from servoc.observe import listing_lines

_LABEL = re.compile(r"^([A-Za-z_]\w*)::?")
VEC, RET = 1000, 1001     # the probes' tags for the handler's runs
TIMER0 = 0x000B             # the Timer0 vector


def addresses(listing: str) -> tuple[dict[str, int], list[int], int]:
    """Each label's code address, the addresses of the RETI instructions, and the address of the
    Timer0 vector's second instruction (a probe at the vector itself is not hit at every entry
    in ucsim), from a listing (`servoc.observe.listing_lines`)."""
    labels, retis, code = {}, [], []
    for addr, text, raw in listing_lines(listing):
        if addr is None:
            continue
        m = _LABEL.match(text)
        if m:
            labels[m.group(1)] = addr
            text = text[m.end():].strip()
        if text.upper() == "RETI":
            retis.append(addr)
        if raw:
            code.append(addr)
    return labels, retis, min(a for a in code if a > TIMER0)


def measure(period: int, text: str | None = None) -> dict:
    """The parts at `period` (us) of `text` (a program on three ports, with `frame {period}us`;
    default: the goal program)."""
    text = goal_source("", period) if text is None else text
    plan, fw = build_unchecked(text, "goal", {"stagger": True, "stepping": False})
    unit = fw.unit
    labels, retis, vector_next = addresses(fw.image.listing)
    ports = plan.ports
    header = next(name for name in api.codegen.items_loop(ports[0]) if name in labels)
    names = [f"{k}{p}" for p in ports for k in ("fs", "fi", "ft")] + ["fi_done", header]
    points = {labels[n]: n for n in names}          # fs of the first port is frame_io itself
    probes = [(a, i, ()) for i, a in enumerate(points)] + [(vector_next, VEC, ())] + [(a, RET, ()) for a in retis]
    tag = {i: n for i, n in enumerate(points.values())}
    frames = sum(m.frames for m in plan.moves) + 10
    trace = sim.run(fw.hex_text, api.cycles_needed(plan, frames), probes=probes,
                    xtal_hz=plan.program.target.clock_hz)

    runs, begin = [], None            # the handler's runs: from its vector's LCALL to the end of RETI
    for p in trace.probes:
        if p.tag == VEC:
            begin = p.cycle - 4       # the vector's LCALL (2) and its first instruction, PUSH PSW (2)
        elif p.tag == RET and begin is not None:
            runs.append((begin, p.cycle + 2))
            begin = None
    starts = [a for a, _ in runs]
    longest_run = max(b - a for a, b in runs)

    def handler_in(t0: int, t1: int) -> int:
        total, i = 0, bisect.bisect_left(starts, t0 - longest_run)
        while i < len(runs) and runs[i][0] < t1:
            a, b = runs[i]
            total += max(0, min(b, t1) - max(a, t0))
            i += 1
        return total

    calls, cur = [], None
    for p in trace.probes:
        if p.tag in (VEC, RET):
            continue
        n = tag[p.tag]
        if n == f"fs{ports[0]}":
            cur = {n: p.cycle}
            calls.append(cur)
        elif cur is not None and n not in cur:
            cur[n] = p.cycle          # a wait loop's label: its first pass
    first, last = ports[0], ports[-1]
    parts: dict[str, int] = {"W": 0, "chain wall": 0, "chain handler": 0, "header wall": 0, "header handler": 0}
    for p in ports:
        parts[f"sort P{p}"] = parts[f"items P{p}"] = 0
    for a, b in zip(calls[1:], calls[2:]):
        if "fi_done" not in a or f"ft{first}" not in b or f"fs{ports[1]}" not in b or header not in b:
            continue
        pure = lambda t0, t1: t1 - t0 - handler_in(t0, t1)     # noqa: E731
        parts["W"] = max(parts["W"], pure(a["fi_done"], b[f"fs{first}"]))
        for k, p in enumerate(ports):
            end = a[f"fs{ports[k + 1]}"] if k + 1 < len(ports) else a["fi_done"]
            parts[f"sort P{p}"] = max(parts[f"sort P{p}"], pure(a[f"fs{p}"], a[f"fi{p}"]))
            parts[f"items P{p}"] = max(parts[f"items P{p}"], pure(a[f"ft{p}"], end))
        t0, t1 = a[f"ft{last}"], b[f"fs{ports[1]}"]
        if t1 - t0 > parts["chain wall"]:
            parts["chain wall"], parts["chain handler"] = t1 - t0, handler_in(t0, t1)
        if b[header] - t0 > parts["header wall"]:
            parts["header wall"], parts["header handler"] = b[header] - t0, handler_in(t0, b[header])

    b = unit.budget
    target = unit.target
    m = len(ports)
    load = [costs.handler_load(r, f) for r, f in zip(b.rises, b.falls)]
    # the work after the last sort from its start: the last port's items, W, the first port's sort
    # and items, the handler's loads in it, the last two ports' falls for their worst frame together
    # (costs._frame_cycles)
    together = sum(b.falls[-2:]) - costs.last_two_falls(b)
    chain = (b.items[-1] + b.work + b.sorts[0] + load[-1]
             + load[-2] - costs.rise_edge(b, m - 2) + costs.ENTRY - together)
    charged = {"W": b.work, "chain wall": chain, "header wall": chain - b.items[0] + b.head}
    for k, p in enumerate(ports):
        charged[f"sort P{p}"] = b.sorts[k] - b.items[k]
        charged[f"items P{p}"] = b.items[k]
    return {"period_us": period, "reported_us": unit.min_period_us, "parts": parts, "charged": charged}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--period", type=int, default=None, help="the period in us (default: the one servoc reports)")
    args = ap.parse_args(argv)
    period = args.period
    if period is None:
        plan, fw = build_unchecked(goal_source(""), "goal", {"stagger": True, "stepping": False})
        period = fw.unit.min_period_us
    r = measure(period)
    print(f"goal program at 12 MHz, rises among falls, P = {r['period_us']} us (reported {r['reported_us']} us)")
    print("| part | the budget charges (cycles) | the most measured in ucsim (cycles) |")
    print("|---|---|---|")
    parts, charged = r["parts"], r["charged"]
    for name, cycles in charged.items():
        shown = parts[name]
        if name in ("chain wall", "header wall"):
            what = name.split()[0]
            name = {"chain": "the work after the last sort: handover to the first port's items done (wall)",
                    "header": "the same, to the first port's header written (wall)"}[what]
            shown = f"{shown} (the handler's runs in it: {parts[what + ' handler']})"
        print(f"| {name} | {cycles} | {shown} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
