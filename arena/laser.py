"""Exact beam-beacon crossing times inside physics steps, by root finding.

Within one physics step pymunk moves every body at constant velocity (its integrator
updates velocity, then position), so the robot's pose is exactly linear in time across the
step; the laser's phase relative to the body is linear too (its rate is constant within a
step). The beam's world angle is heading(t) + phase(t). A crossing with beacon b is a time
at which that angle equals the bearing from the laser to b (mod 2 pi). We never step the
beam: for each step we compare the wrapped difference beam - bearing at the step's ends,
and where it passes zero we solve for the instant by Newton's method with the analytic
derivative. All of it is vectorized over steps x robots x beacons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from arena.angles import TWO_PI, wrap_angle

NEWTON_ITERATIONS = 2  # each squares the error; the linear first guess is already < 1e-5 rad off
# constants as 0-d arrays: NumPy combines them with small arrays faster than Python floats
_ZERO, _ONE, _PI = np.array(0.0), np.array(1.0), np.array(np.pi)


@dataclass(frozen=True)
class Trajectory:
    """Robot states at the ends of consecutive physics steps: `t` (n+1,), the rest (n+1, R).
    `h` is the unwrapped body heading, `phi` the unwrapped laser phase relative to the body."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    h: np.ndarray
    phi: np.ndarray

    def pose_at(self, step: np.ndarray, s: np.ndarray, robot: np.ndarray) -> tuple[np.ndarray, ...]:
        """Interpolated (x, y, h) at fraction `s` of step `step` for robots `robot`."""

        return (*self.position_at(step, s, robot), _lerp(self.h, step, s, robot))

    def position_at(self, step: np.ndarray, s: np.ndarray, robot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interpolated (x, y) at fraction `s` of step `step` for robots `robot`."""
        return _lerp(self.x, step, s, robot), _lerp(self.y, step, s, robot)


def _lerp(a: np.ndarray, step: np.ndarray, s: np.ndarray, robot: np.ndarray) -> np.ndarray:
    a0 = a[step, robot]
    return a0 + s * (a[step + 1, robot] - a0)


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


def find_crossings(
    traj: Trajectory, bx: np.ndarray, by: np.ndarray, beam_offset: np.ndarray | None = None
) -> Crossings:
    """All times at which a robot's beam points exactly at a beacon at (bx, by), unsorted.

    `beam_offset` (per robot, m, + = to the beam's left) is how far the beam line passes beside
    the spin axis: it meets a beacon at range r when its direction is the bearing minus
    asin(offset / r), which shifts every crossing by an amount that depends on the range.

    d = wrap(beam - bearing) changes by well under pi per step (the loader bounds the beam's
    turn per step), so the beam passes a beacon in step k exactly when d changes sign there
    without wrapping round. A pass belongs to the step in which d arrives at 0, so an exact
    hit at a step boundary is counted once, whichever way the beam turns."""
    dx = bx[None, None, :] - traj.x[:, :, None]
    dy = by[None, None, :] - traj.y[:, :, None]
    a = traj.h + traj.phi  # beam world angle (n+1, R)
    off = beam_offset if beam_offset is not None and beam_offset.any() else None
    d = a[:, :, None] - np.arctan2(dy, dx)
    if off is not None:
        d += np.arcsin(np.clip(off[None, :, None] / np.hypot(dx, dy), -1.0, 1.0))
    d = wrap_angle(d)
    # d passes zero in a step where it leaves a nonzero sign for zero or the other sign
    sign = np.sign(d)
    passes = (sign[:-1] != _ZERO) & (sign[1:] != sign[:-1]) & (np.abs(d[1:] - d[:-1]) < _PI)
    size = dx[0].size  # robots x beacons
    flat = passes.ravel().nonzero()[0]  # passes in (step, robot, beacon) order
    step, robot, beacon = (i[flat] for i in grid_index(passes.shape))
    d = d.ravel()
    f0, f1 = d[flat], d[flat + size]
    s = f0 / (f0 - f1)  # linear first guess
    # the crossing's step, as start values and changes over the step
    ex0, ey0 = dx.ravel()[flat], dy.ravel()[flat]  # laser -> beacon at the start
    state = np.array((traj.x, traj.y, a, traj.phi)).reshape(4, -1)  # rows of (step, robot)
    at = step * dx.shape[1] + robot
    start = state[:, at]
    ddx, ddy, da, dphi = state[:, at + dx.shape[1]] - start
    a0, phi0 = start[2], start[3]
    o = None if off is None else off[robot]
    for _ in range(NEWTON_ITERATIONS):
        ex, ey = ex0 - s * ddx, ey0 - s * ddy
        r2 = ex * ex + ey * ey
        f = a0 + s * da - np.arctan2(ey, ex)
        slope = da - (ey * ddx - ex * ddy) / r2  # d(beam - bearing)/ds
        if o is not None:  # + asin(o / r), and its derivative through r
            r = np.sqrt(r2)
            f += np.arcsin(np.clip(o / r, -1.0, 1.0))
            slope += o * (ex * ddx + ey * ddy) / (r2 * r * np.sqrt(np.maximum(1.0 - o * o / r2, 1e-12)))
        f = wrap_angle(f)
        # clipped to [0, 1]: minimum(maximum()) is np.clip's arithmetic (s is never -0)
        s = np.minimum(np.maximum(s - f / np.where(slope == _ZERO, _ONE, slope), _ZERO), _ONE)
    ex, ey = ex0 - s * ddx, ey0 - s * ddy
    d2 = ex * ex + ey * ey
    dt = traj.t[step + 1] - traj.t[step]
    return Crossings(
        robot=robot,
        beacon=beacon,
        step=step,
        s=s,
        t=traj.t[step] + s * dt,
        x=bx[beacon] - ex,
        y=by[beacon] - ey,
        phi=phi0 + s * dphi,
        beam_rate=(da - (ey * ddx - ex * ddy) / d2) / dt,
        distance=np.sqrt(d2),
        bearing=np.arctan2(ey, ex),
    )


@lru_cache(maxsize=64)
def grid_index(shape: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """The indices along each axis of every element of an array of `shape`, in C order: a
    lookup that turns flat positions into indices cheaper than a division (read-only)."""
    out = np.unravel_index(np.arange(math.prod(shape)), shape)
    for axis in out:
        axis.flags.writeable = False
    return out


def find_phase_marks(traj: Trajectory, per_turn: int, direction: np.ndarray) -> tuple[np.ndarray, ...]:
    """Times at which each robot's laser phase passes a multiple of 2 pi / per_turn.

    `direction` is each robot's spin sign (the phase is monotonic). Returns (robot, step, s,
    t, mark), sorted by time, with `mark` the signed count of such angles since phase 0;
    `per_turn=1` gives the index switch (relative angle 0). Several marks may fall in one
    step. Phase is linear within a step, so these times are exact."""
    v = traj.phi * (direction * per_turn / TWO_PI)  # increasing
    whole = np.floor(v)
    count = (whole[1:] - whole[:-1]).astype(np.int64)
    step, robot = np.nonzero(count)
    n = count[step, robot]
    step, robot = np.repeat(step, n), np.repeat(robot, n)
    offset = np.arange(len(step)) - np.repeat(np.cumsum(n) - n, n)
    mark = whole[step, robot] + 1 + offset
    v0, v1 = v[step, robot], v[step + 1, robot]
    s = (mark - v0) / (v1 - v0)
    t = traj.t[step] + s * (traj.t[step + 1] - traj.t[step])
    order = np.lexsort((robot, t))
    signed = (mark * direction[robot]).astype(np.int64)
    return robot[order], step[order], s[order], t[order], signed[order]


def segment_hits_circles(
    px: np.ndarray, py: np.ndarray, qx: np.ndarray, qy: np.ndarray, cx: np.ndarray, cy: np.ndarray, radius: np.ndarray
) -> np.ndarray:
    """Whether segments P-Q pass within `radius` of centres C (closed discs); elementwise."""
    ux, uy = qx - px, qy - py
    length2 = ux * ux + uy * uy
    u = ((cx - px) * ux + (cy - py) * uy) / np.where(length2 > _ZERO, length2, _ONE)
    u = np.minimum(np.maximum(u, _ZERO), _ONE)  # np.clip's arithmetic; a zero's sign cannot change a distance
    return np.hypot(px + u * ux - cx, py + u * uy - cy) <= radius
