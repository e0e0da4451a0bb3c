"""Reader for the exports of the "Blender Servo Animation" add-on (Tim Hendriks).

Input: one of the add-on's three exports of one scene (add-on 2.x; source:
github.com/timhendriks93/blender-servo-animation, `addon/ops/*_export.py`):
- `.json`: `{"description", "fps", "frames", "seconds", "bones", "file",
  "scene", "positions": [{"<servo id>": position, ...}, ...]}`, one object per
  frame.
- `.h`: `const byte FPS = 30; const int FRAMES = 100; const int LENGTH = 600;
  const byte PROGMEM ANIMATION_DATA[LENGTH] = {0x3c, ...};`, optionally inside
  `namespace Scene { ... }`; several such arrays in one header are several tracks.
- `.bin`: the bytes of ANIMATION_DATA alone, no header, so `--fps` is required. Known by its
  name or by its bytes (`is_records`: nothing but records), so a copy under another name is
  read as one too.
The bytes are fixed 5-byte records `0x3C id hi lo 0x3E` (position = hi*256+lo),
each frame ended by `0x0A`. They are read by position, never by searching for a
marker, so a `0x3C` or `0x0A` inside an id or position (1852 = 0x073C,
2570 = 0x0A0A, id 10) is data (the add-on's own Arduino parser gets these wrong).

Or one of the add-on 1.x's two exports, one list or array of positions per servo:
- `.json`: 1.0-1.2 `{"description", "fps", "frames", ..., "positions": {"<bone>":
  [position, ...], ...}}` (1.0 wrote the positions as strings, `"375"`, and an early
  1.0 named them `"pulses"`); 1.3-1.4 `{..., "servos": {"<servo id>": {"name": "<bone>",
  "positions": [...]}}}`.
- `.h`: `const int Bone[100] PROGMEM = {90, 91, ...};` (`float` when exported with
  decimals; `[FRAMES]` and `const byte FPS = 30; const int FRAMES = 100;` from 1.4,
  optionally in `namespace Scene { ... }`), the frame rate in the comment at the top
  (`FPS: 30`) or in `FPS`, each array after a `// Servo ID: N` comment from 1.3.
A 1.x servo is channel N of its servo id (1.3 and later), else the servos are
channels 0, 1, ... in file order, named by their bones; one track per scene.
The 1.x add-on wrote each bone's angle mapped onto the position range set on the
bone (default 150..600, PCA9685 counts; 0..180, degrees, for the Arduino Servo
library; or µs), and the export does not say which. Each servo's unit is read off
its positions: with `--ticks HZ` they are PCA9685 counts (as in 2.x); else a servo
whose positions all lie in 0..180 is in degrees, and A degrees is the width a
.servo `A deg` gives (N = floor(A x 250/185 + 1/2), `deg_to_us`); a servo whose
positions are all 500 or more is in µs; any other servo is an error that names
the version and says what to do (`--ticks HZ`, or export again with add-on 2.x).
A note says which servos were read in which unit.

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
  by `ticks_to_us`. A note says which (`unit_note`), and if all positions are below
  500 that they are unlikely µs.
- The file's FPS is used; `--fps` may repeat it but a different value is an error.
- Anything malformed raises `ImportError_` naming the file and frame or byte;
  more than MAX_FRAMES frames are refused as soon as they are counted.
"""

from __future__ import annotations

import json
import math
import os
import re
from fractions import Fraction

from .keyframes import (Channel, ImportError_, Key, Keyframes, ReadOptions, Track, check_frames, decimal, deg_to_us,
                        ticks_to_us, unit_note)

_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
_ARRAY_START = re.compile(r"ANIMATION_DATA\s*\[")
_ARRAY = re.compile(r"ANIMATION_DATA\s*\[[^\]]*\][^={};]*=\s*\{([^}]*)\}")
_CONST = re.compile(r"\b(FPS|FRAMES|LENGTH)\s*=\s*([0-9]+)\s*;")
_BYTE = re.compile(r"0[xX][0-9a-fA-F]{1,2}|0|[1-9][0-9]{0,2}")
_NAMESPACE = re.compile(r"\bnamespace\s+(\w+)\s*\{")
# add-on 1.x headers: one array of positions per servo, `const int Bone[100] PROGMEM = {...};`
_V1_TYPES = r"(?:unsigned\s+)?(?:int|float|double|long|short|byte|word|u?int(?:8|16|32)_t)"
_V1_START = re.compile(r"\bconst\s+" + _V1_TYPES + r"\s+(?:PROGMEM\s+)?(\w+)\s*\[\s*(\w*)\s*\]")
_V1_ARRAY = re.compile(r"\bconst\s+" + _V1_TYPES + r"\s+(?:PROGMEM\s+)?(\w+)\s*\[\s*(\w*)\s*\]\s*"
                       r"(?:PROGMEM\s*)?=\s*\{([^}]*)\}\s*;")
