"""Checks of a level beyond its schema: file size, YAML nesting and aliases, convex obstacles,
start poses clear of everything, and enough beacons for a fix. (Whether the default controller
exists is the referee's check, `referee.sandbox.teams.controller_problem`, which the referee
passes to `levels.loader`.)

Each check returns a `Problem` (the dotted key it concerns and a one-line message) or None;
`levels.loader` turns the first problem into a `LevelError` with the key's file line.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import yaml

from levels.model import Level, Obstacle, Pose, RobotModel
from levels.yaml_reader import SAFE_LOADER

MAX_BYTES = 1 << 20  # a level is a page of YAML; a megabyte is already absurd
MAX_DEPTH = 16  # nested mappings and lists; the deepest built-in level nests 4
MAX_NODES = 200_000  # values (scalars, mappings, lists) in the whole file
# Beacons a fix needs: every solver of robots/toolkit/solvers.py works from three bearings
# (ToTal, circle intersection, Newton, Bac's corner table with three of four arrays, the wall
# targets, the lights' law of sines); with fewer, no position can be computed at all.
MIN_BEACONS = {"reflector": 3, "sensor_array": 3, "flash_detector": 3, "light": 3}
EPS = 1e-9


@dataclass(frozen=True)
class Problem:
    """What is wrong with a level: the dotted `key` it concerns, a one-line `message`, and the
    file line when the check knows it better than the key does."""

    key: str
    message: str
    line: int | None = None


def text_problem(data: bytes) -> Problem | None:
    """Size, nesting and alias limits, checked on the YAML event stream before anything is
    composed (PyYAML's parser is iterative, so a 10 000-deep list cannot exhaust the stack here
    the way composing it would). Aliases are refused outright: no level needs one, and a few
    lines of nested aliases ("billion laughs") would expand into millions of values."""
    if len(data) > MAX_BYTES:
        return Problem("(file)", f"{len(data)} bytes; a level file may have at most {MAX_BYTES}")
    text = data.decode("utf-8", errors="replace")
    try:
        return _stream_problem(yaml.parse(text, Loader=SAFE_LOADER))
    except yaml.YAMLError:  # libyaml stops early at its own limits: PyYAML's own parser says why
        pass
    try:
        return _stream_problem(yaml.parse(text, Loader=yaml.SafeLoader))
    except yaml.YAMLError:
        return None  # malformed YAML: the loader's composer reports it with its line


def _stream_problem(events: Iterable[yaml.Event]) -> Problem | None:
    """The first alias, or nesting or count past the limits, in a YAML event stream."""
    depth = values = 0
    for event in events:
        line = event.start_mark.line + 1 if event.start_mark else None  # the parser marks every event
        if isinstance(event, yaml.AliasEvent):
            return Problem("(yaml)", f"aliases (*{event.anchor}) are not allowed in levels", line)
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                return Problem("(yaml)", f"nested deeper than {MAX_DEPTH} levels", line)
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent, yaml.ScalarEvent)):
            values += 1
            if values > MAX_NODES:
                return Problem("(yaml)", f"more than {MAX_NODES} values", line)
    return None


def convex_problem(points: tuple[tuple[float, float], ...]) -> str | None:
    """Why a polygon is not a simple convex one, or None. pymunk would silently use the convex
    hull of a concave outline (and the drawing would not), so such a level is refused: split
    the shape into convex polygons instead."""
    n = len(points)
    turns, sign, area = 0.0, 0.0, 0.0
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = points[i - 1], points[i], points[(i + 1) % n]
        ux, uy, vx, vy = bx - ax, by - ay, cx - bx, cy - by
        if math.hypot(ux, uy) < EPS:
            return f"points {(i - 1) % n} and {i} coincide"
        cross = ux * vy - uy * vx
        scale = math.hypot(ux, uy) * math.hypot(vx, vy)
        if abs(cross) > EPS * scale:
            if sign and (cross > 0) != (sign > 0):
                return f"not convex: the outline turns the other way at point {i}; split it into convex polygons"
            sign = cross
        turns += math.atan2(cross, ux * vx + uy * vy)
        area += ax * by - bx * ay
    if abs(area) < EPS:
        return "the points enclose no area"
    if abs(abs(turns) - 2 * math.pi) > 1e-6:
        return "the outline crosses itself; give the points in order around the polygon"
    return None


def footprint(model: RobotModel, pose: Pose) -> list[tuple[float, float]]:
    """The corners of a robot's body at `pose`, counter-clockwise."""
    c, s = math.cos(pose.heading), math.sin(pose.heading)
    half = (
        (model.length / 2, model.width / 2),
        (-model.length / 2, model.width / 2),
        (-model.length / 2, -model.width / 2),
        (model.length / 2, -model.width / 2),
    )
    return [(pose.x + c * dx - s * dy, pose.y + s * dx + c * dy) for dx, dy in half]


