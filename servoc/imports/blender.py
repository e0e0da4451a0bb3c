"""Reader for the exports of the "Blender Servo Animation" add-on (Tim Hendriks).

Input: one of the add-on's three exports of one scene (add-on 2.x; source:
github.com/timhendriks93/blender-servo-animation, `addon/ops/*_export.py`):
- `.json`: `{"description", "fps", "frames", "seconds", "bones", "file",
  "scene", "positions": [{"<servo id>": position, ...}, ...]}`, one object per
  frame. (The 1.x exports, one list or array per servo, are not read.)
- `.h`: `const byte FPS = 30; const int FRAMES = 100; const int LENGTH = 600;
  const byte PROGMEM ANIMATION_DATA[LENGTH] = {0x3c, ...};`, optionally inside
  `namespace Scene { ... }`; several such arrays in one header are several tracks.
- `.bin`: the bytes of ANIMATION_DATA alone, no header, so `--fps` is required.
The bytes are fixed 5-byte records `0x3C id hi lo 0x3E` (position = hi*256+lo),
each frame ended by `0x0A`. They are read by position, never by searching for a
marker, so a `0x3C` or `0x0A` inside an id or position (1852 = 0x073C,
2570 = 0x0A0A, id 10) is data (the add-on's own Arduino parser gets these wrong).

Output: `Keyframes(format="blender")` with one channel per servo id
(`servo_<id>`: the exports name no servo, nor say min/max/home) and one
`Track(sampled=True)` per animation, named by its namespace or else the file's
name: key k (counted from 0 at the scene's first frame) is at 1000*k/fps ms and
sets every servo of the track, `source="frame k"`.

Rules:
- A servo missing from a frame keeps its position: the add-on's "Skip unchanged
  positions" (on by default) leaves unchanged servos out, so frames may list
  different servos or none. Every servo must have a position in frame 0; a servo
  twice in one frame ends at the last (as on the Arduino).
- Positions are µs; with `--ticks HZ` they are PCA9685 counts (0..4095) converted
  by `ticks_to_us`. If all positions are below 500 a note says they are unlikely µs.
- The file's FPS is used; `--fps` may repeat it but a different value is an error.
- Anything malformed raises `ImportError_` naming the file and frame or byte;
  more than MAX_FRAMES frames are refused as soon as they are counted.
"""

from __future__ import annotations

import json
import os
import re
from fractions import Fraction

from .keyframes import Channel, ImportError_, Key, Keyframes, ReadOptions, Track, check_frames, ticks_to_us

_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
_ARRAY_START = re.compile(r"ANIMATION_DATA\s*\[")
_ARRAY = re.compile(r"ANIMATION_DATA\s*\[[^\]]*\][^={};]*=\s*\{([^}]*)\}")
_CONST = re.compile(r"\b(FPS|FRAMES|LENGTH)\s*=\s*([0-9]+)\s*;")
_BYTE = re.compile(r"0[xX][0-9a-fA-F]{1,2}|0|[1-9][0-9]{0,2}")
_NAMESPACE = re.compile(r"\bnamespace\s+(\w+)\s*\{")


def sniff(data: bytes, path: str) -> bool:
    """True when `data` looks like a Blender servo-animation export (JSON, .h or .bin)."""
    try:
        head = data.lstrip(b"\xef\xbb\xbf \t\r\n")
        if head[:1] == b"{":
            return all(key in data for key in (b'"fps"', b'"frames"', b'"positions"'))
        if b"ANIMATION_DATA" in data:
            return True
        body = data.lstrip(b"\n")
        return (path.lower().endswith(".bin") and len(body) >= 6 and data[-1] == 0x0A
                and body[0] == 0x3C and body[4] == 0x3E)
    except Exception:       # sniffing must never fail
        return False


def read(data: bytes, path: str, options: ReadOptions) -> Keyframes:
    """The Keyframes of one Blender servo-animation export (see the module docstring)."""
    stem = os.path.splitext(os.path.basename(path))[0] or "animation"
    if data.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] in (b"{", b"["):
        animations = [(stem, *_read_json(data, path, options), path)]
    elif b"ANIMATION_DATA" in data:
        animations = _read_header(_text(data, path), path, stem, options)
    elif options.fps is None:
        raise ImportError_(f"{path}: a Blender .bin export does not say its frame rate: pass --fps N")
    else:
        animations = [(stem, _fps(options.fps, path, "--fps"), _frames(data, path), path)]
    notes, ids = [], set()
    tracks = tuple(_track(*animation, options, ids, notes) for animation in animations)
    channels = tuple(Channel(index=i, name=f"servo_{i}") for i in sorted(ids))
    return Keyframes(format="blender", channels=channels, tracks=tracks, notes=tuple(notes))


