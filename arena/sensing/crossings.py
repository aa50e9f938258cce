"""Exact beam-beacon crossing times inside physics steps, by root finding.

Within one physics step pymunk moves every body at constant velocity (its integrator
updates velocity, then position), so the robot's pose is exactly linear in time across the
step; the laser's phase relative to the body is linear too (its rate is constant within a
step). The beam's world angle is heading(t) + phase(t). A crossing with beacon b is a time
at which that angle equals the bearing from the laser to b (mod 2 pi). We never step the
beam: for each step we compare the wrapped difference beam - bearing at the step's ends,
and where it passes zero we solve for the instant by Newton's method with the analytic
derivative. All of it runs over steps x robots x beacons at once, in compiled loops (here,
with NumPy's bits: arena.compiled) arc functions included (the C library's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from arena.angles import TWO_PI
from arena.compiled import compiled, maximum, minimum, sign, wrap_angle

NEWTON_ITERATIONS = 2  # each squares the error; the linear first guess is already < 1e-5 rad off
_NO_OFFSET = np.zeros(0)  # for beams on their spin axis


class Trajectory(NamedTuple):
    """Robot states at the ends of consecutive physics steps: `t` (n+1,), the rest (n+1, R).
    `h` is the unwrapped body heading, `phi` the unwrapped laser phase relative to the body.
    A named tuple: one is made at every control period."""

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
    hit at a step boundary is counted once, whichever way the beam turns. All of it is one
    compiled: the bearings of every step (`bearings`), then `crossing_arrays`."""
    off = beam_offset if beam_offset is not None and beam_offset.any() else _NO_OFFSET
    grid = bearings(traj.x, traj.y, bx, by)
    robot, beacon, step, s, rows = crossing_arrays(traj.x, traj.y, traj.h, traj.phi, traj.t, bx, by, off, *grid)
    return Crossings(robot, beacon, step, s, *rows)


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


# ---- the compiled loops ----------------------------------------------------------------------


