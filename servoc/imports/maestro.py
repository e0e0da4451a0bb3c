"""Reader for Pololu Maestro Control Center settings files (XML, root `<UscSettings>`).

Input: what "File > Save settings file..." writes. The parts read here:

    <UscSettings version="1">
      <Channels ...>            <!-- 6 <Channel> (Micro Maestro) or 12, 18, 24 (Mini Maestro) -->
        <Channel name="jaw" mode="Servo" min="4000" max="8000" homemode="Goto" home="6000" ... />
      </Channels>
      <Sequences>
        <Sequence name="Wave">
          <Frame name="Frame 0" duration="500">6000 0 4000 0 0 0</Frame>
          <Frame name="Frame 1" duration="250">6000 0 4000 0 0 0 s 0 0 20 0 0 0 a 0 0 4 0 0 0</Frame>
    ...

Positions, `min`, `max` and `home` are quarter-µs (4000 = 1000 µs). A frame's text is one
target per channel in channel order (older Control Centers); newer ones follow the targets
with `s` and a speed per channel, then `a` and an acceleration per channel. Only the
targets (the part before `s`) are used.

Output: `Keyframes(format="maestro")`:
- channels: each `<Channel>` whose mode is `Servo` or `ServoMultiplied` (a servo the Maestro
  pulses at a multiplied period). The others (`Output`, `Input`) are not servos: left out,
  their targets dropped from every key, with a note. No mode = `Servo` (the Maestro's
  default). index = position in `<Channels>`; name = `name` unless blank; min_us/max_us
  from `min`/`max`; home_us from `home` only when `homemode` is `Goto`; speed_us_s from
  `speed` (Maestro units of 0.25 µs per 10 ms, so 25 µs/s each; 0 = no limit: None) and
  the frames' own speeds (below).
- tracks: one per `<Sequence>`, paced as the Maestro plays it (see `Track`): named as
  written ("Sequence N" when unnamed, a repeated name gets " (2)", " (3)", ...). A
  sequence without frames is an empty one; a file without sequences gives no tracks
  (with a note).
- keys: one per `<Frame>`, at the frame's start (`at_ms`: the sum of the durations
  before it); the track lasts the sum of all of them. A target of 0 means the channel
  keeps its target: left out of `Key.targets` (a frame that sets nothing is a pause).
  A target outside the channel's `min`..`max` is clamped there, and so is a `home` (a note
  counts them).
  Every key's `speeds` are the frame's own (after `s`) where it has them, else the
  channels' (µs/s; 0 = as fast as the servo allows). A channel's `speed_us_s`, which the
  writer declares as the servo's speed, is the fastest it is asked to go: its channel
  speed, or a frame's own speed for it above that (None when either is 0: no limit).
  `Key.source` is e.g. "Wave frame 1", plus the frame's name in brackets when not the
  default "Frame 1".
- not imported (with a note when present): accelerations (channels' and frames'), the
  `<Script>`. `ReadOptions` is unused: positions are always quarter-µs.
- errors, as `ImportError_` naming the file, sequence and frame: not XML or truncated, any
  DOCTYPE or entity declaration, a root other than `<UscSettings>`, no `<Channel>` in
  `<Channels>`, an unknown mode or homemode, a value (target, speed, min, max, home,
  duration) not a whole number 0..65535, no duration, more targets than channels.
"""

from __future__ import annotations

import dataclasses
import re
import xml.etree.ElementTree as ET
from fractions import Fraction
from xml.parsers import expat

from .keyframes import Channel, ImportError_, Key, Keyframes, ReadOptions, Track, check_frames

_HEAD = re.compile(r"\s*(<\?xml[^>]*\?>\s*)?(<!--.*?-->\s*|<!DOCTYPE[^\[>]*(\[.*?\])?\s*>\s*)*<UscSettings[\s/>]",
                   re.S)     # a DOCTYPE is recognised here so that `read` can refuse it by name
_NOT_SERVO = {"input": "Input", "output": "Output"}
_SERVO = ("servo", "servomultiplied")     # ServoMultiplied: a servo pulsed at a multiple of the period
SPEED_UNIT_US_S = 25                      # a Maestro speed of 1 is 0.25 µs per 10 ms


