"""Reader for Bottango's "export to code" files (format "bottango").

Input: the C++ file Bottango writes for its Arduino driver, `GeneratedCodeAnimations.cpp`
(`SETUP_DATA_k`, `ANIM_n_DATAk`, `ANIM_n_LOOP`; names from `// animation n, "Name"` or the
`// n: Name` key) or the older `GeneratedCommandStreams.cpp` (`SETUP_CHAR_STREAM`,
`STREAM_NAME_CHAR_STREAM[_LOOP]`; names from the `n - Name` key): comma-separated commands
ending in `\\n` in C string literals, those of one stream joined in file order (a command may
straddle two). A file without such literals is read as bare command lines, one animation.

Output: one `Channel` per `rSVPin,pin,minUs,maxUs,maxUsPerSec,startUs` (index = pin, name
`pin_N`, home = start µs, `speed_us_s` = maxUsPerSec, the servo's top speed in µs of width a
second, which the writer declares as the servo's `speed` (`servo_speed`), faster or slower than
the default servo; 0 says no speed; curves name the servo by its pin) and one sampled `Track` per
animation, in file order: `curve(t_ms)` -> {pin: µs as Fraction}, `length_ms` = the end of its
last curve.

Rules:
- `sC,id,startMs,durMs,startY,startCtrlX,startCtrlY,endY,endCtrlX,endCtrlY` is the cubic Bézier
  (0, startY), (startCtrlX, startY+startCtrlY), (dur+endCtrlX, endY+endCtrlY), (dur, endY): x in
  ms from the curve's start, y 0..8192 over min..max µs; `bezier_y` evaluates it as the driver
  does; the width is clamped to min..max as the driver's lerpSignal does.
- `sCI,id,y` (instant) sets y at the start of the last curve read before it.
- A later-starting curve replaces an earlier one; between curves a servo holds the end of its
  last curve, before its first curve in a track its start µs.
- Not imported (one note names the commands): loop streams (the move back to the start when
  looping), curves in the setup stream, and the commands for other kinds of actuators: every
  register command but `rSVPin` (`rSVI2C` servos on an I2C board, steppers, events, `rMTR`
  custom motors, `rAud`, `rCtrl` relay controllers, and any newer `r...` register command),
  `sR` (a command passed on to a relay controller), and the curves of those effectors.
  Skipped: `xE xC xUE xUC STOP tSYN upE sycM sCO sCT sCC sCCI`, and the driver's settings and
  links (`sCfg xUCtrl xCtrl rBOOT sBOOT rMAC ota hRQ hMOD OK`). `sSY` bundles are unpacked, a
  trailing `,hNNN` hash dropped.
- `ImportError_` naming file, line and command: a truncated command, a non-numeric field,
  min = max, a negative speed, start or duration, a curve for an unknown servo, a servo
  registered twice, an unknown command (one that is not a register command); and an export
  with no servo (no `rSVPin`: the error names the other actuators it registers), no animation.
"""

from __future__ import annotations

import bisect
import os
import re
from fractions import Fraction

from .keyframes import Channel, ImportError_, Keyframes, ReadOptions, Track, as_utf8

SIGNAL_MAX = 8192                    # COMPRESSED_SIGNAL_MAX: y of a curve runs 0..8192 over min..max µs

_LITERAL = r'"(?:[^"\\\n]|\\.)*"'
_DECL = re.compile(r'\bconst\s+char\s+(\w+)\s*\[\s*\]\s*(?:PROGMEM\s*)?=\s*((?:' + _LITERAL + r'\s*)+);')
_SNIFF = re.compile(r'(?:^|[\s"]|\\n)(?:rSVPin,\d|sC,[^,\s"]+,\d)')
_ESCAPES = {"n": "\n", "t": "\t", "r": "\r", "0": "\0"}
_SKIPPED = {"xE", "xC", "xUE", "xUC", "STOP", "tSYN", "upE", "sycM", "sCO", "sCT", "sCC", "sCCI",
            "sCfg", "xUCtrl", "xCtrl", "rBOOT", "sBOOT", "rMAC", "ota", "hRQ", "hMOD", "OK"}
_REGISTER = re.compile(r"r[A-Z][A-Za-z0-9]*")      # rSVPin, rSVI2C, rMTR, rCtrl, ...: register an actuator
_RELAY = "sR"                                      # sR,controller,command...: passed on to a relay controller