_V1_SNIFF = re.compile(rb"\bconst\s+(?:int|float)\s+(?:PROGMEM\s+)?\w+\s*\[\s*(?:[0-9]+|FRAMES)\s*\]\s*"
                       rb"(?:PROGMEM\s*)?=\s*\{")
_V1_FPS = re.compile(r"\bFPS\s*(?::|=)\s*([0-9]+)")             # the comment `FPS: 30` or `FPS = 30;`
_V1_FRAMES = re.compile(r"\bFRAMES\s*=\s*([0-9]+)\s*;")
_V1_SERVO_ID = re.compile(r"Servo\s+ID:\s*([0-9]+)")
_V1_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]{1,2})?")
V1_MAX = 10_000                 # the add-on's largest position setting
V1_DEGREES = 180                # 1.x positions all within 0..180 are degrees (the Arduino Servo library's range)
V1_US = 500                     # ... all 500 or more are µs


def sniff(data: bytes, path: str) -> bool:
    """True when `data` looks like a Blender servo-animation export (JSON, .h or .bin)."""
    try:
        head = data.lstrip(b"\xef\xbb\xbf \t\r\n")
        if head[:1] == b"{":
            return b'"fps"' in data and b'"frames"' in data and (b'"positions"' in data or b'"pulses"' in data)
        if b"ANIMATION_DATA" in data:
            return True
        if b"FPS" in data and _V1_SNIFF.search(data[:1 << 20]):      # an add-on 1.x header
            return True
        if is_records(data):
            return True
        body = data.lstrip(b"\n")          # named .bin: one that starts and ends as records do (errors name the byte)
        return (path.lower().endswith(".bin") and len(body) >= 6 and data[-1] == 0x0A
                and body[0] == 0x3C and body[4] == 0x3E)
    except Exception:       # sniffing must never fail
        return False


def is_records(data: bytes) -> bool:
    """Whether `data` is a `.bin` export by its content, whatever the file is called: every byte in
    5-byte records `0x3C id hi lo 0x3E`, each frame ended by 0x0A, and at least one record."""
    if data[:1] not in (b"<", b"\n") or not data.strip(b"\n"):
        return False
    try:
        _frames(data, "", limit=False)
        return True
    except ImportError_:
        return False


def read(data: bytes, path: str, options: ReadOptions) -> Keyframes:
    """The Keyframes of one Blender servo-animation export (see the module docstring)."""
    stem = os.path.splitext(os.path.basename(path))[0] or "animation"
    is_bin = path.lower().endswith(".bin") or is_records(data)        # by its name, or its bytes
    text_like = path.lower().endswith((".h", ".hpp", ".json", ".txt")) and not is_bin
    if data.lstrip(b"\xef\xbb\xbf \t\r\n")[:1] in (b"{", b"["):
        doc = _load_json(data, path)
        if _is_v1_json(doc):
            return _read_v1(_v1_json(doc, path, stem, options), path, options)
        animations = [(stem, *_read_json(doc, path, options), path)]
    elif b"ANIMATION_DATA" in data:
        animations = _read_header(_text(data, path), path, stem, options)
    elif not is_bin and _V1_START.search(data.decode("utf-8", "replace")):
        return _read_v1(_v1_header(_text(data, path), path, stem, options), path, options)
    elif text_like:
        raise ImportError_(f"{path}: not a Blender servo-animation export: no JSON object, no ANIMATION_DATA array "
                           "(add-on 2.x) and no arrays of positions (add-on 1.x)")
    elif options.fps is None:
        raise ImportError_(f"{path}: a Blender .bin export does not say its frame rate: pass --fps N")
    else:
        animations = [(stem, _fps(options.fps, path, "--fps"), _frames(data, path), path)]
    notes, ids = [], set()
    tracks = tuple(_track(*animation, options, ids, notes) for animation in animations)
    channels = tuple(Channel(index=i, name=f"servo_{i}") for i in sorted(ids))
    return Keyframes(format="blender", channels=channels, tracks=tracks,
                     notes=(unit_note(options.ticks_hz),) + tuple(notes))