def _text(data: bytes, path: str) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ImportError_(f"{path}: not UTF-8 text (byte {e.start})") from None


def _fps(value, where: str, what: str, options: ReadOptions | None = None) -> Fraction:
    """A frame rate from the file (or --fps) as a positive Fraction, checked against --fps."""
    if isinstance(value, bool) or not isinstance(value, (int, Fraction)):
        raise ImportError_(f"{where}: {what} must be a whole number, not {value!r}")
    fps = Fraction(value)
    if fps <= 0:
        raise ImportError_(f"{where}: {what} must be more than 0, not {value!r}")
    if options is not None and options.fps is not None and Fraction(options.fps) != fps:
        raise ImportError_(f"{where}: the file says {what} {fps} but --fps says {Fraction(options.fps)}: "
                           f"leave out --fps or give --fps {fps}")
    return fps


def _read_json(data: bytes, path: str, options: ReadOptions):
    """(fps, frames) of a JSON export, each frame a dict servo id -> position."""
    try:
        doc = json.loads(_text(data, path))
    except (ValueError, RecursionError) as e:
        raise ImportError_(f"{path}: not valid JSON ({e})") from None
    if isinstance(doc, dict) and "servos" in doc and "positions" not in doc:
        raise ImportError_(f"{path}: the add-on 1.x JSON layout (\"servos\") is not read: "
                           "export it again with add-on 2.x")
    if not isinstance(doc, dict) or "fps" not in doc or "positions" not in doc:
        raise ImportError_(f"{path}: not a Blender servo-animation JSON export (no \"fps\" and \"positions\")")
    fps = _fps(doc["fps"], path, "fps", options)
    count, frames = doc.get("frames"), doc["positions"]
    if isinstance(count, bool) or not isinstance(count, int):
        raise ImportError_(f"{path}: \"frames\" must be a whole number, not {count!r}")
    if not isinstance(frames, list) or not all(isinstance(f, dict) for f in frames):
        raise ImportError_(f"{path}: \"positions\" must be a list with one object per frame")
    if count != len(frames):
        raise ImportError_(f"{path}: \"frames\" is {count} but \"positions\" has {len(frames)} frames")
    check_frames(count, path)
    ids, out = {}, []       # ids: JSON key -> servo id, each key checked once
    for k, frame in enumerate(frames):
        for key, position in frame.items():
            if key not in ids:
                if not re.fullmatch(r"[0-9]{1,3}", key) or int(key) > 255:
                    raise ImportError_(f"{path}: frame {k}: servo id {key!r} is not a number 0..255")
                ids[key] = int(key)
            if type(position) is not int:
                raise ImportError_(f"{path}: frame {k}: position of servo {key} must be a whole number, "
                                   f"not {position!r}")
        out.append({ids[key]: position for key, position in frame.items()})
    return fps, out


