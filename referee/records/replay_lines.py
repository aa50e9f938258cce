"""The replay's hot records (frames, sensor events, estimates) as text, formatted by hand
byte for byte as `json.dumps(sort_keys=True)` writes them, floats rounded to DECIMALS places,
at a fraction of its cost (docs/decisions/0023-replay-lines-formatted-by-hand.md).

Each function raises TypeError, ValueError or KeyError where a value is not one it formats
(not a finite float, an int, a string or None): the writer then lets JSON's encoder write it.
"""

from __future__ import annotations

import functools
import json
import math
import re
from collections.abc import Iterable, Sequence
from typing import Any, Protocol

from referee.records.canonical import DECIMALS


class Detected(Protocol):
    """What the replay keeps of a sensor detection (`arena.sensing.events.Detection`)."""

    @property
    def time(self) -> float: ...
    @property
    def kind(self) -> str: ...
    @property
    def beacon(self) -> str | None: ...
    @property
    def source(self) -> int: ...
    @property
    def beam(self) -> tuple[float, float, float, float] | None: ...


Pose = tuple[float, float, float]  # x, y, heading
Frame = tuple[float, list[Pose]]  # time, every robot's pose

_FIXED = f"%.{DECIMALS}f"


def number(value: float) -> str:
    """A float rounded to DECIMALS places as JSON writes it: the repr of `round(value,
    DECIMALS)`; TypeError unless it is a finite float. Between 1e-4 and 1e6 in size, `%.9f`
    gives the same decimal as round() (both are correctly rounded), and with at most 15
    significant digits that decimal, trailing zeros dropped, is also repr's shortest form."""
    if type(value) is float and 1e-4 <= abs(value) < 1e6:
        text = (_FIXED % value).rstrip("0")
        return text + "0" if text[-1] == "." else text
    text = float.__repr__(round(value, DECIMALS))
    if "n" in text:  # nan, inf
        raise TypeError("not finite")
    return text


_TRAILING_ZEROS = re.compile("0+\n")


def numbers(values: list[float]) -> list[str]:
    """`number` of each value, formatted at once: one `%` for all of them and one pass to
    drop their trailing zeros; the few outside the fast range (a heading near 0) one by one."""
    if not values or set(map(type, values)) != {float}:  # every one a float, checked at C speed
        return list(map(number, values))
    text = _TRAILING_ZEROS.sub("\n", (_FIXED + "\n") * len(values) % tuple(values)).replace(".\n", ".0\n")
    if "n" in text:  # nan, inf
        raise TypeError("not finite")
    texts = text.split("\n")
    if not (1e-4 <= min(map(abs, values)) and max(map(abs, values)) < 1e6):
        for i, v in enumerate(values):
            if not 1e-4 <= abs(v) < 1e6:
                texts[i] = number(v)
    return texts[:-1]


@functools.cache
def _string(value: str | None) -> str:
    """A string (beacon ids, event kinds: a handful per match) or None as JSON."""
    return json.dumps(value)


@functools.lru_cache(maxsize=1024)
def _place(x: float, y: float, x_sign: float, y_sign: float) -> str:
    """A point as two `number`s: a beam's far end, formatted once per beacon. The signs are
    part of the key, since 0.0 and -0.0 are one key but two texts."""
    return number(x) + "," + number(y)


def _floats(values: Iterable[float]) -> str:
    return "[" + ",".join(map(number, values)) + "]"


def rounded(values: Iterable[float]) -> list[float]:
    """The values rounded as the replay keeps them (for JSON's encoder to write)."""
    return [round(v, DECIMALS) for v in values]


def _int(value: int) -> str:
    if type(value) is not int:
        raise TypeError("not an int")
    return int.__repr__(value)


_EVENT = '{"b":%s,"k":"e","kind":%s,"line":%s,"r":%s,"s":%s,"t":%s}'


def _beam(x: str, y: str, bx: float, by: float) -> str:
    """A beam as JSON: the laser's place (formatted) and its far end, a beacon's place: a
    handful per match, each formatted once."""
    return "[" + x + "," + y + "," + _place(bx, by, math.copysign(1.0, bx), math.copysign(1.0, by)) + "]"


def event_line(f: dict[str, Any]) -> str:
    """An `e` record's fields (t, r, s, kind, b, line) as its line."""
    if len(f) != 6:
        raise KeyError("fields")
    beam = f["line"]
    if beam is not None:
        x, y, bx, by = beam
        beam = _beam(number(x), number(y), bx, by)
    return _EVENT % (_string(f["b"]), _string(f["kind"]), beam or "null", _int(f["r"]), _int(f["s"]), number(f["t"]))


def event_lines(slot: int, detections: Sequence[Detected]) -> list[str]:
    """The `e` records of one robot's detections, as `event_line` writes each (newline
    included): their numbers formatted at once (`numbers`)."""
    if type(slot) is not int:
        raise TypeError("not an int")
    values: list[float] = []
    for d in detections:
        values.append(d.time)
        if d.beam is not None:
            values += d.beam[:2]
    formatted = iter(numbers(values))
    r, lines = int.__repr__(slot), []
    for d in detections:
        t, beam = next(formatted), d.beam
        text = _beam(next(formatted), next(formatted), *beam[2:]) if beam is not None else "null"
        if type(d.source) is not int:
            raise TypeError("not an int")
        lines.append(_EVENT % (_string(d.beacon), _string(d.kind), text, r, int.__repr__(d.source), t) + "\n")
    return lines


def estimate_line(f: dict[str, Any]) -> str:
    """An `est` record's fields (t, r, e) as its line."""
    if len(f) != 3:
        raise KeyError("fields")
    return '{"e":' + _floats(f["e"]) + ',"k":"est","r":' + _int(f["r"]) + ',"t":' + number(f["t"]) + "}"


def frame_line(time: float, poses: list[Pose]) -> str:
    """One `f` record's line."""
    return '{"k":"f","p":[' + ",".join(map(_floats, poses)) + '],"t":' + number(time) + "}"


def frame_lines(frames: list[Frame]) -> list[str]:
    """The `f` records of `frames` (newline included), their numbers formatted at once."""
    if any(len(p) != 3 for _, poses in frames for p in poses):
        raise ValueError("a pose is (x, y, heading)")
    formatted = iter(numbers([v for time, poses in frames for v in (time, *(u for p in poses for u in p))]))
    lines = []
    for _, poses in frames:
        t = next(formatted)
        p = ",".join("[" + next(formatted) + "," + next(formatted) + "," + next(formatted) + "]" for _ in poses)
        lines.append('{"k":"f","p":[' + p + '],"t":' + t + "}\n")
    return lines
