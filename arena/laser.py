"""Exact beam-beacon crossing times inside physics steps, by root finding.

Within one physics step pymunk moves every body at constant velocity (its integrator
updates velocity, then position), so the robot's pose is exactly linear in time across the
step; the laser's phase relative to the body is linear too (its rate is constant within a
step). The beam's world angle is heading(t) + phase(t). A crossing with beacon b is a time
at which that angle equals the bearing from the laser to b (mod 2 pi). We never step the
beam: for each step we compare g = beam - bearing at the step's ends (bearing unwrapped
along time), and where g passes a multiple of 2 pi we solve g(t) = 2 pi n by Newton's method
with the analytic derivative. All of it is vectorized over steps x robots x beacons.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * np.pi
NEWTON_ITERATIONS = 4  # each squares the error; the linear first guess is already < 1e-6 rad off


@dataclass(frozen=True)
class Trajectory:
    """Robot states at the ends of consecutive physics steps: `t` (n+1,), the rest (n+1, R).
    `h` is the unwrapped body heading, `phi` the unwrapped laser phase relative to the body."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    h: np.ndarray
    phi: np.ndarray

    def at(self, step: np.ndarray, s: np.ndarray, robot: np.ndarray) -> tuple[np.ndarray, ...]:
        """Interpolated (t, x, y, h, phi) at fraction `s` of step `step` for robots `robot`."""
        def lerp(a: np.ndarray) -> np.ndarray:
            return a[step, robot] + s * (a[step + 1, robot] - a[step, robot])
        t = self.t[step] + s * (self.t[step + 1] - self.t[step])
        return t, lerp(self.x), lerp(self.y), lerp(self.h), lerp(self.phi)


@dataclass(frozen=True)
class Crossings:
    """Every beam-beacon crossing found in a trajectory, as parallel arrays."""

    robot: np.ndarray
    beacon: np.ndarray
    step: np.ndarray
    s: np.ndarray  # fraction of the step
    t: np.ndarray  # time (s)
    x: np.ndarray  # laser position at the crossing (m)
    y: np.ndarray
    phi: np.ndarray  # laser phase relative to the body (unwrapped, rad)
    beam_rate: np.ndarray  # world angular rate of the beam (rad/s)
    distance: np.ndarray  # laser to beacon centre (m)
    bearing: np.ndarray  # world bearing from the laser to the beacon (rad)

    def __len__(self) -> int:
        return len(self.t)

    def take(self, mask: np.ndarray) -> Crossings:
        """The crossings where `mask` is true (a boolean array or indices)."""
        return Crossings(*(getattr(self, f)[mask] for f in self.__dataclass_fields__))


def find_crossings(traj: Trajectory, bx: np.ndarray, by: np.ndarray) -> Crossings:
    """All times at which a robot's beam points exactly at a beacon at (bx, by)."""
    # g[k, r, b] = beam world angle - bearing to the beacon, continuous along k
    dx = bx[None, None, :] - traj.x[:, :, None]
    dy = by[None, None, :] - traj.y[:, :, None]
    bearing = np.unwrap(np.arctan2(dy, dx), axis=0)
    g = (traj.h + traj.phi)[:, :, None] - bearing
    (step, robot, beacon), turn = _passes(g / TWO_PI)
    target = TWO_PI * turn
    g0, g1 = g[step, robot, beacon], g[step + 1, robot, beacon]
    s = np.clip((target - g0) / (g1 - g0), 0.0, 1.0)
    bxs, bys = bx[beacon], by[beacon]
    b0 = bearing[step, robot, beacon]
    dh = traj.h[step + 1, robot] - traj.h[step, robot]
    dphi = traj.phi[step + 1, robot] - traj.phi[step, robot]
    ddx = traj.x[step + 1, robot] - traj.x[step, robot]
    ddy = traj.y[step + 1, robot] - traj.y[step, robot]
    for _ in range(NEWTON_ITERATIONS):
        _, x, y, h, phi = traj.at(step, s, robot)
        ex, ey = bxs - x, bys - y
        d2 = ex * ex + ey * ey
        beta = b0 + _wrap(np.arctan2(ey, ex) - b0)
        f = h + phi - beta - target
        # d(beta)/ds for a laser moving by (ddx, ddy) over the step
        dbeta = (ey * ddx - ex * ddy) / d2
        slope = dh + dphi - dbeta
        s = np.clip(s - f / np.where(slope == 0.0, 1.0, slope), 0.0, 1.0)
    t, x, y, h, phi = traj.at(step, s, robot)
    ex, ey = bxs - x, bys - y
    dt = traj.t[step + 1] - traj.t[step]
    d2 = ex * ex + ey * ey
    beam_rate = (dh + dphi - (ey * ddx - ex * ddy) / d2) / dt
    order = np.lexsort((beacon, robot, t))
    return Crossings(robot=robot, beacon=beacon, step=step, s=s, t=t, x=x, y=y, phi=phi,
                     beam_rate=beam_rate, distance=np.sqrt(d2),
                     bearing=np.arctan2(ey, ex)).take(order)


