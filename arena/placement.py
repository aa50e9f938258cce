"""Where each robot really stands: its start, and each trial's pose, drawn per match.

A level gives a nominal start and a `Placement` (docs/levels.md): a hand placement within a
stated distance and angle of the nominal pose, or anywhere in a region. The true pose is drawn
from the match's random tree (so, in a graded match, from its secret), never from anything a
controller sees; `--ideal` keeps it, since it is the task's uncertainty, not the hardware's.
A level whose floor has tiles (arena.floor) lays each trial's position out on the match's real
tile grid from where the robot started, as an experimenter carried it tile by tile, before the
hand placement; `--ideal` makes that grid perfect.
A draw whose body would leave the field or overlap an obstacle, a beacon or a robot already
set down is drawn again, up to `ATTEMPTS` times, and then falls back to the nominal pose.
"""

from __future__ import annotations

import math

import numpy as np

from arena.angles import wrap
from arena.floor import Grid
from arena.rng import RandomTree
from levels.checks import body_problem, footprint
from levels.model import Level, Placement, Pose, Trials

ATTEMPTS = 1000


def draw(nominal: Pose, placement: Placement, rng: np.random.Generator) -> Pose:
    """One pose around `nominal` as `placement` spreads it (three draws, always)."""
    u = rng.random(3).tolist()
    if placement.region is not None:
        x0, y0, x1, y1 = placement.region
        x, y = x0 + u[0] * (x1 - x0), y0 + u[1] * (y1 - y0)
    else:
        r, a = placement.position * math.sqrt(u[0]), 2 * math.pi * u[1]
        x, y = nominal.x + r * math.cos(a), nominal.y + r * math.sin(a)
    heading = nominal.heading + placement.heading * (2 * u[2] - 1)
    return Pose(x, y, wrap(heading))


def _fits(level: Level, slot: int, pose: Pose, others: list[list[tuple[float, float]]]) -> bool:
    body = footprint(level.robots[slot].model, pose)
    return all(level.field.contains(x, y) for x, y in body) and (
        body_problem(level, level.robots[slot].model, pose, others) is None
    )


def set_down(
    level: Level, slot: int, nominal: Pose, rng: np.random.Generator, others: list[list[tuple[float, float]]]
) -> Pose:
    """Robot `slot` set down around `nominal` by its placement, clear of the field's border,
    the obstacles, the beacons and the bodies `others`."""
    placement = level.robots[slot].placement
    if placement.exact:
        return nominal
    for _ in range(ATTEMPTS):
        pose = draw(nominal, placement, rng)
        if _fits(level, slot, pose, others):
            return pose
    return nominal


def starts(level: Level, tree: RandomTree) -> tuple[Pose, ...]:
    """Every robot's true start, in slot order (each from its own stream), clear of the robots
    set down before it and of those set down exactly at their starts (they do not move over)."""
    out: list[Pose] = []
    exact = {r.slot: footprint(r.model, r.start) for r in level.robots if r.placement.exact}
    for r in level.robots:
        bodies = [footprint(level.robots[k].model, p) for k, p in enumerate(out)]
        bodies += [body for k, body in exact.items() if k > r.slot]
        out.append(set_down(level, r.slot, r.start, tree.stream("robot", r.slot, "start"), bodies))
    return tuple(out)


def trial_poses(
    level: Level, tree: RandomTree, first: tuple[Pose, ...], tiles: Grid | None = None
) -> tuple[tuple[Pose, ...], ...]:
    """Every trial's true pose of every robot: `poses[trial][slot]`. The first trial is the
    start (`first`); each later trial's nominal pose is one of the task's trial positions, taken
    in a shuffled order (shuffled again each time all have been used), or a point of its
    region, with one of its headings, or one within its heading spread of the robot's nominal
    start heading (any heading when it gives neither), laid out on the `tiles`
    grid from the robot's start if there is one, and the robot is set down around it by its
    placement."""
    trials = level.task.trials
    out = [first]
    if trials.count <= 1:
        return tuple(out)
    streams = [tree.stream("robot", r.slot, "trials") for r in level.robots]
    orders: list[list[int]] = [[] for _ in level.robots]
    for _ in range(1, trials.count):
        poses: list[Pose] = []
        for r, rng in zip(level.robots, streams):
            bodies = [footprint(level.robots[k].model, p) for k, p in enumerate(poses)]
            pose = first[r.slot]  # if no draw fits (a level whose trial positions leave no room)
            for _ in range(ATTEMPTS):
                nominal = _trial_nominal(trials, r.start.heading, rng, orders[r.slot])
                if tiles is not None:
                    nominal = tiles.place(first[r.slot], nominal)
                drawn = nominal if r.placement.exact else draw(nominal, r.placement, rng)
                if _fits(level, r.slot, drawn, bodies):
                    pose = drawn
                    break
            poses.append(pose)
        out.append(tuple(poses))
    return tuple(out)


def _trial_nominal(trials: Trials, start_heading: float, rng: np.random.Generator, order: list[int]) -> Pose:
    """A trial's nominal pose (three draws and, each time the positions run out, a shuffle)."""
    u = rng.random(3).tolist()
    if trials.region is not None:
        x0, y0, x1, y1 = trials.region
        x, y = x0 + u[0] * (x1 - x0), y0 + u[1] * (y1 - y0)
    else:
        if not order:
            order.extend(rng.permutation(len(trials.positions)).tolist())
        x, y = trials.positions[order.pop()]
    headings = trials.headings
    if headings:
        heading = headings[min(int(u[2] * len(headings)), len(headings) - 1)]  # not u[1]: a region's y
    elif trials.heading_spread is not None:
        heading = wrap(start_heading + trials.heading_spread * (2 * u[2] - 1))
    else:
        heading = math.pi * (2 * u[2] - 1)
    return Pose(x, y, heading)