def sniff(data: bytes, path: str) -> bool:
    """True when `data` holds Bottango commands (`rSVPin,...` or `sC,...`) as Bottango writes them."""
    try:
        text = data[:1 << 20].decode("utf-8-sig", "replace")
        return text.lstrip()[:1] not in ("{", "[", "<") and _SNIFF.search(text) is not None
    except Exception:
        return False


def _casteljau(p0: float, p1: float, p2: float, p3: float, u: float) -> float:
    """The cubic at u by repeated lerps, each (end - start) * u + start as the driver writes it."""
    a, b, c = (p1 - p0) * u + p0, (p2 - p1) * u + p1, (p3 - p2) * u + p2
    d, e = (b - a) * u + a, (c - b) * u + b
    return (e - d) * u + d


def bezier_y(t_ms, duration, start_y, start_cx, start_cy, end_y, end_cx, end_cy, tol_ms=1e-9) -> float:
    """y (0..8192) of one `sC` curve `t_ms` after its start, as FloatBezierCurve::Evaluate finds it.

    The driver bisects u in [0, 1] from u = 0.5 (x(u) above the time: upper = u, below: lower = u,
    then u = the middle) until |x(u) - t| < 1 ms, then returns y(u), both by de Casteljau. This is
    that search run to `tol_ms` (the driver's 1 ms, and its start from the last call's u, put it
    up to a millisecond's worth of motion off). Before the curve y is startY, after it endY.
    """
    t = float(t_ms)
    if t <= 0:
        return float(start_y)
    if t >= duration:
        return float(end_y)
    xs = (0.0, float(start_cx), float(duration + end_cx), float(duration))
    ys = (float(start_y), float(start_y + start_cy), float(end_y + end_cy), float(end_y))
    lower, upper, u = 0.0, 1.0, 0.5
    for _ in range(200):
        x = _casteljau(*xs, u)
        if abs(x - t) < tol_ms or upper - lower < 1e-15:
            break
        if x > t:
            upper = u
        else:
            lower = u
        u = (upper - lower) / 2 + lower
    return _casteljau(*ys, u)


def _streams(text: str, stem: str):
    """(setup chunks, [(name, main chunks, loop chunks)]); a chunk is (text, line, has raw newlines)."""
    setup, anims = [], {}
    for decl in _DECL.finditer(text):
        pieces = [(re.sub(r"\\(.)", lambda e: _ESCAPES.get(e[1], e[1]), m[0][1:-1]),
                   text.count("\n", 0, decl.start(2) + m.start()) + 1, False)
                  for m in re.finditer(_LITERAL, decl[2])]
        if re.fullmatch(r"SETUP(_DATA_\d+|_CHAR_STREAM)", decl[1]):
            setup += pieces
        elif m := (re.fullmatch(r"ANIM_(\d+)_(DATA\d+|LOOP)", decl[1])
                   or re.fullmatch(r"STREAM_(\w+?)_CHAR_STREAM(_LOOP)?", decl[1])):
            anims.setdefault(m[1], ([], []))[bool(m[2] and m[2].endswith("LOOP"))].extend(pieces)
    if not setup and not anims:
        return [], [(stem, [(text, 1, True)], [])]
    titled = dict(re.findall(r'//\s*animation\s+(\d+),\s*"(.*)"', text))       # // animation 0, "Wave"
    keyed = dict(re.findall(r"^[ \t]*(?://)?[ \t]*(\d+)[ \t]*[:-][ \t]*(\S.*?)[ \t]*$", text, re.M))  # 0: Wave
    squashed = {re.sub(r"[\W_]", "", n).upper(): n for n in keyed.values()}        # WAVEHELLO -> Wave Hello

    def title(k):
        if k.isdigit():
            return titled.get(k) or keyed.get(k) or f"animation_{k}"
        return squashed.get(k.replace("_", ""), k)
    return setup, [(title(k), main, loop) for k, (main, loop) in anims.items()]


def _commands(chunks):
    """(command, line) for each non-empty command of a stream, its chunks joined."""
    starts = [0]
    for chunk, _, _ in chunks:
        starts.append(starts[-1] + len(chunk))
    pos = 0
    for command in "".join(c for c, _, _ in chunks).split("\n"):
        if command.strip():
            i = bisect.bisect_right(starts, pos) - 1
            chunk, line, raw = chunks[i]
            yield command.strip(), line + (chunk.count("\n", 0, pos - starts[i]) if raw else 0)
        pos += len(command) + 1