def _text(data: bytes, path: str) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ImportError_(f"{path}: not UTF-8 text (byte {e.start})") from None


def _fps(value, where: str, what: str, options: ReadOptions | None = None) -> Fraction:
    """A frame rate from the file (or --fps) as a positive Fraction, checked against --fps."""
    if isinstance(value, bool) or not isinstance(value, (int, Fraction)):
        raise ImportError_(f"{where}: {what} must be a whole number, not {_short(value)}")
    fps = Fraction(value)
    if fps <= 0:
        raise ImportError_(f"{where}: {what} must be more than 0, not {decimal(fps)}")
    if options is not None and options.fps is not None and Fraction(options.fps) != fps:
        raise ImportError_(f"{where}: the file says {what} {decimal(fps)} but --fps says {decimal(options.fps)}: "
                           f"leave out --fps or give --fps {decimal(fps)}")
    return fps


def _load_json(data: bytes, path: str):
    try:
        return json.loads(_text(data, path))
    except (ValueError, RecursionError) as e:
        raise ImportError_(f"{path}: not valid JSON ({e})") from None


def _read_json(doc, path: str, options: ReadOptions):
    """(fps, frames) of a JSON export, each frame a dict servo id -> position."""
    if not isinstance(doc, dict) or "fps" not in doc or "positions" not in doc:
        raise ImportError_(f"{path}: not a Blender servo-animation JSON export (no \"fps\" and \"positions\")")
    fps = _fps(doc["fps"], path, "fps", options)
    count, frames = doc.get("frames"), doc["positions"]
    if isinstance(count, bool) or not isinstance(count, int):
        raise ImportError_(f"{path}: \"frames\" must be a whole number, not {_short(count)}")
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
                    raise ImportError_(f"{path}: frame {k}: servo id {_short(key)} is not a number 0..255")
                ids[key] = int(key)
            if type(position) is not int:
                raise ImportError_(f"{path}: frame {k}: position of servo {key} must be a whole number, "
                                   f"not {_short(position)}")
        out.append({ids[key]: position for key, position in frame.items()})
    return fps, out


def _read_header(text: str, path: str, stem: str, options: ReadOptions):
    """[(name, fps, frames, where)] of the ANIMATION_DATA arrays of a C header."""
    text = _COMMENT.sub(lambda m: "\n" * m.group().count("\n"), text)
    starts = [m.start() for m in _ARRAY_START.finditer(text)]
    if not starts:
        raise ImportError_(f"{path}: no ANIMATION_DATA array")
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


def _frames(data: bytes, where: str, limit: bool = True) -> list:
    """The frames of 5-byte records `0x3C id hi lo 0x3E` each ended by 0x0A, as dicts id -> position
    (`limit`: no more than MAX_FRAMES of them)."""
    frames, frame, start, i, n = [], {}, 0, 0, len(data)
    while i < n:
        b = data[i]
        if b == 0x0A:
            frames.append(frame)
            if limit:
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


# --- add-on 1.x: one list of positions per servo ---------------------------------------------------

def _is_v1_json(doc) -> bool:
    """The 1.x JSON layouts: positions (or pulses) by bone name, or servos by id."""
    if not isinstance(doc, dict):
        return False
    if "positions" in doc:
        return isinstance(doc["positions"], dict)
    return isinstance(doc.get("servos"), dict) or isinstance(doc.get("pulses"), dict)


