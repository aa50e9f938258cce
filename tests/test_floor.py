"""The floor (arena.floor): a tilt that leans each robot so its beam leaves beside its base,
checked against geometry worked out here, and gone when ideal."""

import math

import numpy as np
import pytest
from helpers import ONE, TABLE, edited, hits, sense

from arena import floor
from arena.level import Pose
from arena.loader import parse_level
from arena.rng import RandomTree
from arena.world import World

IN = 0.0254


def height_at(t: floor.Tilt, x: float, y: float) -> float:
    """The floor's height at (x, y), summed from the tilt's plane waves."""
    return float(t.amp * np.cos(t.k[:, 0] * x + t.k[:, 1] * y + t.phase).sum())


def test_the_tilt_is_the_slope_of_the_floors_height():
    t = floor.Tilt(math.radians(2.0), 0.3, np.random.default_rng(4))
    h = 1e-6
    for x, y in np.random.default_rng(5).uniform(-1, 1, size=(20, 2)):
        gx, gy = t.slope(np.array(x), np.array(y))
        assert float(gx) == pytest.approx((height_at(t, x + h, y) - height_at(t, x - h, y)) / (2 * h), abs=1e-7)
        assert float(gy) == pytest.approx((height_at(t, x, y + h) - height_at(t, x, y - h)) / (2 * h), abs=1e-7)


def test_the_tilt_has_the_levels_rms_slope():
    """Over many floors the slope along each axis has the RMS the level gives (sampling error of
    800 values: about 2.5 %)."""
    rms = math.tan(math.radians(0.3))
    slopes = []
    for seed in range(800):
        t = floor.Tilt(rms, 12 * IN, np.random.default_rng(seed))
        gx, gy = t.slope(np.array(0.4), np.array(-0.7))
        slopes += [float(gx), float(gy)]
    assert math.sqrt(np.mean(np.square(slopes))) == pytest.approx(rms, rel=0.1)


def leaning_table(height: float = 0.3) -> str:
    """The laser test table on a floor tilted 2 deg RMS, its laser `height` m above the base."""
    text = TABLE.format(kind="sensor_array", omega=20.0, robots=ONE, params="  params: {clock_hz: 0}", obstacles="")
    return edited(text, {"floor": {"tilt": 2.0, "tilt_length": 1.0}, "laser.height": height})


def first_hits(start: Pose, origin: tuple[float, float], level, omega: float) -> dict[str, float]:
    """When a beam leaving `origin` (robot at rest at `start`, laser at phase 0 at t = 0) first
    points at each beacon."""
    out = {}
    for b in level.beacons.items:
        direction = math.atan2(b.y - origin[1], b.x - origin[0])
        out[b.id] = ((direction - start.heading) % (2 * math.pi)) / omega
    return out


def test_a_robot_on_a_tilted_floor_sees_the_beacons_from_the_top_of_its_lean():
    """A body square on the floor stands along the floor's normal (-gx, -gy, 1) / |.|: its beam,
    `height` above the base, leaves from base + height (-gx, -gy) / sqrt(1 + gx^2 + gy^2), and
    every crossing is timed from there; --ideal has no tilt, and the beam leaves from the base."""
    level = parse_level(leaning_table().encode(), "t.yaml")
    start = level.robots[0].start
    t = floor.tilt(level.floor, RandomTree(1), ideal=False)  # the match's floor, drawn as sensing draws it
    h = 1e-6
    gx = (height_at(t, start.x + h, start.y) - height_at(t, start.x - h, start.y)) / (2 * h)
    gy = (height_at(t, start.x, start.y + h) - height_at(t, start.x, start.y - h)) / (2 * h)
    norm = math.sqrt(1 + gx * gx + gy * gy)
    top = (start.x - 0.3 * gx / norm, start.y - 0.3 * gy / norm)
    assert math.dist(top, (start.x, start.y)) > 0.003  # leaning by millimetres: the times tell
    leaned, base = first_hits(start, top, level, 20.0), first_hits(start, (start.x, start.y), level, 20.0)
    (events,), _ = sense(World(level), 1.0, ideal=False)
    for b in level.beacons.items:
        assert hits(events, b.id)[0].time == pytest.approx(leaned[b.id], abs=1e-7)
        assert abs(leaned[b.id] - base[b.id]) > 1e-5
    (ideal,), _ = sense(World(level), 1.0, ideal=True)
    for b in level.beacons.items:
        assert hits(ideal, b.id)[0].time == pytest.approx(base[b.id], abs=1e-7)


def test_a_laser_at_the_base_does_not_lean():
    """A beam that leaves at the base (height 0) is not displaced, however tilted the floor."""
    level = parse_level(leaning_table(height=0.0).encode(), "t.yaml")
    start = level.robots[0].start
    base = first_hits(start, (start.x, start.y), level, 20.0)
    (events,), _ = sense(World(level), 1.0, ideal=False)
    for b in level.beacons.items:
        assert hits(events, b.id)[0].time == pytest.approx(base[b.id], abs=1e-7)