def _cut_short(text: str, path: str) -> None:
    """A file cut short: a string declaration that does not end, or a stream whose last command
    does not end with its `\\n` (Bottango ends every command with one)."""
    for m in re.finditer(r"\bconst\s+char\s+(\w+)\s*\[", text):
        decl = _DECL.match(text, m.start())
        if decl is None:
            raise ImportError_(f"{path}: line {text.count(chr(10), 0, m.start()) + 1}: the string {m[1]} does not "
                               "end: the file is cut short (export it again)")


def _no_servo(path: str, others) -> ImportError_:
    kinds = sorted(set(others))
    return ImportError_(f"{path}: no servo: the export registers no pin servo (no rSVPin command)"
                        + (f", only other kinds of actuators ({', '.join(kinds)})" if kinds else "")
                        + "; servoc imports pin servos: give the servos pins in Bottango and export again")


def read(data: bytes, path: str, options: ReadOptions) -> Keyframes:
    text = as_utf8(data, path).decode("utf-8-sig", "replace")     # as_utf8: the same whether or not converted
    if "rSVPin," not in text:
        raise _no_servo(path, [m for m in re.findall(r'(?:^|[\s",;]|\\n)(r[A-Z][A-Za-z0-9]*),', text)
                               if m not in _SKIPPED])
    _cut_short(text, path)
    setup, animations = _streams(text, os.path.splitext(os.path.basename(path))[0])
    for name, main, loop in ([("setup", setup, [])] if setup else []) + animations:
        for chunks in (main, loop):
            joined = "".join(c for c, _, raw in chunks if not raw)
            if joined.strip() and not joined.rstrip(" \t").endswith("\n"):
                last = joined.rstrip().rsplit("\n", 1)[-1]
                raise ImportError_(f"{path}: the {name} stream ends in the middle of a command ({last[:40]!r}): "
                                   "the file is cut short (export it again)")
    servos, others, in_setup = {}, set(), []        # servos: identifier (the pin as text) -> Channel
    left_out, dropped = {}, [0]                     # other actuators' commands: name -> count; their curves
    signal = {}                                     # identifier -> (µs at y = 0, µs at y = 8192)

    def fail(line, command, problem):
        raise ImportError_(f"{path}: line {line}: {command!r}: {problem}")

    def ints(line, command, fields, count, first=1):
        if len(fields) < count:
            fail(line, command, f"truncated: {fields[0]} needs {count - 1} fields, has {len(fields) - 1}")
        try:
            return [int(f) for f in fields[first:count]]
        except ValueError:
            fail(line, command, "a field is not a whole number")

    def run(chunks, curves):
        """Obey one stream; its curves (id, seq, start, duration, y0, cx0, cy0, y1, cx1, cy1) go to `curves`."""
        for command, line in _commands(chunks):
            fields = command.split(",")
            if len(fields) > 1 and re.fullmatch(r"h\d+", fields[-1]):
                fields.pop()
            name, ident = fields[0], (fields[1] if len(fields) > 1 else None)
            if name == "sSY":            # sSY,sC,9,...;10,...;*sCT,ev,0: commands sharing a prefix
                if len(fields) < 3:
                    fail(line, command, "truncated: sSY without commands")
                prefix = ident + ","
                parts = [p for p in ",".join(fields[1:]).split(";") if p.strip()]    # each part ends with `;`
                for i, part in enumerate(parts):
                    if part.startswith("*") and "," in part:
                        prefix, part = part[1:].split(",", 1)
                        prefix += ","
                    parts[i] = (prefix + part.removeprefix(prefix) + "\n", line, False)
                run(parts, curves)
            elif name == "rSVPin":
                pin, lo, hi, speed, start = ints(line, command, fields, 6)
                if pin < 0:
                    fail(line, command, "negative pin")
                if speed < 0:
                    fail(line, command, f"negative maximum speed ({speed} µs a second)")
                if lo == hi:
                    fail(line, command, f"min and max are both {lo} µs")
                if str(pin) in servos:
                    fail(line, command, f"servo on pin {pin} registered twice")
                # min > max is a servo set up inverted (y = 0 at min): the limits are stored sorted, the
                # direction in `signal`
                servos[str(pin)] = Channel(pin, f"pin_{pin}", Fraction(min(lo, hi)), Fraction(max(lo, hi)),
                                           Fraction(start), Fraction(speed) if speed else None, servo_speed=True)
                signal[str(pin)] = (Fraction(lo), Fraction(hi))
            elif name == _RELAY or (_REGISTER.fullmatch(name) and name not in _SKIPPED):
                if len(fields) < 2 + (name == "rSVI2C"):
                    fail(line, command, f"truncated: {name} without an identifier")
                left_out[name] = left_out.get(name, 0) + 1
                if name != _RELAY:
                    others.add(ident + fields[2] if name == "rSVI2C" else ident)     # I2C: address and pin
            elif name in ("sC", "sCI") and ident in others and ident not in servos:
                dropped[0] += 1
            elif name in ("sC", "sCI"):
                values = ints(line, command, fields, 10 if name == "sC" else 3, first=2)
                if not servos:
                    raise _no_servo(path, left_out)
                if ident not in servos:
                    fail(line, command, f"curve for servo {ident!r}, which no rSVPin registers")
                if curves is None:
                    in_setup.append(command)
                elif name == "sCI":
                    y = values[0]
                    curves.append((ident, len(curves), curves[-1][2] if curves else 0, 0, y, 0, 0, y, 0, 0))
                elif values[0] < 0 or values[1] < 0:
                    fail(line, command, "negative " + ("start time" if values[0] < 0 else "duration"))
                else:
                    curves.append((ident, len(curves), *values))
            elif name not in _SKIPPED:
                fail(line, command, f"unknown command {name!r}")

    run(setup, None)
    if setup and not servos:
        raise _no_servo(path, left_out)
    runs = [(name, []) for name, _, _ in animations]
    for (_, main, _), (_, curves) in zip(animations, runs):
        run(main, curves)
    if not servos:
        raise _no_servo(path, left_out)
    if not runs:
        raise ImportError_(f"{path}: no animation (no ANIM_n_DATAk or STREAM_..._CHAR_STREAM strings)")
    loops = [name for name, _, loop in animations if any(True for _ in _commands(loop))]
    notes = []
    if loops:
        notes.append(f"Not imported: the loop streams of {', '.join(loops)} (the move back to the start when looping).")
    if left_out:
        commands = ", ".join(f"{name} x{count}" if count > 1 else name for name, count in sorted(left_out.items()))
        curves = f", and {dropped[0]} curve{'s' * (dropped[0] != 1)} of theirs" if dropped[0] else ""
        notes.append(f"Not imported: the commands for actuators other than pin servos ({commands}){curves}.")
    if in_setup:
        notes.append(f"Not imported: {len(in_setup)} curves in the setup stream.")
    channels = tuple(sorted(servos.values(), key=lambda c: c.index))
    return Keyframes("bottango", channels, tuple(_track(n, c, servos, signal) for n, c in runs), tuple(notes))