def sniff(data: bytes, path: str) -> bool:
    """True when the content starts like a Maestro settings file: XML whose root is <UscSettings>."""
    try:
        head = data[:65536]
        utf16 = head[:2] in (b"\xff\xfe", b"\xfe\xff")
        return bool(_HEAD.match(head.decode("utf-16" if utf16 else "utf-8", errors="replace").lstrip("\ufeff")))
    except Exception:
        return False


def _parse(data: bytes, path: str) -> ET.Element:
    """The XML as an Element tree, refusing any DOCTYPE or entity declaration.

    Hardening with the standard library only: expat reports a DOCTYPE as it starts, before
    any entity in it is declared, and we raise there. With no DTD no entity can be defined
    (no "billion laughs" expansion) nor any external one referenced (a reference to an
    undeclared entity is an XML error). A Maestro settings file never has a DOCTYPE.
    """
    def refuse(*_):
        raise ImportError_(f"{path}: the XML has a DOCTYPE or entity declaration: refused "
                           f"(a Maestro settings file has none)")
    builder, parser = ET.TreeBuilder(), expat.ParserCreate()
    parser.StartDoctypeDeclHandler = parser.EntityDeclHandler = refuse
    parser.UnparsedEntityDeclHandler = parser.ExternalEntityRefHandler = refuse
    parser.StartElementHandler, parser.EndElementHandler = builder.start, builder.end
    parser.CharacterDataHandler = builder.data
    try:
        parser.Parse(data, True)
        return builder.close()
    except (expat.ExpatError, ValueError, AssertionError) as e:
        raise ImportError_(f"{path}: not a readable XML file ({e})") from None


def _u16(text, where: str, what: str) -> int:
    """A whole number 0..65535 (the Maestro keeps these as unsigned 16 bits), or ImportError_."""
    if text is None or not re.fullmatch(r"[0-9]+", text.strip()) or int(text) > 65535:
        raise ImportError_(f"{where}: {what} must be a whole number from 0 to 65535, not {text!r}")
    return int(text)


def _channels(root: ET.Element, path: str, notes: list):
    """(the servo Channels, how many <Channel> there are)."""
    element = root.find("Channels")
    items = [] if element is None else element.findall("Channel")
    if not items:
        raise ImportError_(f"{path}: no <Channel> in <Channels>: not a complete Maestro settings file")
    servos, others = [], []
    for index, ch in enumerate(items):
        where, mode = f"{path}: channel {index}", (ch.get("mode") or "Servo").strip().lower()
        if mode in _NOT_SERVO:
            others.append(f"{index} ({_NOT_SERVO[mode]})")
            continue
        if mode not in _SERVO:
            raise ImportError_(f"{where}: unknown mode {ch.get('mode')!r} (Servo, ServoMultiplied, Input, Output)")
        homemode = (ch.get("homemode") or "Off").strip().lower()
        if homemode not in ("goto", "off", "ignore"):
            raise ImportError_(f"{where}: unknown homemode {ch.get('homemode')!r} (Goto, Off, Ignore)")
        us = {k: None if ch.get(k) is None else Fraction(_u16(ch.get(k), where, k), 4) for k in ("min", "max", "home")}
        if us["min"] is not None and us["max"] is not None and us["min"] > us["max"]:
            raise ImportError_(f"{where}: min ({ch.get('min')}) is above max ({ch.get('max')})")
        home = us["home"] if homemode == "goto" and us["home"] else None
        speed = _u16(ch.get("speed", "0") or "0", where, "speed") * SPEED_UNIT_US_S or None
        servos.append(Channel(index, (ch.get("name") or "").strip() or None, us["min"], us["max"], home,
                              Fraction(speed) if speed else None))
    if others:
        notes.append(f"Channels whose mode is not Servo, left out with their targets: {', '.join(others)}.")
    if any(ch.get("acceleration", "0").strip() not in ("", "0") for ch in items):
        notes.append("The channels' acceleration limits are not imported: each move is at constant speed.")
    return servos, len(items)


