"""Keyframes -> .servo text: channels become servos, tracks sequences, keys moves.

Input: a `Keyframes` (servoc.imports.keyframes), the pin of each channel, and
for sampled tracks the frame period they are fitted at. Output: `Imported`,
the program's text (laid out by servoc.printer, with a comment on every move
naming its source) and the import's figures.

- Positions become N by the Positions rule (widths rounded half up to the
  8 µs grid) and are written as widths on the grid; `Imported.off_grid`
  counts those that were not on it. A negative width is an `ImportError_`
  that names its key (`-1500us` is no .servo width: nothing is written).
- A keyed track (CSV): each key is one linear move that arrives at its time:
  it ends on the frame nearest that time, frames counted from the sequence's
  first (frame 0, at time 0) at the period the program declares (`frame`, the
  default of the pins in use), so no rounding piles up from key to key. The
  duration written is the source's `time - previous time` where that gives
  those frames, else the whole ms nearest it that does (a key at the time of
  the one before: `in 0ms`, one frame; a key that sets nothing: a `hold`).
- A paced track (Maestro): see `_Writer.paced`.
- A sampled track (Blender; a Bottango curve sampled at every frame): the
  first sample is a `move` without a duration, then as few linear moves as
  meet every sample within ±1 N. A run of samples i..j becomes one move when,
  for every servo, the straight line from N_i to N_j passes within 1/2 N of
  the exact source value at every sample between: the firmware's rounding of
  that line adds at most 1/2 more, so every sample is met within 1 N. Each
  servo keeps the interval of slopes that passes all the samples so far, so
  the fit is one pass over the samples (linear in frames x servos). The 1/2
  N is inclusive (and a float's error more): a servo held at a value halfway
  between two N (1200 µs, N 87.5, written 88) may stay put along a run.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from fractions import Fraction

from .. import nodes
from ..printer import format_program
from ..source import NO_SPAN
from ..units import (BASE_US, DAV_DEG, DEFAULT_T_DAV_US, DIV_US, N_MAX, frames_for, move_frames, n_to_width_us,
                     round_half_up, width_on_grid, width_to_n)
from .keyframes import ImportError_, Keyframes, Track, check_frames, decimal, identifier

MAX_MOVE_FRAMES = 65535        # the firmware's frame counters are 16 bits
_SLACK = 0.5 + 1e-9            # 1/2 N and a float's error: a tie (1200 us is N 87.5, written 88) may stay put


def default_pin(channel: int) -> str | None:
    """The spec's channel rule: 0-7 on P1.0-P1.7, 8-15 on P2.0-P2.7, 16-23 on P0.0-P0.7."""
    if 0 <= channel < 24:
        return f"P{(1, 2, 0)[channel // 8]}.{channel % 8}"
    return None


@dataclass(frozen=True)
class Imported:
    text: str                   # the .servo program
    frames_in: int              # source keyframes or samples
    moves_out: int              # moves and holds written
    deviation: int              # largest |N commanded - N of the source| at a source sample (sampled tracks)
    off_grid: int               # source widths that were not on the 8 µs grid
    positions: int              # source widths read
    notes: tuple = ()
    warnings: tuple = ()        # what the program does differently from the source (a Maestro frame too short)


@dataclass(frozen=True)
class Timing:
    """How sampled tracks meet the firmware's frames: sample i is kept when i % step == 0, and the
    k-th kept one lands `frames` x k frames after the first."""
    period_us: int
    step: int = 1
    frames: int = 1


