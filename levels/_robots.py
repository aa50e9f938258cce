"""A level file's `robots` and `laser`: each robot's model (with its drive errors and silhouette),
start pose, placement, laser and path, and the checks across them (slots, the beam's turn per
physics step) (docs/levels.md, docs/drive.md)."""

from __future__ import annotations

import dataclasses
import math

from levels import yaml_reader as yr
from levels._geometry import inside, pose
from levels.model import DriveErrors, Field, Laser, Placement, RobotSlot, Task
from levels.robot_models import ROBOT_MODELS

ROBOT_KEYS = ("slot", "model", "start", "placement", "start_known", "laser", "path", "drive", "silhouette")
LASER_KEYS = ("angular_velocity", "index", "beam_offset", "height")
PLACEMENT_KEYS = ("position", "heading", "region")
DRIVE_KEYS = tuple(f.name for f in dataclasses.fields(DriveErrors))
# Largest allowed value per drive key: spreads stay far from a negative gain or track, a
# dead band below top speed, slips below the whole motion.
DRIVE_MAX = {
    "gain_sd": 0.2,
    "radius_sd": 0.2,
    "track_sd": 0.2,
    "dead_band": 0.9,
    "turn_slip": 0.9,
    "turn_slip_sd": 0.5,
    "accel_slip": 0.9,
}


def laser(m: yr.Map) -> Laser:
    """A spinning laser: its rate (rad/s, not zero), index pulse, beam offset and height."""
    w = m.req("angular_velocity", yr.number)
    if w == 0:
        raise m.ctx.fail(m.raw("angular_velocity").line, m.key("angular_velocity"), "must not be zero")
    return Laser(
        angular_velocity=w,
        index=m.opt("index", yr.flag, False),
        beam_offset=m.opt("beam_offset", yr.length_signed, 0.0),
        height=m.opt("height", yr.nonnegative, 0.0) * m.ctx.scale,
    )


def robots(
    top: yr.Map,
    fld: Field,
    default_laser: Laser,
    task: Task,
    shared_path: tuple[tuple[float, float], ...],
    physics_rate: int,
) -> list[RobotSlot]:
    """The robots in file order: at least one, slots 0..n-1 once each, no beam turning a
    quarter turn or more in one physics step."""
    ctx = top.ctx
    robot_nodes = top.seq("robots")
    if not robot_nodes:
        raise ctx.fail(top.raw("robots").line, "robots", "at least one robot is required")
    out = [robot(ctx, n, k, i, fld, default_laser, task, shared_path) for i, (n, k) in enumerate(robot_nodes)]
    for r, (node, _key) in zip(out, robot_nodes):
        turn = (abs(r.laser.angular_velocity) + 2 * r.model.max_wheel_speed / r.model.track) / physics_rate
        if turn >= math.pi / 2:
            where = top.raw("laser") if r.laser is default_laser else node
            raise ctx.fail(
                where.line,
                "laser.angular_velocity",
                f"the beam would turn {math.degrees(turn):.0f} deg per physics step; keep it "
                f"under 90 by raising physics_rate",
            )
    slots = sorted(r.slot for r in out)
    if slots != list(range(len(out))):
        raise ctx.fail(top.raw("robots").line, "robots", f"slots must be 0..{len(out) - 1} once each, got {slots}")
    return out


def robot(
    ctx: yr.Context,
    node: yr.Node,
    key: str,
    index: int,
    fld: Field,
    default_laser: Laser,
    task: Task,
    shared_path: tuple[tuple[float, float], ...],
) -> RobotSlot:
    """One robot: its model, a start whose footprint lies inside the field, its laser and path."""
    m = yr.Map(ctx, node, key, ROBOT_KEYS)
    model_name = m.opt("model", yr.choice(*ROBOT_MODELS), "boe-bot")
    model = ROBOT_MODELS[model_name]
    if m.has("drive"):
        model = dataclasses.replace(model, drive=_drive(m.sub("drive", DRIVE_KEYS), model.drive))
    if m.has("silhouette"):  # the radius of what this robot puts in the laser plane
        model = dataclasses.replace(model, silhouette_radius=m.req("silhouette", yr.length))
    start = m.req("start", pose)
    line = m.raw("start").line
    inside(ctx, fld, (start.x, start.y), line, m.key("start"), "start")
    c, s = math.cos(start.heading), math.sin(start.heading)
    for dx in (-model.length / 2, model.length / 2):
        for dy in (-model.width / 2, model.width / 2):
            corner = (start.x + c * dx - s * dy, start.y + s * dx + c * dy)
            if not fld.contains(*corner):
                raise ctx.fail(
                    line, m.key("start"), f"the {model_name} footprint at this start pose reaches outside the field"
                )
    robot_laser = laser(m.sub("laser", LASER_KEYS)) if m.has("laser") else default_laser
    path = _path(m, fld, task, shared_path)
    return RobotSlot(
        slot=m.opt("slot", yr.count, index),
        model=model,
        start=start,
        laser=robot_laser,
        start_known=m.opt("start_known", yr.flag, False),
        path=path,
        placement=_placement(m.sub("placement", PLACEMENT_KEYS), fld) if m.has("placement") else Placement(),
    )


def _path(
    m: yr.Map, fld: Field, task: Task, shared_path: tuple[tuple[float, float], ...]
) -> tuple[tuple[float, float], ...]:
    """A robot's own path, else the task's; a race robot, and a waypoints robot with no task
    path to share, must name one."""
    if m.has("path"):
        if task.kind not in ("waypoints", "race"):
            raise m.ctx.fail(m.raw("path").line, m.key("path"), f"not used by a {task.kind} task")
        path: tuple[tuple[float, float], ...] = m.req("path", yr.points)
        for i, p in enumerate(path):
            inside(m.ctx, fld, p, m.raw("path").line, f"{m.key('path')}[{i}]", "waypoint")
        return path
    if task.kind == "race" or (task.kind == "waypoints" and not shared_path):
        raise m.ctx.fail(
            m.node.line,
            m.key("path"),
            f"missing required key (no task.path to share, and a {task.kind} robot needs a path)",
        )
    return shared_path


def _drive(m: yr.Map, base: DriveErrors) -> DriveErrors:
    """A robot's drive errors: the model's, with the keys the level gives replaced."""
    values = {}
    for key in DRIVE_KEYS:
        if m.has(key):
            v = m.req(key, yr.nonnegative)
            if v > DRIVE_MAX.get(key, math.inf):
                raise m.ctx.fail(m.raw(key).line, m.key(key), f"must be at most {DRIVE_MAX[key]:g}, got {v:g}")
            values[key] = v
    return dataclasses.replace(base, **values)


def _placement(m: yr.Map, fld: Field) -> Placement:
    """How a robot is set down around its nominal start (and each trial's pose)."""
    if m.has("position") and m.has("region"):
        raise m.ctx.fail(m.raw("region").line, m.key("region"), "give a position spread or a region, not both")
    region = m.opt("region", yr.rectangle, None)
    if region is not None:
        for corner in (region[:2], region[2:]):
            inside(m.ctx, fld, corner, m.raw("region").line, m.key("region"), "corner")
    return Placement(
        position=m.opt("position", yr.nonnegative, 0.0) * m.ctx.scale,
        heading=m.opt("heading", yr.half_turn, 0.0),
        region=region,
    )