def _v1_json(doc: dict, path: str, stem: str, options: ReadOptions):
    """[(scene, fps, [(channel, name, positions)], where)] of a 1.x JSON export."""
    if "fps" not in doc:
        raise ImportError_(f"{path}: add-on 1.x JSON export without \"fps\"")
    fps = _fps(doc["fps"], path, "fps", options)
    count = doc.get("frames")
    if isinstance(count, bool) or not isinstance(count, int):
        raise ImportError_(f"{path}: \"frames\" must be a whole number, not {_short(count)}")
    check_frames(count, path)
    servos = []
    if "servos" in doc and "positions" not in doc:             # 1.3-1.4: by servo id
        if not isinstance(doc["servos"], dict):
            raise ImportError_(f"{path}: \"servos\" must be an object, servo id -> {{\"name\", \"positions\"}}")
        for key, servo in doc["servos"].items():
            if not re.fullmatch(r"[0-9]{1,3}", key) or int(key) > 255:
                raise ImportError_(f"{path}: servo id {_short(key)} is not a number 0..255")
            if not isinstance(servo, dict) or not isinstance(servo.get("positions"), list):
                raise ImportError_(f"{path}: servo {key} must be an object with a list \"positions\"")
            name = servo.get("name") if isinstance(servo.get("name"), str) else None
            servos.append((int(key), name, servo["positions"]))
    else:                                                      # 1.0-1.2: by bone name, in file order
        bones = doc.get("positions", doc.get("pulses"))
        for i, (bone, values) in enumerate(bones.items()):
            if not isinstance(values, list):
                raise ImportError_(f"{path}: the positions of bone {_short(bone)} must be a list")
            servos.append((i, bone, values))
    where = path
    out = []
    for index, name, values in servos:
        what = f"servo {index}" + (f" ({name})" if name else "")
        if len(values) != count:
            raise ImportError_(f"{where}: \"frames\" is {count} but {what} has {len(values)} positions")
        out.append((index, name, [_v1_value(v, f"{where}: {what}, frame {k}") for k, v in enumerate(values)]))
    scene = doc.get("scene") if isinstance(doc.get("scene"), str) and doc.get("scene") else stem
    return [(scene, fps, out, where)]


def _v1_value(value, where: str) -> Fraction:
    """One 1.x position: a number, or a number as a string (1.0-1.2 wrote `"375"`)."""
    if isinstance(value, str) and len(value) <= 40 and _V1_NUMBER.fullmatch(value.strip()):
        value = Fraction(value.strip())
    elif isinstance(value, bool) or not isinstance(value, (int, float)) or \
            (isinstance(value, float) and not math.isfinite(value)):
        raise ImportError_(f"{where}: the position {_short(value)} is not a number")
    value = Fraction(value)
    if not 0 <= value <= V1_MAX:
        raise ImportError_(f"{where}: the position {decimal(value)} is outside 0..{V1_MAX}, the add-on's range")
    return value


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _v1_header(text: str, path: str, stem: str, options: ReadOptions):
    """[(scene, fps, [(channel, name, positions)], where)] of a 1.x header, one entry a scene."""
    blank = _COMMENT.sub(lambda m: re.sub(r"[^\n]", " ", m.group()), text)     # comments out, offsets kept
    marks = [(m.start(), int(m[1])) for c in _COMMENT.finditer(text)           # `// Servo ID: 3` comments
             for m in _V1_SERVO_ID.finditer(text, c.start(), c.end())]
    fps_at = [(m.start(), int(m[1])) for m in _V1_FPS.finditer(text)]
    frames_at = [(m.start(), int(m[1])) for m in _V1_FRAMES.finditer(blank)]
    scenes, done = {}, 0
    for start in [m.start() for m in _V1_START.finditer(blank)]:
        if start < done:
            continue
        where = f"{path}:{text.count(chr(10), 0, start) + 1}"
        m = _V1_ARRAY.match(blank, start)
        if not m:
            raise ImportError_(f"{where}: an array of positions without its closing '}};' (is the file cut short?)")
        name, size, body = m[1], m[2], m[3]
        namespaces = _NAMESPACE.findall(blank, 0, start)
        scene = namespaces[-1] if namespaces else stem
        mark = [sid for at, sid in marks if done <= at < start]
        fps = [v for at, v in fps_at if at < start]
        frames = [v for at, v in frames_at if at < start]
        done = m.end()
        tokens = [t.strip() for t in body.split(",")]
        if tokens and not tokens[-1]:
            tokens.pop()                        # the add-on ends each line of values with a comma
        check_frames(len(tokens), where)
        values = []
        for k, token in enumerate(tokens):
            token = token.rstrip("fF")
            if not _V1_NUMBER.fullmatch(token):
                raise ImportError_(f"{where}: {name} frame {k}: {_short(token)} is not a number")
            values.append(_v1_value(token, f"{where}: {name}, frame {k}"))
        want = int(size) if size.isdigit() else frames[-1] if size == "FRAMES" and frames else None
        if size and want is None:
            raise ImportError_(f"{where}: {name}[{size}]: no `{size} = N;` before it says how many frames")
        if want is not None and want != len(values):
            raise ImportError_(f"{where}: {name}[{size}] has {len(values)} positions, not {want}")
        entry = scenes.setdefault(scene, [None, [], where])
        if entry[0] is None:
            if fps:
                entry[0] = _fps(fps[-1], where, "FPS", options)
            elif options.fps is not None:
                entry[0] = _fps(options.fps, where, "--fps")
            else:
                raise ImportError_(f"{where}: no `FPS: N` or `FPS = N;` before {name}: pass --fps N")
        entry[1].append((mark[-1] if mark else None, name, values))
    if not scenes:
        raise ImportError_(f"{path}: no array of positions")
    out, taken, by_name = [], {sid for _, (_, servos, _) in scenes.items() for sid, _, _ in servos}, {}
    for scene, (fps, servos, where) in scenes.items():
        lengths = {len(v) for _, _, v in servos}
        if len(lengths) > 1:
            raise ImportError_(f"{where}: the arrays of {scene} have different lengths "
                               f"({', '.join(map(str, sorted(lengths)))})")
        numbered = []
        for sid, name, values in servos:
            if sid is None:             # before 1.3 no servo id: channels 0, 1, ... by bone, in file order
                if name not in by_name:
                    by_name[name] = next(i for i in range(len(taken) + 1) if i not in taken)
                    taken.add(by_name[name])
                sid = by_name[name]
            numbered.append((sid, name, values))
        out.append((scene, fps, numbered, where))
    return out