def sampled_timing(fps: Fraction, floor_us: int) -> Timing:
    """The frame period for samples 1/fps apart: the longest P = (1/fps) / k that is at least
    `floor_us` (so every sample falls on a frame); for an fps faster than that, every
    `step`-th sample at P = step / fps."""
    interval = Fraction(1_000_000) / fps
    k = int(interval // floor_us)
    if k >= 1:
        return Timing(round_half_up(interval / k), 1, k)
    step = math.ceil(floor_us / interval)
    return Timing(round_half_up(interval * step), step, 1)


class _Writer:
    def __init__(self, kf: Keyframes, pins: dict):
        self.kf = kf
        self.taken: set = set()
        self.names = {c.index: identifier(c.name or f"ch{c.index}", "ch", self.taken) for c in kf.channels}
        self.pins = pins
        self.poses: list = []
        self.comments: dict = {}
        self.positions = self.off_grid = self.moves = self.frames_in = self.deviation = 0
        self.warnings: list = []
        self.on_the_way: dict = {}        # paced tracks: channel -> the target of a servo cut short on its way

    # ---- positions
    def n(self, width: Fraction, ch: int, *where: str) -> int:
        """N of a source width (channel `ch`, at `where`: the key, or the track and sample). A negative
        width is an `ImportError_` naming them: no N is below 0 µs, and `-1500us` is not a .servo width."""
        if width < 0:
            raise ImportError_(f"{', '.join(where)}: `{self.names[ch]}` is at {decimal(width)} µs, a negative pulse "
                               f"width (a servo's pulse is 500 µs + 8 µs x N, N 0..250)")
        self.positions += 1
        if not width_on_grid(width):
            self.off_grid += 1
        return width_to_n(width)

    def pose(self, name: str, values: dict) -> nodes.Name:
        pose = identifier(name, "pose", self.taken)
        entries = tuple(nodes.Entry(_name(self.names[ch]), _width(n), NO_SPAN) for ch, n in sorted(values.items()))
        self.poses.append(nodes.PoseDecl(_name(pose), None, entries, NO_SPAN))
        return _name(pose)

    def statement(self, stmt, comment: str):
        self.comments[id(stmt)] = comment
        self.moves += 1
        return stmt

    # ---- tracks
    def keyed(self, track: Track, prefix: str, period: int) -> list:
        """A keyed track (CSV) at the frame period `period` (µs): each key's move ends on the frame
        nearest its time, frame 0 the sequence's first (at time 0), whatever the keys before it took."""
        body, last, frame = [], Fraction(0), -1           # frame: where the moves so far end (-1: none yet)
        for i, key in enumerate(track.keys):
            self.frames_in += 1
            values = {ch: self.n(w, ch, key.source) for ch, w in sorted(key.targets.items()) if ch in self.names}
            gap, last = max(Fraction(0), key.at_ms - last), key.at_ms
            frames = round_half_up(key.at_ms * 1000 / period) - frame        # to the frame nearest its time
            if not values:
                if frames > 0:
                    body.append(self.statement(nodes.HoldStmt(_frames_ms(frames, period, gap), NO_SPAN), key.source))
                    frame += frames
                continue
            frames = max(1, frames)                  # a move takes a frame at least
            pose = self.pose(f"{prefix}_{i}", values)
            body.append(self.statement(nodes.MoveStmt(pose, _frames_ms(frames, period, gap, move=True), None,
                                                      NO_SPAN), key.source))
            frame += frames
        return body

    def paced(self, track: Track, prefix: str, timing: Timing, current: dict, final: bool = True) -> list:
        """A paced track (Maestro) at the frame period `timing.period_us`, run as the Maestro runs it:
        each key's moves start on the frame nearest its start time, each servo going at its own speed
        (`runs`), and the next key starts on the frame nearest its own start time, holds filling the
        time to it and to the track's end. A servo still on its way when the next key starts (the key
        is shorter than its move: a warning names it) is cut there: its move ends where it is then
        (`reach`), and it goes on to its target in the next key unless that key sets it (the
        Maestro changes its target mid-move), in the next track's first key after the last. Only the
        very last key played (`final`: no track after this one has keys) is not cut: nothing changes
        the targets after it. `current`: channel -> N where the servos are as the track starts
        (updated as it goes)."""
        period, channels = timing.period_us, {c.index: c for c in self.kf.channels}
        body, frame = [], 0                  # frames since the track's start

        def wait_until(ms: Fraction, why: str):
            nonlocal frame
            start = round_half_up(ms * 1000 / period)
            if start > frame:
                body.append(self.statement(nodes.HoldStmt(_frames_ms(start - frame, period), NO_SPAN), why))
                frame = start

        for i, key in enumerate(track.keys):
            self.frames_in += 1
            own = {ch: self.n(w, ch, key.source) for ch, w in sorted(key.targets.items()) if ch in self.names}
            targets = {**self.on_the_way, **own}     # the servos cut short go on unless the key sets them
            values = {ch: n for ch, n in sorted(targets.items()) if current.get(ch) != n}     # the servos it moves
            if not values:
                continue                     # a pause: the hold before the next key's move waits it out
            wait_until(key.at_ms, f"until {key.source} starts")
            end_ms = track.keys[i + 1].at_ms if i + 1 < len(track.keys) else track.length_ms
            duration = end_ms - key.at_ms
            need_us = max((self.travel_us(channels[ch], current.get(ch), n, key.speeds)
                           for ch, n in values.items() if ch in own), default=0)
            last = final and i + 1 == len(track.keys)
            if need_us > duration * 1000:
                self.warnings.append(
                    f"{key.source}: its move needs {decimal(need_us / 1000, 1)} ms at the servos' speeds, longer than "
                    f"the frame's {decimal(duration, 1)} ms" + (
                        "; it is the last frame played, so nothing changes the targets and its move completes" if last
                        else " (the Maestro would change targets mid-move): here too the next frame starts on time, "
                             "from where the servos are then"))
            frames = None if last else max(1, round_half_up(end_ms * 1000 / period) - frame)   # to the next key
            goal, runs = self.cut(values, current, key.speeds, channels, period, duration, frames)
            self.on_the_way = {ch: n for ch, n in values.items() if goal[ch] != n}
            for j, (moves, pose, arriving) in enumerate(runs):
                name = self.pose(f"{prefix}_{i}" + (f"_{j + 1}" if j else ""), pose)
                there = [self.names[ch] for ch in arriving if ch not in self.on_the_way]
                cut = [self.names[ch] for ch in arriving if ch in self.on_the_way]
                why = key.source if len(runs) == 1 and not cut else f"{key.source}: " + "; ".join(
                    ([f"{', '.join(there)} there"] if there else [])
                    + ([f"{', '.join(cut)} on the way as the next frame starts"] if cut else []))
                body.append(self.statement(nodes.MoveStmt(name, _frames_ms(moves, period), None, NO_SPAN), why))
                frame += moves
            current.update(goal)
        wait_until(track.length_ms, f"until the end of {track.name}'s last frame")
        return body

    def cut(self, values: dict, current: dict, speeds, channels: dict, period: int, ms: Fraction, frames) -> tuple:
        """(where each servo of `values` ends this key, the key's `runs`): where it is `ms` after the key's
        start (`reach`), at most where it gets in the key's `frames` so that the next key starts on time
        (None: not cut). When the runs take longer than `frames` (a move boundary costs a servo at its
        very top speed a frame or more, see `runs`), the servos still on their way stop that much
        sooner."""
        budget = frames
        while True:
            goal = values if frames is None else {ch: self.reach(channels[ch], current.get(ch), n, speeds, ms,
                                                                  budget * period) for ch, n in values.items()}
            moving = {ch: n for ch, n in goal.items() if current.get(ch) != n}
            runs = self.runs(moving, current, speeds, channels, period) if moving else []
            over = sum(r[0] for r in runs) - (frames or 0)
            if frames is None or over <= 0 or budget == 1:
                return goal, runs
            budget = max(1, budget - over)

    def reach(self, channel, n0, n1: int, speeds, ms: Fraction, most_us: int) -> int:
        """Where a servo going from N0 to N1 at its speed (`travel_us`) is `ms` after it starts: its width
        then, start + sign x min(|delta|, speed x time), by the Positions rule; and no farther than it
        goes in `most_us` (the frames the move has), so that the move is never too fast for it."""
        if n0 is None or n0 == n1:
            return n1                        # no position yet: set at once
        per_n = self.travel_us(channel, 0, 1, speeds)        # µs it needs per N, so DIV_US µs of width per per_n
        sign = 1 if n1 > n0 else -1
        width = n_to_width_us(n0) + sign * min(abs(n1 - n0) * DIV_US, DIV_US * ms * 1000 / per_n)
        step = min(abs(width_to_n(width) - n0), int(most_us // per_n))
        return n0 + sign * step

    def runs(self, values: dict, current: dict, speeds, channels: dict, period: int) -> list:
        """The moves of one paced key, each servo at its own speed: (frames, pose, the servos that
        arrive), one move to each arrival. A servo arrives after the frames it needs (at least one);
        one still on its way is, at the end of a move, at the N nearest its straight line then that
        it can reach in that move and from which it can still arrive in time; a move takes a frame
        more where no N is both (the rounding of a servo at its very top speed)."""
        need = {ch: max(1, math.ceil(self.travel_us(channels[ch], current.get(ch), n, speeds) / period))
                for ch, n in values.items()}
        per_n = {ch: self.travel_us(channels[ch], 0, 1, speeds) for ch in values}     # µs a servo needs per N (> 0)
        where, out, before = {ch: current.get(ch) for ch in values}, [], 0
        for end in sorted(set(need.values())):
            pose = {}
            for ch, n in values.items():
                n0 = current.get(ch)                 # None (no position yet): need is 1, set at once
                if need[ch] == end:
                    pose[ch] = n
                elif need[ch] > end:
                    # on its way: the N nearest its straight line at `end` that it can reach in this
                    # move and from which it can still arrive in the frames it has left
                    delta, done = abs(n - n0), abs(where[ch] - n0)
                    most = done + int((end - before) * period // per_n[ch])
                    least = delta - int((need[ch] - end) * period // per_n[ch])
                    step = min(max(round_half_up(Fraction(delta * end, need[ch])), least), most, delta)
                    pose[ch] = n0 + (step if n >= n0 else -step)
            frames = end - before
            while any(self.travel_us(channels[ch], where[ch], m, speeds) > frames * period for ch, m in pose.items()):
                frames += 1
            out.append((frames, pose, [ch for ch in pose if need[ch] == end]))
            where.update(pose)
            before = end
        return out

    @staticmethod
    def travel_us(channel, n0, n1: int, speeds) -> Fraction:
        """How long (µs) a servo takes from N0 to N1: at its own top speed, and no faster than the
        key's speed for it (0: no limit) or else the channel's; a servo with no position goes at once."""
        if n0 is None:
            return Fraction(0)
        delta = abs(n1 - n0)
        v = channel.speed_us_s if speeds is None else speeds.get(channel.index) or None
        return max(delta * t_dav_us(channel), delta * DIV_US * Fraction(1_000_000) / v if v else Fraction(0))

    def sampled(self, track: Track, prefix: str, timing: Timing) -> list:
        channels = [c.index for c in self.kf.channels]
        if track.curve is not None:     # a curve: sampled at every frame
            count = int(track.length_ms * 1000 // timing.period_us) + 1
            check_frames(count, f"{track.name} (one sample a frame)")
            frames = [(j, track.curve(Fraction(j * timing.period_us, 1000))) for j in range(count)]
            labels = [f"{j * timing.period_us / 1000:.1f} ms" for j in range(count)]
        else:
            kept = track.keys[::timing.step]
            frames = [(i * timing.frames, k.targets) for i, k in enumerate(kept)]
            labels = [k.source for k in kept]
        self.frames_in += len(frames)
        if not frames:
            return []
        for i, (_, t) in enumerate(frames):
            missing = [self.names[ch] for ch in channels if ch not in t]
            if missing:
                raise ImportError_(f"{track.name}, {labels[i]}: no position for `{missing[0]}`")
        at = [f for f, _ in frames]
        exact = {ch: [float((Fraction(t[ch]) - BASE_US) / DIV_US) for _, t in frames] for ch in channels}
        ns = {ch: [self.n(t[ch], ch, track.name, labels[k]) for k, (_, t) in enumerate(frames)] for ch in channels}
        first = self.pose(f"{prefix}_0", {ch: ns[ch][0] for ch in channels})
        body = [self.statement(nodes.MoveStmt(first, None, None, NO_SPAN), f"{track.name}: {labels[0]}, the start")]
        i = 0
        while i < len(frames) - 1:
            j = _longest_run(at, exact, ns, i)
            duration = _ms(Fraction((at[j] - at[i]) * timing.period_us, 1000))
            changed = {ch: ns[ch][j] for ch in channels if ns[ch][j] != ns[ch][i]}
            stmt = nodes.MoveStmt(self.pose(f"{prefix}_{j}", changed), duration, None, NO_SPAN) if changed \
                else nodes.HoldStmt(duration, NO_SPAN)
            body.append(self.statement(stmt, f"{track.name}: {labels[i]} to {labels[j]}"))
            self.deviation = max(self.deviation, _deviation(at, ns, i, j))
            i = j
        return body


def _longest_run(at: list, exact: dict, ns: dict, i: int) -> int:
    """The last sample j > i such that a linear move from i to j meets every sample between
    within 1 N (see the module's docstring), at most MAX_MOVE_FRAMES frames on."""
    lo = {ch: -math.inf for ch in exact}
    hi = {ch: math.inf for ch in exact}
    best, k = i + 1, i + 1
    while k < len(at) and at[k] - at[i] <= MAX_MOVE_FRAMES:
        t = at[k] - at[i]
        if t > 0:
            if all(lo[ch] <= (ns[ch][k] - ns[ch][i]) / t <= hi[ch] for ch in exact):
                best = k
            for ch, ys in exact.items():
                lo[ch] = max(lo[ch], (ys[k] - ns[ch][i] - _SLACK) / t)
                hi[ch] = min(hi[ch], (ys[k] - ns[ch][i] + _SLACK) / t)
                if lo[ch] > hi[ch]:
                    return best
        k += 1
    return best


def _deviation(at: list, ns: dict, i: int, j: int) -> int:
    """Largest |firmware N - source N| at the samples i..j of one linear move (the Statements rule)."""
    worst, frames = 0, at[j] - at[i]
    for ys in ns.values():
        n0, d = ys[i], ys[j] - ys[i]
        for k in range(i + 1, j):
            step = (2 * abs(d) * (at[k] - at[i]) + frames) // (2 * frames)
            worst = max(worst, abs(n0 + (step if d >= 0 else -step) - ys[k]))
    return worst


def write(kf: Keyframes, pins: dict, timing: Timing | None, source_name: str) -> Imported:
    """The program for `kf`: `pins` maps each channel to its pin (`P1.0`); `timing` is how sampled
    tracks meet the frames, or the period of keyed and paced ones (`servoc.api` gives the default
    period of the pins in use; None only without tracks)."""
    used = {c.index for c in kf.channels if c.home_us is not None}
    for track in kf.tracks:
        used |= {c.index for c in kf.channels} if track.curve is not None else \
            {ch for key in track.keys for ch in key.targets}
    unused = [c for c in kf.channels if c.index not in used]
    kf = dataclasses.replace(kf, channels=tuple(c for c in kf.channels if c.index in used))
    kf, edged = _inside_limits(kf)
    w = _Writer(kf, pins)
    servos = [nodes.ServoDecl(_name(w.names[c.index]), nodes.Pin(pins[c.index], NO_SPAN), _speed(c) + _limit(c),
                              NO_SPAN) for c in kf.channels]
    sequences = []
    homes = {c.index: w.n(c.home_us, c.index, "the home position") for c in kf.channels if c.home_us is not None}
    current = dict(homes)                   # where paced tracks find the servos: main plays them in order
    final = max((i for i, t in enumerate(kf.tracks) if t.keys), default=-1)    # the last track with keys
    for i, track in enumerate(kf.tracks):
        seq = identifier(track.name, "seq", w.taken)
        body = w.sampled(track, seq, timing) if track.sampled else \
            w.paced(track, seq, timing, current, i == final) if track.paced else \
            w.keyed(track, seq, timing.period_us)
        sequences.append(nodes.SequenceDecl(_name(seq), tuple(body), NO_SPAN))
    items: list = []
    if homes:
        home = w.pose("home", homes)
        items.append(nodes.SettingDecl(_name("home"), home, NO_SPAN))
    if timing is not None and kf.tracks:
        items.append(nodes.FrameDecl(_ms(Fraction(timing.period_us, 1000)), NO_SPAN))
    main = tuple(nodes.PlayStmt(s.name, NO_SPAN) for s in sequences)
    items += servos + w.poses + sequences + [nodes.MainDecl(main, NO_SPAN, NO_SPAN)]
    header = [f"# {source_name}: imported by `servoc import` from {_FORMATS[kf.format]}",
              f"# {w.frames_in} source frames became {w.moves} moves"
              + (f"; every source frame met within {w.deviation} N" if any(t.sampled for t in kf.tracks) else "")]
    text = "\n".join(header) + "\n\n" + format_program(nodes.Program(tuple(items), NO_SPAN), w.comments)
    notes = tuple(kf.notes)
    if unused:
        notes += (f"channel{'s' * (len(unused) > 1)} {', '.join(str(c.index) for c in unused)} never move"
                  f"{'s' * (len(unused) == 1)} and {'have' if len(unused) > 1 else 'has'} no home: left out",)
    if w.off_grid:
        notes += (f"{w.off_grid} of {w.positions} positions were off the 8 µs grid and were rounded to the "
                  f"nearest N (500 us + 8 us x N)",)
    if edged[0]:
        notes += (f"{edged[0]} position{'s' * (edged[0] != 1)} at the edge of a channel's range "
                  f"{'were' if edged[0] != 1 else 'was'} set to the edge of its limit, which is the range rounded "
                  f"inward to the 8 µs grid (so that no servo is driven past the range)",)
    return Imported(text, w.frames_in, w.moves, w.deviation, w.off_grid, w.positions, notes, tuple(w.warnings))


_FORMATS = {"maestro": "a Pololu Maestro Control Center settings file", "blender": "a Blender servo-animation export",
            "bottango": "a Bottango code export", "csv": "a CSV of keyframes"}


def _name(text: str) -> nodes.Name:
    return nodes.Name(text, NO_SPAN)


def _ms(value: Fraction) -> nodes.Quantity:
    return nodes.Quantity(Fraction(value), "ms", NO_SPAN)


def _frames_ms(frames: int, period_us: int, near: Fraction | None = None, move: bool = False) -> nodes.Quantity:
    """A duration that lasts exactly `frames` (1 or more) frames of `period_us` by the Statements rule
    (a hold's F = floor(DUR / P + 1/2), a `move`'s at least 1): `near` (ms) itself where it does, else
    the whole ms nearest it that does; without `near`, the whole ms nearest frames x P. (A period is
    over 2 ms, so whole ms lie within the half frame either side of frames x P.)"""
    if near is not None and (move_frames if move else frames_for)(near * 1000, period_us) == frames:
        return _ms(near)
    lo = Fraction((2 * frames - 1) * period_us, 2000)          # F is `frames` from lo (inclusive) to hi
    hi = Fraction((2 * frames + 1) * period_us, 2000)
    ms = round_half_up(Fraction(frames * period_us, 1000) if near is None else near)
    return _ms(Fraction(min(max(ms, math.ceil(lo)), math.ceil(hi) - 1)))


def _width(n: int) -> nodes.Quantity:
    return nodes.Quantity(Fraction(n_to_width_us(n)), "us", NO_SPAN)


def t_dav_us(channel) -> Fraction:
    """The time per DAV (µs) of the servo a channel becomes: the source's speed where it is the
    servo's own (`Channel.servo_speed`: Bottango's rSVPin), else where it is slower than the default
    servo's (a Maestro channel's speed is a limit: the servo goes no faster than it can), else the
    default's."""
    if channel.speed_us_s is None or channel.speed_us_s <= 0:
        return DEFAULT_T_DAV_US
    own = Fraction(DIV_US * 1_000_000) / channel.speed_us_s
    return own if channel.servo_speed else max(DEFAULT_T_DAV_US, own)


def _speed(channel) -> tuple:
    """`speed 1s/Adeg` for a channel whose speed is the servo's own or slower than the default servo:
    v µs/s is v/8 DAV a second."""
    if t_dav_us(channel) == DEFAULT_T_DAV_US and not (channel.servo_speed and channel.speed_us_s):
        return ()
    degrees = Fraction(channel.speed_us_s) / DIV_US * DAV_DEG
    return (nodes.SpeedOption(nodes.Quantity(Fraction(1), "s", NO_SPAN), nodes.Quantity(degrees, "deg", NO_SPAN),
                              NO_SPAN),)


def _limit_n(channel) -> tuple | None:
    """A channel's min..max µs as N, rounded inward to the 8 µs grid (min up, max down), so that the
    limit never lets the servo past the source's range; None without a range or when it holds no N."""
    if channel.min_us is None or channel.max_us is None:
        return None
    lo = min(max(math.ceil((Fraction(channel.min_us) - BASE_US) / DIV_US), 0), N_MAX)
    hi = min(max(math.floor((Fraction(channel.max_us) - BASE_US) / DIV_US), 0), N_MAX)
    return (lo, hi) if lo <= hi else None


def _limit(channel) -> tuple:
    bounds = _limit_n(channel)
    if bounds is None:
        return ()
    return (nodes.LimitOption(_width(bounds[0]), _width(bounds[1]), NO_SPAN),)


def _inside_limits(kf: Keyframes) -> tuple:
    """`kf` with its positions kept inside the channels' limits (`_limit_n`, rounded inward): a
    position within a channel's min..max whose N (rounded half up) falls past the limit, at most
    1 N, is set to the limit's edge. Positions outside min..max are left for the checker to flag.
    Returns (Keyframes, [count of positions moved]); a curve's are counted as it is sampled."""
    channels = {c.index: c for c in kf.channels}
    edges = {ch: b for ch, c in channels.items() if (b := _limit_n(c)) is not None}
    moved = [0]
    if not edges:
        return kf, moved

    def inside(ch, width):
        bounds, c = edges.get(ch), channels.get(ch)
        if bounds is None or width is None or not c.min_us <= width <= c.max_us:
            return width
        n = width_to_n(width)
        if bounds[0] <= n <= bounds[1]:
            return width
        moved[0] += 1
        return Fraction(n_to_width_us(min(max(n, bounds[0]), bounds[1])))

    def targets(values: dict) -> dict:
        return {ch: inside(ch, w) for ch, w in values.items()}

    def kept(curve):
        return None if curve is None else (lambda t: targets(curve(t)))

    tracks = tuple(dataclasses.replace(t, curve=kept(t.curve),
                                       keys=tuple(dataclasses.replace(k, targets=targets(k.targets)) for k in t.keys))
                   for t in kf.tracks)
    chans = tuple(dataclasses.replace(c, home_us=inside(c.index, c.home_us)) for c in kf.channels)
    return dataclasses.replace(kf, channels=chans, tracks=tracks), moved