def _separated(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> bool:
    """True if two convex polygons do not overlap (a separating axis exists; touching is apart)."""
    for poly in (a, b):
        for i in range(len(poly)):
            (x0, y0), (x1, y1) = poly[i - 1], poly[i]
            nx, ny = y1 - y0, x0 - x1
            pa = [nx * x + ny * y for x, y in a]
            pb = [nx * x + ny * y for x, y in b]
            if max(pa) <= min(pb) + EPS or max(pb) <= min(pa) + EPS:
                return True
    return False


def _circle_apart(poly: list[tuple[float, float]], centre: tuple[float, float], radius: float) -> bool:
    """True if a circle and a convex polygon do not overlap."""
    px, py = centre
    inside = True
    sign = 0.0
    for i in range(len(poly)):
        (x0, y0), (x1, y1) = poly[i - 1], poly[i]
        cross = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
        if sign and cross * sign < 0:
            inside = False
        sign = sign or cross
        dx, dy = x1 - x0, y1 - y0
        t = max(0.0, min(1.0, ((px - x0) * dx + (py - y0) * dy) / (dx * dx + dy * dy)))
        if math.hypot(x0 + t * dx - px, y0 + t * dy - py) < radius - EPS:
            return False
    return not inside


def _obstacle_apart(body: list[tuple[float, float]], ob: Obstacle) -> bool:
    if ob.kind == "circle":
        return _circle_apart(body, ob.points[0], ob.radius)
    return _separated(body, list(ob.points))


def body_problem(
    level: Level, model: RobotModel, pose: Pose, others: Sequence[list[tuple[float, float]]] = ()
) -> str | None:
    """What a robot's body at `pose` would overlap (an obstacle, a beacon, one of the bodies
    `others`: 'robot k' for the k-th), or None if it stands clear. The field's border is the
    loader's check."""
    body = footprint(model, pose)
    for k, ob in enumerate(level.obstacles):
        if not _obstacle_apart(body, ob):
            return f"obstacles[{k}]"
    for b in level.beacons.items:
        if not _circle_apart(body, (b.x, b.y), level.beacons.radius):
            return f"beacon {b.id}"
    for k, other in enumerate(others):
        if not _separated(body, other):
            return f"robot {k}"
    return None


def start_problem(level: Level) -> Problem | None:
    """A robot whose body, at its start pose, overlaps an obstacle, a beacon or another robot."""
    bodies = [footprint(r.model, r.start) for r in level.robots]
    for i, r in enumerate(level.robots):
        what = body_problem(level, r.model, r.start, bodies[:i])
        if what is not None:
            if what.startswith("robot "):
                what = f"robot slot {level.robots[int(what.split()[1])].slot}"
            return Problem(f"robots[{i}].start", f"the {r.model.name} footprint at this start pose overlaps {what}")
    return None


def beacon_count_problem(level: Level) -> Problem | None:
    """Fewer beacons than any position fix of the level's beacon kind needs."""
    need = MIN_BEACONS[level.beacons.kind]
    have = len(level.beacons.items)
    if have < need:
        return Problem(
            "beacons.items",
            f"{have} {level.beacons.kind} beacon(s); a position fix from bearings needs at least {need}",
        )
    return None


def level_problem(level: Level, contest: bool = True) -> Problem | None:
    """The first problem of a loaded level that the schema alone does not catch; `contest`
    adds the checks that concern a contest rather than the physics (enough beacons)."""
    return (beacon_count_problem(level) if contest else None) or start_problem(level)