@compiled()
def crossing_arrays(
    x: np.ndarray,
    y: np.ndarray,
    h: np.ndarray,
    phi: np.ndarray,
    t: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    offset: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    bearing: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`find_crossings` but the grid: (robot, beacon, step, s, and the rows t, x, y, phi,
    beam_rate, distance, bearing) from a trajectory (x, y, h, phi at the step ends `t`), the
    beacons, each robot's beam offset (none: every beam on its axis), the vectors from every
    laser to every beacon and their bearings (`bearings`), or none: then a bearing is taken only
    where a beam may pass its beacon (`near_passes`). Its arc functions are the C library's
    (decision 0050)."""
    shifted = offset.shape[0] > 0
    k, r, b = dx.shape
    if bearing.shape[0] == 0 and shifted:  # an offset beam's passes are found on the whole grid
        bearing = bearing_grid(dx, dy)
    beam = np.empty((k, r))
    shift = np.empty((k, r, b)) if shifted else np.empty((0, 0, 0))
    for i in range(k):
        for j in range(r):
            beam[i, j] = h[i, j] + phi[i, j]
            for m in range(b):
                if shifted:
                    ratio = offset[j] / math.hypot(dx[i, j, m], dy[i, j, m])
                    shift[i, j, m] = math.asin(minimum(maximum(ratio, -1.0), 1.0))
    step, robot, beacon, s, rows, ex, ey = first_guesses(beam, bearing, shift, shifted, dx, dy, x, y, phi)
    n = s.shape[0]
    o = np.empty(n if shifted else 0)
    if shifted:
        for c in range(n):
            o[c] = offset[robot[c]]
    turn, toward_beacon = np.empty(n if shifted else 0), np.empty(n)
    for _ in range(NEWTON_ITERATIONS):
        for c in range(n):
            toward_beacon[c] = math.atan2(ey[c], ex[c])
        if shifted:
            ratio_ = offset_ratio(ex, ey, o)
            for c in range(n):
                turn[c] = math.asin(ratio_[c])
        newton_step(rows, s, ex, ey, toward_beacon, o, turn, shifted)
    values = crossing_values(rows, s, ex, ey, step, beacon, t, bx, by)
    out = np.empty((7, n))
    for c in range(n):
        for q in range(6):
            out[q, c] = values[q + 2, c]
        out[6, c] = math.atan2(values[1, c], values[0, c])
    return robot, beacon, step, s, out


@compiled()
def laser_to_beacons(x: np.ndarray, y: np.ndarray, bx: np.ndarray, by: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vectors from every laser (steps, robots) to every beacon: (steps, robots, beacons)."""
    k, r, b = x.shape[0], x.shape[1], bx.shape[0]
    dx, dy = np.empty((k, r, b)), np.empty((k, r, b))
    for i in range(k):
        for j in range(r):
            for m in range(b):
                dx[i, j, m] = bx[m] - x[i, j]
                dy[i, j, m] = by[m] - y[i, j]
    return dx, dy


@compiled()
def bearings(x: np.ndarray, y: np.ndarray, bx: np.ndarray, by: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vectors from every laser (steps, robots) to every beacon and their bearings, the C
    library's `atan2` (decision 0050): the grid `crossing_arrays` takes."""
    dx, dy = laser_to_beacons(x, y, bx, by)
    return dx, dy, bearing_grid(dx, dy)


@compiled()
def bearing_grid(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """The bearings of the vectors (dx, dy), the C library's `atan2`."""
    bearing = np.empty(dx.shape)
    k, r, b = dx.shape
    for i in range(k):
        for j in range(r):
            for m in range(b):
                bearing[i, j, m] = math.atan2(dy[i, j, m], dx[i, j, m])
    return bearing


@compiled(inline="always")
def passes_zero(d0: float, d1: float) -> bool:
    """Whether the wrapped angle d from a beam to a bearing passes zero within a step, from d0
    at its start to d1 at its end (the pass's first guess is then d0 / (d0 - d1)): it changes
    sign by less than half a turn, and it arrives at zero in this step rather than leaving it,
    so an exact hit at a step's end is counted once."""
    s0 = sign(d0)
    return s0 != 0.0 and sign(d1) != s0 and abs(d1 - d0) < math.pi


NEAR = 1e-9  # of the range: how close to its beacon a beam may seem and still be looked at exactly


@compiled()
def near_passes(
    beam: np.ndarray, dx: np.ndarray, dy: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`passes` of beams on their spin axes, with a bearing taken only where a beam may pass its
    beacon: the same passes, the same first guesses, bit for bit, at a fraction of the `atan2`s.

    With the beam's direction (cos, sin) and the vector to the beacon (dx, dy), at range r,
    c = r cos(d) and q = -r sin(d), d the angle from beam to bearing. A pass needs d to change
    sign within the step by less than pi, so one end has |d| < pi/2 (c > 0) and q changes sign,
    or is near zero. Those are computed with other roundings than d, so the test looks at any
    step where they come within NEAR x r of the bounds; there the exact test of `passes` runs
    on d as the grid would hold it. The beam's angle is wrapped to a turn first: an unwrapped
    phase of thousands of radians costs the C library's `cos` and `sin` twice the time, and
    the wrap's rounding (a few ulps of the phase: 1e-10 rad at 10^6 rad) is inside NEAR."""
    k, r, b = dx.shape
    cos, sin = np.empty((k, r)), np.empty((k, r))
    for i in range(k):
        for j in range(r):
            turned = wrap_angle(beam[i, j])  # within a turn, where `cos` and `sin` take their fast path
            cos[i, j], sin[i, j] = math.cos(turned), math.sin(turned)
    most = (k - 1) * r * b
    step, robot, beacon = np.empty(most, np.int64), np.empty(most, np.int64), np.empty(most, np.int64)
    s = np.empty(most)
    count = 0
    for i in range(k - 1):
        for j in range(r):
            for m in range(b):
                ax, ay, bx_, by_ = dx[i, j, m], dy[i, j, m], dx[i + 1, j, m], dy[i + 1, j, m]
                ra, rb = NEAR * (abs(ax) + abs(ay)), NEAR * (abs(bx_) + abs(by_))
                ca = cos[i, j] * ax + sin[i, j] * ay
                cb = cos[i + 1, j] * bx_ + sin[i + 1, j] * by_
                if ca <= -ra and cb <= -rb:
                    continue
                qa = cos[i, j] * ay - sin[i, j] * ax
                qb = cos[i + 1, j] * by_ - sin[i + 1, j] * bx_
                if (qa > ra and qb > rb) or (qa < -ra and qb < -rb):
                    continue
                d0 = wrap_angle(beam[i, j] - math.atan2(ay, ax))
                d1 = wrap_angle(beam[i + 1, j] - math.atan2(by_, bx_))
                if passes_zero(d0, d1):
                    step[count], robot[count], beacon[count] = i, j, m
                    s[count] = d0 / (d0 - d1)
                    count += 1
    return step[:count], robot[:count], beacon[:count], s[:count]


@compiled()
def passes(
    beam: np.ndarray, bearing: np.ndarray, shift: np.ndarray, shifted: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the wrapped angle d = beam - bearing (+ shift) passes zero within a step, in
    (step, robot, beacon) order: those indices and the linear first guess of the instant."""
    k, r, b = bearing.shape
    d = np.empty((k, r, b))
    for i in range(k):
        for j in range(r):
            for m in range(b):
                v = beam[i, j] - bearing[i, j, m]
                if shifted:
                    v = v + shift[i, j, m]
                d[i, j, m] = wrap_angle(v)
    count = 0
    for pass_ in range(2):  # count, then fill
        if pass_ == 1:
            step, robot, beacon = np.empty(count, np.int64), np.empty(count, np.int64), np.empty(count, np.int64)
            s = np.empty(count)
            count = 0
        for i in range(k - 1):
            for j in range(r):
                for m in range(b):
                    d0, d1 = d[i, j, m], d[i + 1, j, m]
                    if passes_zero(d0, d1):
                        if pass_ == 1:
                            step[count], robot[count], beacon[count] = i, j, m
                            s[count] = d0 / (d0 - d1)
                        count += 1
    return step, robot, beacon, s


@compiled()
def crossing_steps(
    step: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    beam: np.ndarray,
    phi: np.ndarray,
) -> np.ndarray:
    """Per crossing, its step as rows: laser -> beacon at the start (ex0, ey0), the changes over
    the step (ddx, ddy, d beam, d phase) and the start's beam angle and phase: (8, crossings)."""
    out = np.empty((8, step.shape[0]))
    for n in range(step.shape[0]):
        i, j, m = step[n], robot[n], beacon[n]
        out[0, n], out[1, n] = dx[i, j, m], dy[i, j, m]
        out[2, n] = x[i + 1, j] - x[i, j]
        out[3, n] = y[i + 1, j] - y[i, j]
        out[4, n] = beam[i + 1, j] - beam[i, j]
        out[5, n] = phi[i + 1, j] - phi[i, j]
        out[6, n], out[7, n] = beam[i, j], phi[i, j]
    return out


@compiled()
def toward(rows: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Laser -> beacon at fraction `s` of each crossing's step."""
    n = s.shape[0]
    ex, ey = np.empty(n), np.empty(n)
    toward_into(rows, s, ex, ey)
    return ex, ey


@compiled(inline="always")
def toward_into(rows: np.ndarray, s: np.ndarray, ex: np.ndarray, ey: np.ndarray) -> None:
    """`toward`, written into `ex` and `ey`."""
    for c in range(s.shape[0]):
        ex[c] = rows[0, c] - s[c] * rows[2, c]
        ey[c] = rows[1, c] - s[c] * rows[3, c]


@compiled(inline="always")
def first_guesses(
    beam: np.ndarray,
    bearing: np.ndarray,
    shift: np.ndarray,
    shifted: bool,
    dx: np.ndarray,
    dy: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    phi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`passes` (`near_passes` where there is no grid of bearings), then `crossing_steps` and
    `toward` of the first guesses, in one call: (step, robot, beacon, s, rows, ex, ey)."""
    if bearing.shape[0] == 0:
        step, robot, beacon, s = near_passes(beam, dx, dy)
    else:
        step, robot, beacon, s = passes(beam, bearing, shift, shifted)
    rows = crossing_steps(step, robot, beacon, dx, dy, x, y, beam, phi)
    ex, ey = toward(rows, s)
    return step, robot, beacon, s, rows, ex, ey


@compiled()
def offset_ratio(ex: np.ndarray, ey: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """clip(offset / range, -1, 1): what the beam's offset asks of arcsin."""
    n = ex.shape[0]
    out = np.empty(n)
    for c in range(n):
        r = math.sqrt(ex[c] * ex[c] + ey[c] * ey[c])
        out[c] = minimum(maximum(offset[c] / r, -1.0), 1.0)
    return out


@compiled()
def newton_step(
    rows: np.ndarray,
    s: np.ndarray,
    ex: np.ndarray,
    ey: np.ndarray,
    bearing: np.ndarray,
    offset: np.ndarray,
    shift: np.ndarray,
    shifted: bool,
) -> None:
    """One Newton step of each crossing's instant `s`, clipped to its step (`find_crossings`),
    and laser -> beacon there (`toward`: `ex`, `ey`), each moved on in place."""
    n = s.shape[0]
    for c in range(n):
        ddx, ddy, da = rows[2, c], rows[3, c], rows[4, c]
        r2 = ex[c] * ex[c] + ey[c] * ey[c]
        f = rows[6, c] + s[c] * da - bearing[c]
        slope = da - (ey[c] * ddx - ex[c] * ddy) / r2
        if shifted:
            o = offset[c]
            r = math.sqrt(r2)
            f = f + shift[c]
            slope = slope + o * (ex[c] * ddx + ey[c] * ddy) / (r2 * r * math.sqrt(maximum(1.0 - o * o / r2, 1e-12)))
        f = wrap_angle(f)
        s[c] = minimum(maximum(s[c] - f / (1.0 if slope == 0.0 else slope), 0.0), 1.0)
    toward_into(rows, s, ex, ey)


@compiled()
def crossing_values(
    rows: np.ndarray,
    s: np.ndarray,
    exs: np.ndarray,
    eys: np.ndarray,
    step: np.ndarray,
    beacon: np.ndarray,
    t: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
) -> np.ndarray:
    """Per crossing at its instant (laser -> beacon there: exs, eys): laser -> beacon, time,
    laser (x, y), phase, the beam's world rate and the range, as rows (8, crossings)."""
    n = s.shape[0]
    out = np.empty((8, n))
    for c in range(n):
        ddx, ddy = rows[2, c], rows[3, c]
        ex, ey = exs[c], eys[c]
        d2 = ex * ex + ey * ey
        k = step[c]
        dt = t[k + 1] - t[k]
        out[0, c], out[1, c] = ex, ey
        out[2, c] = t[k] + s[c] * dt
        out[3, c] = bx[beacon[c]] - ex
        out[4, c] = by[beacon[c]] - ey
        out[5, c] = rows[7, c] + s[c] * rows[5, c]
        out[6, c] = (rows[4, c] - (ey * ddx - ex * ddy) / d2) / dt
        out[7, c] = math.sqrt(d2)
    return out