def _targets(text: str, where: str, count: int):
    """(the frame's targets, its speeds or None, whether it sets an acceleration): all of the
    text is targets (older form), or the part before `s`; speeds follow `s`, accelerations `a`."""
    tokens = text.split()
    s, a = tokens.count("s"), tokens.count("a")
    if s > 1 or a > 1 or (a and not s) or (s and a and tokens.index("a") < tokens.index("s")):
        raise ImportError_(f"{where}: expected 'targets' or 'targets s speeds a accelerations', not {text.strip()!r}")
    cut = tokens.index("s") if s else len(tokens)
    a_at = tokens.index("a") if a else len(tokens)
    speeds = [_u16(t, where, "a speed") for t in tokens[cut + 1:a_at]]
    accelerations = [_u16(t, where, "an acceleration") for t in tokens[a_at + 1:]]
    if cut > count:
        raise ImportError_(f"{where}: {cut} targets, but the file has only {count} channels")
    return [_u16(t, where, "a target (quarter-µs)") for t in tokens[:cut]], speeds if s else None, any(accelerations)


def read(data: bytes, path: str, options: ReadOptions) -> Keyframes:
    """The Maestro settings file `data` (read from `path`) as Keyframes; see the module docstring."""
    root = _parse(data, path)
    check_frames(sum(1 for _ in root.iter("Frame")), path)
    if root.tag != "UscSettings":
        raise ImportError_(f"{path}: the root element is <{root.tag}>, not <UscSettings>: not a Maestro settings file")
    notes = []
    channels, count = _channels(root, path, notes)
    servo = {c.index for c in channels}
    channel_speed = {c.index: c.speed_us_s or Fraction(0) for c in channels}      # µs/s, 0: no limit
    tracks, taken, limited = [], set(), False
    bounds = {c.index: (c.min_us, c.max_us) for c in channels}
    clamped: list[str] = []

    def clamp(ch: int, us: Fraction | None, source: str) -> Fraction | None:
        """A target (or home) outside the channel's min..max, clamped there as the Maestro does."""
        if us is None:
            return None
        lo, hi = bounds[ch]
        kept = min(max(us, lo if lo is not None else us), hi if hi is not None else us)
        if kept != us:
            clamped.append(f"{source}, channel {ch}")
        return kept

    channels = [dataclasses.replace(c, home_us=clamp(c.index, c.home_us, "home")) for c in channels]

    sequences = [] if root.find("Sequences") is None else root.find("Sequences").findall("Sequence")
    for number, seq in enumerate(sequences, 1):
        name = unique = seq.get("name") or f"Sequence {number}"
        n = 2
        while unique in taken:
            unique, n = f"{name} ({n})", n + 1
        taken.add(unique)
        keys, at, label = [], Fraction(0), " ".join(unique.split())
        for i, frame in enumerate(seq.findall("Frame")):
            fname = " ".join((frame.get("name") or "").split())
            where = f"{path}: sequence {name!r}, frame {i}" + (f" ({fname!r})" if fname else "")
            if frame.get("duration") is None:
                raise ImportError_(f"{where}: no duration")
            duration = _u16(frame.get("duration"), where, "the duration (ms)")
            targets, speeds, accelerated = _targets("".join(frame.itertext()), where, count)
            limited |= accelerated
            source = f"{label} frame {i}" + (f" ({fname})" if fname and fname != f"Frame {i}" else "")
            own = {} if speeds is None else {ch: Fraction(v * SPEED_UNIT_US_S) for ch, v in enumerate(speeds)}
            keys.append(Key(at, {ch: clamp(ch, Fraction(t, 4), source) for ch, t in enumerate(targets)
                                 if t and ch in servo}, source,
                            {ch: own.get(ch, channel_speed[ch]) for ch in servo}))
            at += duration
        tracks.append(Track(unique, tuple(keys), paced=True, length_ms=at))     # one without frames: empty
    top = dict(channel_speed)                # a servo's top speed: the fastest it is asked to go (0: no limit)
    for key in (k for t in tracks for k in t.keys):
        for ch in key.targets:
            v = key.speeds[ch]
            top[ch] = 0 if not v or not top[ch] else max(top[ch], v)
    channels = [dataclasses.replace(c, speed_us_s=top[c.index] or None) for c in channels]
    if limited:
        notes.append("The frames' own accelerations (after 'a') are not imported: each move is at constant speed.")
    if clamped:
        notes.append(f"{len(clamped)} target{'s' if len(clamped) != 1 else ''} outside the channel's min..max "
                     f"clamped there, as the Maestro does (first: {clamped[0]}).")     # a home counts as one
    if not sequences:
        notes.append("The file has no sequences.")
    if (root.findtext("Script") or "").strip():
        notes.append("The file's <Script> is not imported, only its sequences.")
    return Keyframes("maestro", tuple(channels), tuple(tracks), tuple(notes))
