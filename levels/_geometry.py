"""A level file's ground: the `field`, its `obstacles` and the `floor` (tilt and tiles), and
what every section placing something on it shares: poses, and points checked to lie inside
the field (docs/levels.md)."""

from __future__ import annotations

import math

from levels import checks
from levels import yaml_reader as yr
from levels.model import Field, Floor, Obstacle, Pose, Tiles

FIELD_KEYS = ("size", "origin", "walls")
OBSTACLE_KEYS = ("kind", "center", "size", "angle", "radius", "points")
FLOOR_KEYS = ("tilt", "tilt_length", "tiles")


def pose(ctx: yr.Context, node: yr.Node, key: str) -> Pose:
    """A pose [x, y, heading_deg], in the file's length unit and degrees."""
    x, y, h = yr.numbers(ctx, node, key, 3, "a pose [x, y, heading_deg]")
    return Pose(x * ctx.scale, y * ctx.scale, math.radians(h))


def inside(ctx: yr.Context, fld: Field, p: tuple[float, float], line: int, key: str, what: str) -> None:
    """Refuse a point outside the field; `what` names it in the error (`beacon`, `goal`)."""
    if not fld.contains(*p):
        s = ctx.scale
        raise ctx.fail(
            line,
            key,
            f"{what} ({p[0] / s:g}, {p[1] / s:g}) is outside the field "
            f"[{fld.xmin / s:g}..{fld.xmax / s:g}] x [{fld.ymin / s:g}..{fld.ymax / s:g}]",
        )


def field(m: yr.Map) -> Field:
    """The field's rectangle, and whether walls close it."""
    return Field(
        origin=m.opt("origin", yr.point, (0.0, 0.0)),
        size=m.req("size", yr.size),
        walls=m.opt("walls", yr.flag, True),
    )


def obstacle(ctx: yr.Context, node: yr.Node, key: str, fld: Field) -> Obstacle:
    """A circle, a box (turned by `angle` degrees) or a convex polygon."""
    m = yr.Map(ctx, node, key, OBSTACLE_KEYS)
    kind = m.req("kind", yr.choice("box", "circle", "polygon"))
    if kind == "circle":
        c = m.req("center", yr.point)
        inside(ctx, fld, c, m.raw("center").line, m.key("center"), "centre")
        return Obstacle("circle", (c,), m.req("radius", yr.length))
    if kind == "box":
        (cx, cy), (w, h) = m.req("center", yr.point), m.req("size", yr.size)
        inside(ctx, fld, (cx, cy), m.raw("center").line, m.key("center"), "centre")
        a = math.radians(m.opt("angle", yr.number, 0.0))
        ca, sa = math.cos(a), math.sin(a)
        corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
        return Obstacle("polygon", tuple((cx + ca * x - sa * y, cy + sa * x + ca * y) for x, y in corners))
    pts = m.req("points", yr.points)
    if len(pts) < 3:
        raise ctx.fail(m.raw("points").line, m.key("points"), "a polygon needs at least 3 points")
    why = checks.convex_problem(pts)
    if why:
        raise ctx.fail(m.raw("points").line, m.key("points"), why)
    for i, p in enumerate(pts):
        inside(ctx, fld, p, m.raw("points").line, f"{m.key('points')}[{i}]", "point")
    return Obstacle("polygon", pts)


def floor(m: yr.Map, fld: Field) -> Floor:
    """The floor's tilt (RMS slope per axis in degrees, below 45; its correlation length) and
    the tiles trials are measured by."""
    tilt = m.opt("tilt", yr.nonnegative, 0.0)
    if tilt >= 45:
        raise m.ctx.fail(m.raw("tilt").line, m.key("tilt"), f"must be below 45 degrees, got {tilt:g}")
    tiles = None
    if m.has("tiles"):
        t = m.sub("tiles", ("origin", "spacing_error", "angle_error"))
        origin = t.req("origin", yr.point)
        inside(m.ctx, fld, origin, t.raw("origin").line, t.key("origin"), "origin")
        spacing = t.opt("spacing_error", yr.nonnegative, 0.0)
        if spacing >= 0.5:
            raise m.ctx.fail(t.raw("spacing_error").line, t.key("spacing_error"), f"must be below 0.5, got {spacing:g}")
        angle = t.opt("angle_error", yr.nonnegative, 0.0)
        if angle >= 45:
            raise m.ctx.fail(
                t.raw("angle_error").line, t.key("angle_error"), f"must be below 45 degrees, got {angle:g}"
            )
        tiles = Tiles(origin=origin, spacing_error=spacing, angle_error=math.radians(angle))
    return Floor(
        tilt=math.tan(math.radians(tilt)),
        tilt_length=m.opt("tilt_length", yr.length, 1.0),
        tiles=tiles,
    )