def _track(name, curves, servos, signal) -> Track:
    per = {ident: sorted((c for c in curves if c[0] == ident), key=lambda c: (c[2], c[1])) for ident in servos}
    starts = {ident: [c[2] for c in cs] for ident, cs in per.items()}

    def width(ident, channel, t):
        i = bisect.bisect_right(starts[ident], t) - 1   # the latest curve started by t
        if i < 0:
            return channel.home_us                      # before its first curve
        _, _, start, duration, y0, cx0, cy0, y1, cx1, cy1 = per[ident][i]
        lo, hi = signal[ident]
        if t - start >= duration:                       # at or after its end: hold endY
            us = lo + (hi - lo) * Fraction(y1, SIGNAL_MAX)
        elif t <= start:
            us = lo + (hi - lo) * Fraction(y0, SIGNAL_MAX)
        else:
            y = bezier_y(float(t - start), duration, y0, cx0, cy0, y1, cx1, cy1)
            us = (lo + (hi - lo) * Fraction(y) / SIGNAL_MAX).limit_denominator(1000)
        return min(max(us, channel.min_us), channel.max_us)

    def curve(t_ms) -> dict:
        t = Fraction(t_ms)
        return {channel.index: width(ident, channel, t) for ident, channel in servos.items()}

    length = max((c[2] + c[3] for c in curves), default=0)
    return Track(name=name, keys=(), sampled=True, curve=curve, length_ms=Fraction(length))
