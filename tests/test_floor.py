"""The floor (arena.floor): a tilt that leans each robot so its beam leaves beside its base, and
the tiles trials are measured by; each checked against geometry worked out here, and gone when ideal."""

import math

import numpy as np
import pytest
from helpers import ONE, TABLE, edited, hits, sense, simi_on_tiles

from arena import floor
from arena.placement import starts, trial_poses
from arena.rng import RandomTree
from arena.world import World
from levels.loader import parse_level
from levels.model import Pose
from referee.match.simulation import Simulation

IN = 0.0254


def height_at(t: floor.Tilt, x: float, y: float) -> float:
    """The floor's height at (x, y), summed from the tilt's plane waves."""
    return float(t.amp * np.cos(t.k[:, 0] * x + t.k[:, 1] * y + t.phase).sum())


def slope_at(t: floor.Tilt, x: float, y: float, h: float = 1e-6) -> tuple[float, float]:
    """The floor's slope (dz/dx, dz/dy) at (x, y), by central differences of its height."""
    gx = (height_at(t, x + h, y) - height_at(t, x - h, y)) / (2 * h)
    gy = (height_at(t, x, y + h) - height_at(t, x, y - h)) / (2 * h)
    return gx, gy


def test_a_body_square_on_the_floor_leans_its_top_downhill():
    """A point `height` above the base stands along the floor's normal (-gx, -gy, 1) / |.|: it is
    height (-gx, -gy) / sqrt(1 + gx^2 + gy^2) off the base, horizontally."""
    t = floor.Tilt(math.tan(math.radians(2.0)), 0.3, np.random.default_rng(4))
    points = np.random.default_rng(5).uniform(-1, 1, size=(20, 2, 2))  # 20 steps, 2 robots
    height = np.array([0.3, 0.05])
    dx, dy = t.lean(points[..., 0], points[..., 1], height)
    for i in range(20):
        for j in range(2):
            gx, gy = slope_at(t, *points[i, j])
            norm = math.sqrt(1 + gx * gx + gy * gy)
            assert (dx[i, j], dy[i, j]) == pytest.approx((-height[j] * gx / norm, -height[j] * gy / norm), abs=1e-9)


def test_the_tilt_has_the_levels_rms_slope():
    """Over many floors the slope along each axis has the RMS the level gives (sampling error of
    800 values: about 2.5 %)."""
    rms = math.tan(math.radians(0.3))
    slopes: list[float] = []
    for seed in range(400):
        slopes += slope_at(floor.Tilt(rms, 12 * IN, np.random.default_rng(seed)), 0.4, -0.7)
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
    assert t is not None
    gx, gy = slope_at(t, start.x, start.y)
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


def grid_by_hand(seed: int, spacing: float, angle: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """The real grid's steps per unit of nominal x and y, from the match's four uniform draws."""
    u = 2 * RandomTree(seed).stream("floor", "tiles").random(4) - 1
    sx, sy, ax, ay = 1 + spacing * u[0], 1 + spacing * u[1], angle * u[2], angle * u[3]
    return (sx * math.cos(ax), sx * math.sin(ax)), (-sy * math.sin(ay), sy * math.cos(ay))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_trials_stand_on_the_drawn_tile_grid_laid_out_from_the_true_start(seed):
    """Each trial's true position is the robot's true start plus its tile value's offset from the
    origin tile, laid out along the real grid (each pitch and each set of lines off by the drawn
    error), then set down by hand within the placement's spread; ideal, the grid is square and
    true, and each trial moves by exactly that error's share of its offset."""
    level = simi_on_tiles()
    tiles, spread = level.floor.tiles, level.robots[0].placement.position
    ex, ey = grid_by_hand(seed, tiles.spacing_error, tiles.angle_error)
    assert ex != (1.0, 0.0) and ey != (0.0, 1.0)
    real = Simulation(level, ["idle"], seed=seed)
    ideal = Simulation(level, ["idle"], seed=seed, ideal=True)
    (start,) = real.starts
    assert ideal.starts == real.starts  # the hand placement of the start is the task's, kept when ideal
    for (p,), (q,) in zip(real.trial_poses[1:], ideal.trial_poses[1:]):
        tile = min(
            level.task.trials.positions,
            key=lambda t: math.dist(t, (q.x - start.x + tiles.origin[0], q.y - start.y + tiles.origin[1])),
        )
        dx, dy = tile[0] - tiles.origin[0], tile[1] - tiles.origin[1]
        on_grid = (start.x + dx * ex[0] + dy * ey[0], start.y + dx * ex[1] + dy * ey[1])
        assert math.dist((p.x, p.y), on_grid) <= spread + 1e-12
        assert math.dist((q.x, q.y), (start.x + dx, start.y + dy)) <= spread + 1e-12
        # the same hand placement on both grids: the difference is the grid's error alone
        error = (dx * (ex[0] - 1) + dy * ey[0], dx * ex[1] + dy * (ey[1] - 1))
        assert (p.x - q.x, p.y - q.y) == pytest.approx(error, abs=1e-12)
        assert p.heading == q.heading


def test_the_grid_error_stays_within_its_bounds():
    level = simi_on_tiles()
    tiles = level.floor.tiles
    origin = Pose(*tiles.origin)
    for seed in range(200):
        g = floor.grid(level.floor, RandomTree(seed), ideal=False)
        step = g.place(origin, Pose(tiles.origin[0] + 1.0, tiles.origin[1]))
        across = g.place(origin, Pose(tiles.origin[0], tiles.origin[1] + 1.0))
        assert abs(math.hypot(step.x - origin.x, step.y - origin.y) - 1) <= tiles.spacing_error + 1e-12
        assert abs(math.atan2(step.y - origin.y, step.x - origin.x)) <= tiles.angle_error + 1e-12
        assert abs(math.atan2(-(across.x - origin.x), across.y - origin.y)) <= tiles.angle_error + 1e-12
        assert g.place(origin, origin) == origin


def test_trial_poses_without_tiles_are_unchanged():
    """A level without tiles lays its trials out at their listed positions, as before."""
    level = simi_on_tiles(floor=None)
    tree = RandomTree(7)
    first = starts(level, tree)
    for (p,) in trial_poses(level, tree, first)[1:]:
        near = min(level.task.trials.positions, key=lambda q: math.dist(q, (p.x, p.y)))
        assert math.dist(near, (p.x, p.y)) <= level.robots[0].placement.position + 1e-12
