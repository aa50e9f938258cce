"""Exact beam-beacon crossing times inside physics steps, by root finding.

Within one physics step pymunk moves every body at constant velocity (its integrator
updates velocity, then position), so the robot's pose is exactly linear in time across the
step; the laser's phase relative to the body is linear too (its rate is constant within a
step). The beam's world angle is heading(t) + phase(t). A crossing with beacon b is a time
at which that angle equals the bearing from the laser to b (mod 2 pi). We never step the
beam: for each step we compare the wrapped difference beam - bearing at the step's ends,
and where it passes zero we solve for the instant by Newton's method with the analytic
derivative. All of it runs over steps x robots x beacons at once, in compiled loops
(arena.kernels) with NumPy's arc functions between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arena import kernels
from arena.angles import TWO_PI

NEWTON_ITERATIONS = 2  # each squares the error; the linear first guess is already < 1e-5 rad off
_NO_SHIFT, _NO_OFFSET = np.zeros((0, 0, 0)), np.zeros(0)  # for beams on their spin axis


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
    """All times at which a robot's beam points exactly at a beacon at (bx, by), in (step,
    robot, beacon) order.

    `beam_offset` (per robot, m, + = to the beam's left) is how far the beam line passes beside
    the spin axis: it meets a beacon at range r when its direction is the bearing minus
    asin(offset / r), which shifts every crossing by an amount that depends on the range.

    d = wrap(beam - bearing) changes by well under pi per step (the loader bounds the beam's
    turn per step), so the beam passes a beacon in step k exactly when d changes sign there
    without wrapping round. A pass belongs to the step in which d arrives at 0, so an exact
    hit at a step boundary is counted once, whichever way the beam turns. The loops are
    compiled (arena.kernels); the arc functions are NumPy's."""
    dx, dy = kernels.laser_to_beacons(traj.x, traj.y, bx, by)
    a = traj.h + traj.phi  # beam world angle (n+1, R)
    off = beam_offset if beam_offset is not None and beam_offset.any() else None
    shift = _NO_SHIFT if off is None else np.arcsin(np.clip(off[None, :, None] / np.hypot(dx, dy), -1.0, 1.0))
    step, robot, beacon, s, rows, ex, ey = kernels.first_guesses(
        a, np.arctan2(dy, dx), shift, off is not None, dx, dy, traj.x, traj.y, traj.phi
    )
    o = _NO_OFFSET if off is None else off[robot]
    for _ in range(NEWTON_ITERATIONS):
        turn = _NO_OFFSET if off is None else np.arcsin(kernels.offset_ratio(ex, ey, o))
        s, ex, ey = kernels.newton_step(rows, s, ex, ey, np.arctan2(ey, ex), o, turn, off is not None)
    ex, ey, t, x, y, phi, beam_rate, distance = kernels.crossing_values(rows, s, ex, ey, step, beacon, traj.t, bx, by)
    return Crossings(
        robot=robot,
        beacon=beacon,
        step=step,
        s=s,
        t=t,
        x=x,
        y=y,
        phi=phi,
        beam_rate=beam_rate,
        distance=distance,
        bearing=np.arctan2(ey, ex),
    )


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