def _read_v1(scenes, path: str, options: ReadOptions) -> Keyframes:
    """Keyframes of 1.x exports: [(scene, fps, [(channel, name, positions)], where)]."""
    hz, channels, tracks, notes = options.ticks_hz, {}, [], []
    units = {}                                  # unit -> names of servos read in it
    for scene, fps, servos, where in scenes:
        if not servos or not servos[0][2]:
            raise ImportError_(f"{where}: no servo positions in {scene}")
        widths = {}
        for index, name, values in servos:
            what = name or f"servo {index}"
            if index in widths:
                raise ImportError_(f"{where}: servo {index} has two arrays of positions in {scene}")
            if index in channels and channels[index].name != name:
                raise ImportError_(f"{where}: servo {index} is both {channels[index].name or '?'} and {name or '?'}")
            channels[index] = Channel(index=index, name=name or f"servo_{index}")
            lo, hi = min(values), max(values)
            if hz is not None:
                if hi > 4095:
                    raise ImportError_(f"{where}: {what}: position {decimal(hi)} is not a PCA9685 count 0..4095")
                widths[index] = [ticks_to_us(v, hz) for v in values]
            elif hi <= V1_DEGREES:
                widths[index] = [deg_to_us(v) for v in values]
                units.setdefault("degrees", []).append(what)
            elif lo >= V1_US:
                widths[index] = values
                units.setdefault("µs", []).append(what)
            else:
                raise ImportError_(
                    f"{where}: {what}: positions {decimal(lo)}..{decimal(hi)} of an add-on 1.x export are neither "
                    f"degrees (0..{V1_DEGREES}) nor µs ({V1_US} and up); if they are PCA9685 counts (the 1.x default "
                    f"range 150..600) import with --ticks HZ, the PWM rate they were made for, or export the "
                    f"animation again with add-on 2.x in µs")
        count, num, den = len(servos[0][2]), fps.denominator * 1000, fps.numerator
        keys = tuple(Key(at_ms=Fraction(num * k, den), targets={i: w[k] for i, w in widths.items()},
                         source=f"frame {k}") for k in range(count))
        tracks.append(Track(name=scene, keys=keys, sampled=True))
    if hz is not None:
        notes.append(unit_note(hz, "add-on 1.x positions"))
    else:
        said = {"degrees": f"degrees (all within 0..{V1_DEGREES}; A is the width of `A deg`, "
                           "N = floor(A x 250/185 + 1/2))",
                "µs": f"µs (all {V1_US} or more)"}
        notes.append("add-on 1.x export: positions read as " + "; ".join(
            f"{said[unit]}: {', '.join(names)}" for unit, names in units.items())
            + " (PCA9685 counts need --ticks HZ)")
    return Keyframes(format="blender", channels=tuple(sorted(channels.values(), key=lambda c: c.index)),
                     tracks=tuple(tracks), notes=tuple(notes))
