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
from robots.toolkit.solvers import least_squares

# "the time-out limit, which was set to 130 ms", with the laser at 81 rad/s: 1.68 turns, the
# same share of a turn at any laser rate (a slower laser, as in the 31 rad/s line run, waits longer)
TIME_OUT_TURNS = 0.130 * 81.0 / (2 * math.pi)
STEADY_TURN = 0.3  # rad/s: turning slower, a closed-form fix may check the filter
FIT_RESIDUAL = 0.02  # rad: a four-array revolution fits its pulses this well, or it is an outlier

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
    fix = least_squares(points, bearings, sigma=1e-3)
    if not fix.ok:
        return None
    if (
        len(hits) > 3
        and max(
            abs(wrap(math.atan2(by - fix.y, bx - fix.x) - fix.heading - a)) for (bx, by), a in zip(points, bearings)
        )
        > FIT_RESIDUAL
    ):
        return None
    return fix.x, fix.y, fix.heading