def find_phase_marks(traj: Trajectory, per_turn: int) -> tuple[np.ndarray, ...]:
    """Times at which each robot's laser phase passes a multiple of 2 pi / per_turn.

    Returns (robot, step, s, t, mark) with `mark` the integer count of such angles since phase 0;
    `per_turn=1` gives the index switch (relative angle 0). Phase is linear within a step,
    so these times are exact."""
    scaled = traj.phi * (per_turn / TWO_PI)
    (step, robot), mark = _passes(scaled)
    p0, p1 = scaled[step, robot], scaled[step + 1, robot]
    s = np.clip((mark - p0) / (p1 - p0), 0.0, 1.0)
    t = traj.t[step] + s * (traj.t[step + 1] - traj.t[step])
    order = np.lexsort((robot, t))
    return robot[order], step[order], s[order], t[order], mark[order].astype(np.int64)


def segment_hits_boxes(px: np.ndarray, py: np.ndarray, qx: np.ndarray, qy: np.ndarray,
                       cx: np.ndarray, cy: np.ndarray, heading: np.ndarray,
                       half_length: np.ndarray, half_width: np.ndarray) -> np.ndarray:
    """Whether segments P-Q cross oriented rectangles (centre, heading, half extents); elementwise."""
    c, s = np.cos(heading), np.sin(heading)
    # both ends in the box frame
    ax, ay = (px - cx) * c + (py - cy) * s, -(px - cx) * s + (py - cy) * c
    bx, by = (qx - cx) * c + (qy - cy) * s, -(qx - cx) * s + (qy - cy) * c
    lo, hi = np.zeros_like(ax), np.ones_like(ax)
    for a, b, half in ((ax, bx, half_length), (ay, by, half_width)):
        d = b - a
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (-half - a) / d, (half - a) / d
        parallel = d == 0
        inside = np.abs(a) <= half
        lo = np.where(parallel, np.where(inside, lo, 2.0), np.maximum(lo, np.minimum(t1, t2)))
        hi = np.where(parallel, np.where(inside, hi, -1.0), np.minimum(hi, np.maximum(t1, t2)))
    return lo <= hi


def _passes(v: np.ndarray) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Where `v` (along axis 0) passes an integer between consecutive rows, and which integer.

    A pass belongs to the row interval (k, k+1] in which `v` arrives at the integer, whichever
    way it moves, so an exact hit at a row is counted once, in the step that ends there."""
    up, down = np.floor(v), np.ceil(v)
    rising = v[1:] > v[:-1]
    moved = np.where(rising, up[1:] != up[:-1], down[1:] != down[:-1])
    where = np.nonzero(moved)
    after = tuple(i + (1 if n == 0 else 0) for n, i in enumerate(where))
    return where, np.where(rising[where], up[after], down[after])


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi)."""
    return (a + np.pi) % TWO_PI - np.pi
