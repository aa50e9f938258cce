"""A robot's position and beam angle in closed form from one turn of its laser's labelled
pulses, as Bac checked them: the fix a tracker starts from, restarts from, or checks its
filter against (robots.toolkit.tracker).

A revolution runs from one pulse of an array to its next pulse, within the 130 ms time-out
(scaled to the laser's rate); its time must agree with the laser's period within its smallest
pulse duration ("The algorithm selected the smallest pulse duration ... as a difference
tolerance"); three of the four arrays are enough ("the system uses the remaining three
pulses"). A fix with four arrays must also be self-consistent.
"""

from __future__ import annotations

import math

from robots.toolkit.angles import wrap
from robots.toolkit.solvers import MAX_STEP, heading_from, total

# "the time-out limit, which was set to 130 ms", with the laser at 81 rad/s: 1.68 turns, the
# same share of a turn at any laser rate (a slower laser, as in the 31 rad/s line run, waits longer)
TIME_OUT_TURNS = 0.130 * 81.0 / (2 * math.pi)
STEADY_TURN = 0.3  # rad/s: turning slower, a closed-form fix may check the filter
FIT_RESIDUAL = 0.02  # rad: a four-array revolution fits its pulses this well, or it is an outlier
NEWTON_ITERATIONS, TOLERANCE = 50, 1e-12  # as solvers.newton's
SINGULAR = 1e-14  # the normal equations' determinant, relative to its scale, below which a fix is refused

TurnFix = tuple[float, float, float]  # x, y (m) and the beam's world angle (rad)


def revolution_fix(
    recent: list[tuple[float, str]], beacons: dict[str, tuple[float, float]], turning: float, time_out: float
) -> TurnFix | None:
    """(x, y, beam world angle now) from the revolution that the newest of the `recent` hits
    (time, array) closes, the beam turning at `turning` (rad/s, the laser's rate plus the
    robot's own turn), or None if it fails Bac's checks."""
    end, closing = recent[-1]
    before = [k for k, (t, b) in enumerate(recent[:-1]) if b == closing]
    if not before:
        return None
    begin = before[-1]
    duration = end - recent[begin][0]
    rate = abs(turning)  # the beam turns with the robot
    if duration > time_out:
        return None  # a pulse of the closing array itself went missing
    hits = recent[begin + 1 :]
    times = [recent[begin][0]] + [t for t, _ in hits]
    smallest = min(b - a for a, b in zip(times, times[1:]))
    if abs(duration - 2 * math.pi / rate) > smallest or len({b for _, b in hits}) != len(hits) or len(hits) < 3:
        return None
    return turn_fix(hits, beacons, turning)


def turn_fix(hits: list[tuple[float, str]], beacons: dict[str, tuple[float, float]], turning: float) -> TurnFix | None:
    """(x, y, beam world angle at the last hit) from one turn's hits of distinct arrays, the
    beam turning at `turning` (rad/s), by least squares; None if it fails, or if four or more
    fit it badly."""
    end = hits[-1][0]
    rate = abs(turning)  # the beam turns with the robot
    sign = math.copysign(1.0, turning)
    points = [beacons[b] for _, b in hits]
    bearings = [sign * rate * (t - end) for t, _ in hits]  # relative to the beam now
    fix = fit(points, bearings)
    if fix is None:
        return None
    x, y, h = fix
    if (
        len(hits) > 3
        and max(abs(wrap(math.atan2(by - y, bx - x) - h - a)) for (bx, by), a in zip(points, bearings)) > FIT_RESIDUAL
    ):
        return None
    return fix


def fit(points: list[tuple[float, float]], bearings: list[float]) -> TurnFix | None:
    """(x, y, reference direction) that best explain the `bearings` of `points`: Gauss-Newton
    from ToTal on the first three, as solvers.least_squares, with each step's 3 x 3 normal
    equations solved in plain floats (a fix costs a quarter of a general solver's); None where
    it fails (no start, no convergence, or the robot on the circle through the points)."""
    seed = total(points[:3], bearings[:3], heading=False)
    x, y = (
        (seed.x, seed.y)
        if seed.ok
        else (sum(p[0] for p in points) / len(points), sum(p[1] for p in points) / len(points))
    )
    h = heading_from(x, y, points, bearings)
    for _ in range(NEWTON_ITERATIONS):
        # J^T J (symmetric: a, b, c on the diagonal; d = xy, e = xh, f = yh) and J^T r, r = -residual
        a = b = d = e = f = gx = gy = gh = 0.0
        for (bx, by), bearing in zip(points, bearings):
            dx, dy = bx - x, by - y
            d2 = dx * dx + dy * dy
            if d2 < 1e-18:
                return None
            jx, jy = dy / d2, -dx / d2
            r = -wrap(math.atan2(dy, dx) - h - bearing)
            a, b, d, e, f = a + jx * jx, b + jy * jy, d + jx * jy, e - jx, f - jy
            gx, gy, gh = gx + jx * r, gy + jy * r, gh - r
        c = float(len(points))
        step = _solve3(a, b, c, d, e, f, gx, gy, gh)
        if step is None:
            return None
        sx, sy, sh = step
        grow = max(abs(sx), abs(sy)) / MAX_STEP
        if grow > 1:  # a trust region, as Newton's: never jump across the field
            sx, sy, sh = sx / grow, sy / grow, sh / grow
        x, y, h = x + sx, y + sy, h + sh
        if abs(sx) + abs(sy) + abs(sh) < TOLERANCE:
            return x, y, wrap(h)
    return None


def _solve3(
    a: float, b: float, c: float, d: float, e: float, f: float, gx: float, gy: float, gh: float
) -> tuple[float, float, float] | None:
    """The solution of [[a, d, e], [d, b, f], [e, f, c]] s = g by Cramer's rule, or None where
    the matrix is singular to working precision (the robot on the circle through the points)."""
    m11, m12, m13 = b * c - f * f, e * f - d * c, d * f - b * e
    det = a * m11 + d * m12 + e * m13
    scale = (abs(a) + abs(d) + abs(e)) * (abs(d) + abs(b) + abs(f)) * (abs(e) + abs(f) + abs(c))
    if not abs(det) > SINGULAR * scale:
        return None
    m22, m23, m33 = a * c - e * e, d * e - a * f, a * b - d * d
    return (
        (m11 * gx + m12 * gy + m13 * gh) / det,
        (m12 * gx + m22 * gy + m23 * gh) / det,
        (m13 * gx + m23 * gy + m33 * gh) / det,
    )
