"""The robot's own motion as its controller knows it: commanded wheel speeds, ramped.

The drive ramps each wheel towards its command at `max_wheel_accel` (docs/levels.md), so a
controller that remembers its commands knows its forward speed and turn rate at any time,
up to slip and collisions. Used to predict between fixes and to compensate a revolution's
hits for the motion during it; the poses the commands alone give (`advance`), and the motion
between two such poses (`between`, `compose`), to carry candidate poses along a move.
"""

from __future__ import annotations

import math

Pose = tuple[float, float, float]  # x, y (m), heading (rad)


class Wheels:
    """Wheel speeds over time, from the commands given."""

    def __init__(self, track: float, accel: float, time: float = 0.0):
        self.track, self.accel = track, accel
        self.time = time
        self.speeds = (0.0, 0.0)
        self.target = (0.0, 0.0)

    def command(self, left: float, right: float, top: float) -> None:
        """A new command, effective now (clipped to the top speed, as the drive does)."""
        self.target = (max(-top, min(top, left)), max(-top, min(top, right)))

    def advance(self, time: float) -> tuple[float, float, float]:
        """Move the clock to `time`; return (dt, mean forward speed, mean turn rate) over it."""
        dt = time - self.time
        if dt <= 0:
            return 0.0, 0.0, 0.0
        (left, left_mean), (right, right_mean) = (
            _ramped(self.speeds[0], self.target[0], dt, self.accel),
            _ramped(self.speeds[1], self.target[1], dt, self.accel),
        )
        self.time, self.speeds = time, (left, right)
        return dt, (left_mean + right_mean) / 2, (right_mean - left_mean) / self.track

    def copy(self) -> Wheels:
        """An independent copy, to try commands on without touching this one."""
        out = Wheels(self.track, self.accel, self.time)
        out.speeds, out.target = self.speeds, self.target
        return out


def _ramped(now: float, goal: float, dt: float, accel: float) -> tuple[float, float]:
    """A wheel ramping from speed `now` towards `goal` at `accel` for `dt` s: its speed at the
    end, and its mean speed over the time."""
    if now == goal:  # at its command, as a wheel mostly is: the general form's numbers, at once
        return goal, goal * dt / dt
    ramp = abs(goal - now) / accel  # time to reach the command
    end = goal if ramp <= dt else now + (goal - now) * dt / ramp
    if ramp >= dt:
        return end, (now + end) / 2
    return end, ((now + goal) / 2 * ramp + goal * (dt - ramp)) / dt


def heading_change(wheels: Wheels, plan: list[tuple[float, float, float]], top: float) -> float:
    """How far (rad) the robot turns if, from the wheels' state now, it is commanded
    `plan` = [(duration, left, right), ...] in turn, the last held until the wheels settle.
    Exact for the ramped model: each wheel's mean speed over an interval is known in closed form."""
    w = wheels.copy()
    turned = 0.0
    for k, (duration, left, right) in enumerate(plan):
        w.command(left, right, top)
        if k == len(plan) - 1:  # hold the last command until both wheels reach it
            duration = max(abs(w.speeds[0] - w.target[0]), abs(w.speeds[1] - w.target[1])) / w.accel + 1e-9
        dt, _, rate = w.advance(w.time + duration)
        turned += rate * dt
    return turned


def advance(pose: Pose, dt: float, v: float, w: float) -> Pose:
    """Where a unicycle at `pose` (x, y, heading) ends after `dt` s at forward speed v and turn
    rate w (the midpoint rule, as the EKF predicts)."""
    x, y, h = pose
    mid = h + w * dt / 2
    return x + v * math.cos(mid) * dt, y + v * math.sin(mid) * dt, h + w * dt


def between(a: Pose, b: Pose) -> Pose:
    """The motion from pose `a` to pose `b` in `a`'s own frame (forward, left, turned)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]


def compose(pose: Pose, motion: Pose) -> Pose:
    """Pose `pose` moved by `motion` (forward, left, turned) given in its own frame."""
    x, y, h = pose
    c, s = math.cos(h), math.sin(h)
    return x + c * motion[0] - s * motion[1], y + s * motion[0] + c * motion[1], h + motion[2]
