"""Occlusion: whether anything stands between a laser and a beacon at an instant. Other robots
block with their silhouettes (a circle at each centre: mast, laser housing), where they stand
at that instant, in a compiled loop; the level's obstacles through pymunk's segment query.
Walls bound a convex field and never block.
"""

from __future__ import annotations

import math

import numpy as np
import pymunk

from arena.compiled import compiled, maximum, minimum
from arena.sensing.crossings import Trajectory
from arena.world import CAT_OBSTACLE, World

TINY = 1e-12


class Occlusion:
    """The robots' silhouettes and the level's obstacles of one match, against its beacons
    (where they really are: `bx`, `by`)."""

    def __init__(self, world: World, bx: np.ndarray, by: np.ndarray):
        level = world.level
        self.world = world
        self.bx, self.by = bx, by
        self.beacon_radius = float(level.beacons.radius)
        robots = level.robots
        # what each robot puts in the laser plane: a circle at its centre (mast, laser housing)
        self.silhouette = np.array([r.model.silhouette_radius for r in robots])
        # how far that circle can reach from the robot's centre at a batch start, within a batch
        batch = level.control_period
        self.reach = self.silhouette + np.array([2 * r.model.max_wheel_speed * batch for r in robots])
        self.has_obstacles = bool(level.obstacles)
        self.obstacle_filter = pymunk.ShapeFilter(mask=CAT_OBSTACLE)

    def blocked(
        self,
        traj: Trajectory,
        robot: np.ndarray,
        step: np.ndarray,
        s: np.ndarray,
        px: np.ndarray,
        py: np.ndarray,
        beacon: np.ndarray,
    ) -> np.ndarray:
        """Whether the segment from each laser (px, py) to each beacon's near edge is blocked by
        another robot of `traj` (at fraction `s` of step `step`) or an obstacle."""
        blocked_, qx, qy = blocked(
            px, py, self.bx, self.by, beacon, self.beacon_radius, robot, step, s,
            traj.x, traj.y, self.reach, self.silhouette,
        )  # fmt: skip
        if self.has_obstacles:
            space = self.world.space
            for i in np.nonzero(~blocked_)[0]:
                first = space.segment_query_first((px[i], py[i]), (qx[i], qy[i]), 0.0, self.obstacle_filter)
                blocked_[i] = first is not None
        return blocked_

    def clear_obstacles(self, rows: np.ndarray) -> None:
        """Drop the kept crossings of `rows` (sweep.candidates': laser x, y in rows 1-2, the
        beacon's near edge in 7-8, kept in 11) whose segment an obstacle blocks."""
        space = self.world.space
        for i in np.nonzero(rows[11] > 0.0)[0].tolist():
            segment = (rows[1, i], rows[2, i]), (rows[7, i], rows[8, i])
            if space.segment_query_first(*segment, 0.0, self.obstacle_filter) is not None:
                rows[11, i] = 0.0


@compiled(inline="always")
def blocked(
    px: np.ndarray,
    py: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    beacon: np.ndarray,
    radius: float,
    robot: np.ndarray,
    step: np.ndarray,
    s: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    reach: np.ndarray,
    silhouette: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whether each segment from a laser (px, py) to the near edge (qx, qy) of its beacon
    (`beacon`, of `radius`, at (bx, by) by index) passes through another robot's silhouette at that instant (fraction
    `s` of step `step` of the trajectory x, y). A robot whose circle, grown by its `reach`
    in the batch, misses the segment at the batch start is not tested exactly. Returns
    (blocked, qx, qy)."""
    n, robots = px.shape[0], x.shape[1]
    qx, qy = np.empty(n), np.empty(n)
    out = np.zeros(n, np.bool_)
    for i in range(n):
        vx, vy = bx[beacon[i]] - px[i], by[beacon[i]] - py[i]
        d = math.hypot(vx, vy)
        shrink = (d - radius) / maximum(d, TINY) if d > radius else 0.0
        qx[i], qy[i] = px[i] + vx * shrink, py[i] + vy * shrink
        if robots < 2:
            continue
        ux, uy = qx[i] - px[i], qy[i] - py[i]
        length2 = ux * ux + uy * uy
        for o in range(robots):
            if o == robot[i]:
                continue
            cx, cy = x[0, o], y[0, o]
            u = minimum(maximum(((cx - px[i]) * ux + (cy - py[i]) * uy) / length2, 0.0), 1.0)
            if not math.hypot(px[i] + u * ux - cx, py[i] + u * uy - cy) <= reach[o]:
                continue
            k = step[i]
            ox = x[k, o] + s[i] * (x[k + 1, o] - x[k, o])
            oy = y[k, o] + s[i] * (y[k + 1, o] - y[k, o])
            u = ((ox - px[i]) * ux + (oy - py[i]) * uy) / (length2 if length2 > 0.0 else 1.0)
            u = minimum(maximum(u, 0.0), 1.0)
            if math.hypot(px[i] + u * ux - ox, py[i] + u * uy - oy) <= silhouette[o]:
                out[i] = True
                break
    return out, qx, qy
