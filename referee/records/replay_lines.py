"""The replay's hot records (frames, sensor events, estimates) as text, formatted by hand
byte for byte as `json.dumps(sort_keys=True)` writes them, floats rounded to DECIMALS places,
at a fraction of its cost (docs/decisions/0023-replay-lines-formatted-by-hand.md).

Each function raises TypeError, ValueError or KeyError where a value is not one it formats
(not a finite float, an int, a string or None): the writer then lets JSON's encoder write it.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import operator
from collections.abc import Iterable, Sequence
from typing import Any, Protocol

import numpy as np

from referee.records import decimals
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


Frame = list[float]  # as its line holds it: every robot's x, y and heading, then the time

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


def numbers(values: list[float]) -> list[str]:
    """`number` of each value, formatted at once: in one compiled call (`decimals.write_fixed`)
    where every one is a float it writes, else one by one."""
    if not values or set(map(type, values)) != {float}:  # every one a float, checked at C speed
        return list(map(number, values))
    out = np.empty(decimals.WIDTH * len(values), np.uint8)
    size = decimals.write_fixed(np.array(values), out)
    if size == decimals.NOT_FINITE:
        raise TypeError("not finite")
    if size == decimals.OWN_FORM:  # zero, under 1e-4 once rounded, or 1e6 and more
        return list(map(number, values))
    texts = out[:size].tobytes().decode("ascii").split("\n")
    texts.pop()  # after the last newline
    return texts


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


_EVENT_FIELDS = operator.attrgetter("time", "kind", "beacon", "source", "beam")
_ONES = itertools.repeat(1.0)


@functools.cache
def _event_head(beacon: str | None, kind: str) -> str:
    """An `e` record's line up to its beam: its beacon and kind (a handful per match)."""
    return '{"b":' + _string(beacon) + ',"k":"e","kind":' + _string(kind) + ',"line":'


_EVENT_TAIL = ',"r":%d,"s":%d,"t":%s}\n'  # an `e` record's line from its beam's end


def event_lines(robots: Sequence[Sequence[Detected]]) -> list[str]:
    """The `e` records of every robot's detections (robot k's are `robots[k]`), as
    `event_line` writes each (newline included), a text per robot: their fields taken as
    columns, all their numbers formatted by one `numbers`, each robot's lines by one `%`."""
    counts = list(map(len, robots))
    detections = list(itertools.chain.from_iterable(robots))
    if not detections:
        return [""] * len(robots)
    slots = itertools.chain.from_iterable(map(itertools.repeat, range(len(robots)), counts))
    times, kinds, beacons, sources, beams = zip(*map(_EVENT_FIELDS, detections))
    if set(map(type, sources)) != {int}:
        raise TypeError("not an int")
    heads, n = map(_event_head, beacons, kinds), len(times)
    lined = [b for b in beams if b is not None]
    if set(map(len, lined)) - {4}:
        raise ValueError("a beam is (x, y, beacon x, beacon y)")
    xs, ys, bxs, bys = zip(*lined) if lined else ((), (), (), ())
    texts = numbers([*times, *xs, *ys])
    places = map(_place, bxs, bys, map(math.copysign, _ONES, bxs), map(math.copysign, _ONES, bys))
    if len(lined) == n:  # every one with its beam (as a rule)
        form, size = "%s[%s,%s,%s]" + _EVENT_TAIL, 7
        fields = zip(heads, texts[n : 2 * n], texts[2 * n :], places, slots, sources, texts[:n])
    else:
        x, y = iter(texts[n : n + len(lined)]), iter(texts[n + len(lined) :])
        beam_texts = ["null" if b is None else "[" + next(x) + "," + next(y) + "," + next(places) + "]" for b in beams]
        form, size = "%s%s" + _EVENT_TAIL, 5
        fields = zip(heads, beam_texts, slots, sources, texts[:n])
    values, out, at = tuple(itertools.chain.from_iterable(fields)), [], 0
    for count in counts:
        out.append(form * count % values[at : at + size * count])
        at += size * count
    return out


def estimate_line(f: dict[str, Any]) -> str:
    """An `est` record's fields (t, r, e) as its line."""
    if len(f) != 3:
        raise KeyError("fields")
    return '{"e":' + _floats(f["e"]) + ',"k":"est","r":' + _int(f["r"]) + ',"t":' + number(f["t"]) + "}"


def frame_line(time: float, poses: Sequence[Sequence[float]]) -> str:
    """One `f` record's line."""
    return '{"k":"f","p":[' + ",".join(map(_floats, poses)) + '],"t":' + number(time) + "}"


@functools.cache
def _frame_format(size: int) -> str:
    """An `f` record's line for a `Frame` of `size` numbers, the numbers left to `%`."""
    if size % 3 != 1:
        raise ValueError("a frame is (x, y, heading) per robot, then the time")
    return '{"k":"f","p":[' + ",".join(["[%s,%s,%s]"] * (size // 3)) + '],"t":%s}\n'


def frame_lines(frames: list[Frame]) -> str:
    """The `f` records of `frames` (newline included), at once: their numbers formatted by
    one `numbers`, in the order the lines hold them, and every line by one `%`."""
    values = list(itertools.chain.from_iterable(frames))
    return "".join(map(_frame_format, map(len, frames))) % tuple(numbers(values))


def frame_poses(frame: Frame) -> list[list[float]]:
    """A `Frame`'s poses, each [x, y, heading]."""
    return [frame[i : i + 3] for i in range(0, len(frame) - 1, 3)]