def _read_header(text: str, path: str, stem: str, options: ReadOptions):
    """[(name, fps, frames, where)] of the ANIMATION_DATA arrays of a C header."""
    text = _COMMENT.sub(lambda m: "\n" * m.group().count("\n"), text)
    starts = [m.start() for m in _ARRAY_START.finditer(text)]
    if not starts:
        raise ImportError_(f"{path}: no ANIMATION_DATA array (1.x headers are not read: export again with add-on 2.x)")
    animations, done = [], 0
    for n, start in enumerate(starts):
        line = text.count("\n", 0, start) + 1
        where = f"{path}:{line}"
        m = _ARRAY.match(text, start)
        if not m:
            raise ImportError_(f"{where}: ANIMATION_DATA has no closing '}}' (is the file cut short?)")
        before, done = text[done:start], m.end()
        consts = {k: int(v) for k, v in _CONST.findall(before)}
        namespaces = _NAMESPACE.findall(before)
        name = namespaces[-1] if namespaces else stem if len(starts) == 1 else f"{stem}_{n + 1}"
        check_frames(consts.get("FRAMES", 0), where)
        if "FPS" in consts:
            fps = _fps(consts["FPS"], where, "FPS", options)
        elif options.fps is not None:
            fps = _fps(options.fps, where, "--fps")
        else:
            raise ImportError_(f"{where}: no `FPS = N;` before ANIMATION_DATA: pass --fps N")
        tokens = m.group(1).replace(",", " ").split()
        try:
            data = bytes(int(t, 16) if t[:2] in ("0x", "0X") else int(t, 0) for t in tokens)
        except ValueError:      # find the culprit: not 0xHH nor a decimal without leading 0 (C's octal), or > 255
            bad = next((i for i, t in enumerate(tokens)
                        if not _BYTE.fullmatch(t) or int(t, 0) > 255), 0)
            raise ImportError_(f"{where}: ANIMATION_DATA byte {bad} is {tokens[bad]!r}, not a byte (0..255)") from None
        if consts.get("LENGTH", len(data)) != len(data):
            raise ImportError_(f"{where}: LENGTH is {consts['LENGTH']} but ANIMATION_DATA has {len(data)} bytes")
        frames = _frames(data, f"{where}: ANIMATION_DATA")
        if consts.get("FRAMES", len(frames)) != len(frames):
            raise ImportError_(f"{where}: FRAMES is {consts['FRAMES']} but ANIMATION_DATA has {len(frames)} frames")
        animations.append((name, fps, frames, where))
    return animations


def _frames(data: bytes, where: str) -> list:
    """The frames of 5-byte records `0x3C id hi lo 0x3E` each ended by 0x0A, as dicts id -> position."""
    frames, frame, start, i, n = [], {}, 0, 0, len(data)
    while i < n:
        b = data[i]
        if b == 0x0A:
            frames.append(frame)
            check_frames(len(frames), where)
            frame, start, i = {}, i + 1, i + 1
        elif b != 0x3C:
            raise ImportError_(f"{where}: byte {i} is 0x{b:02X}, not 0x3C (start of a servo record) "
                               f"or 0x0A (end of frame {len(frames)})")
        elif i + 5 > n:
            raise ImportError_(f"{where}: byte {i}: the servo record is cut short ({n - i} of 5 bytes)")
        elif data[i + 4] != 0x3E:
            raise ImportError_(f"{where}: byte {i + 4} is 0x{data[i + 4]:02X}, "
                               f"not 0x3E (end of the servo record at byte {i})")
        else:
            frame[data[i + 1]] = data[i + 2] << 8 | data[i + 3]
            i += 5
    if frame or start < n:
        raise ImportError_(f"{where}: frame {len(frames)} (from byte {start}) does not end with 0x0A "
                           "(is the file cut short?)")
    return frames


def _track(name, fps, frames, where, options, ids, notes) -> Track:
    """The sampled track of `frames` (dicts id -> raw position); a missing servo keeps its position."""
    servos = set().union(*frames)
    if not servos:
        raise ImportError_(f"{where}: no servo positions in {len(frames)} frames")
    missing = servos - frames[0].keys()
    if missing:
        sid = min(missing)
        first = next(k for k, f in enumerate(frames) if sid in f)
        raise ImportError_(f"{where}: servo {sid} has no position in frame 0 (its first is in frame {first}); "
                           f"every servo must have one in the first frame")
    hz = options.ticks_hz
    widths, current, keys, num, den = {}, {}, [], fps.denominator * 1000, fps.numerator
    for k, frame in enumerate(frames):
        for sid, raw in frame.items():
            us = widths.get(raw)
            if us is None:
                if raw < 0 or (hz is not None and raw > 4095):
                    raise ImportError_(f"{where}: frame {k}: servo {sid} position {raw} is not "
                                       + ("a PCA9685 count 0..4095" if hz is not None else "a width in µs"))
                widths[raw] = us = ticks_to_us(Fraction(raw), hz) if hz is not None else Fraction(raw)
            current[sid] = us
        keys.append(Key(at_ms=Fraction(num * k, den), targets=dict(current), source=f"frame {k}"))
    if hz is None and max(widths) < 500:
        notes.append(f"{name}: every position is below 500, unlikely for µs: if they are PCA9685 counts "
                     f"pass --ticks HZ (the add-on's default range 150..600 is counts at 50-60 Hz)")
    ids.update(servos)
    return Track(name=name, keys=tuple(keys), sampled=True)
