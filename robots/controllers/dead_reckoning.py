"""Follow the task's waypoints by dead reckoning from the announced start pose.

It integrates its own wheel commands (ramped at the robot's acceleration limit, as the
drive does) from the announced nominal start and never looks at a sensor, so its estimate
is off by wherever the robot was really set down, and drifts wherever the physics disagrees
with the commands (collisions, pushing, ramp-up). It is the open-loop baseline a localizing
controller must beat; without an announced start it stands still.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.angles import wrap
from robots.toolkit.steering import next_waypoint

SPIN_ABOVE = 0.3  # rad: heading errors above this turn on the spot
CRUISE = 0.8  # fraction of the top wheel speed used on straights


class DeadReckoning(Controller):
    """`start` (x, y, heading) is taken instead of the brief's nominal start (the pose a team
    would copy from the public level file where the rules announce none)."""

    def __init__(self, start: tuple[float, float, float] | None = None) -> None:
        self.start = start

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.pose = self.start or (brief.start.pose if brief.start else None)
        task = brief.task
        self.path = list(task.path) if task.path else ([task.goal] if task.goal else [])
        self.target = 0
        self.wheels = (0.0, 0.0)  # wheel speeds the drive has reached, as we model it

    def step(self, observation: Observation) -> Command:
        if self.pose is None:
            return Command(0.0, 0.0)
        now = self.pose  # where we believe we are at this tick, before the new command acts
        left, right = self._steer(now)
        self._integrate(now, left, right)
        return Command(left, right, estimate=now)

    def _steer(self, pose: tuple[float, float, float]) -> tuple[float, float]:
        x, y, h = pose
        self.target = next_waypoint(self.path, self.target, x, y, self.brief.task.radius / 2)
        if self.target >= len(self.path):
            return 0.0, 0.0
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - h)
        vmax = self.brief.robot.max_wheel_speed
        half = self.brief.robot.track / 2
        if abs(error) > SPIN_ABOVE:
            w = math.copysign(vmax / half * 0.5, error)
            return -w * half, w * half
        v = CRUISE * vmax
        w = 2.0 * error / self.brief.control_period * 0.5
        left, right = v - w * half, v + w * half
        scale = max(1.0, abs(left) / vmax, abs(right) / vmax)
        return left / scale, right / scale

    def _integrate(self, pose: tuple[float, float, float], left: float, right: float) -> None:
        """Advance `pose` over one control period the way the drive ramps the wheels: each wheel
        speed goes linearly, at the top acceleration, to its command, then holds it. Between the
        instants a wheel arrives, both speeds are linear in time, so the turn rate is too and the
        heading a quadratic: each such piece is integrated by 3-point Gauss-Legendre quadrature
        (exact for the heading, error of order (turn over the piece)^6 for the position)."""
        period, track = self.brief.control_period, self.brief.robot.track
        accel = self.brief.robot.max_wheel_accel
        wl, wr = self.wheels
        arrive = [min(period, abs(goal - now) / accel) for now, goal in ((wl, left), (wr, right))]
        x, y, h = pose
        start = 0.0
        for end in sorted({*arrive, period}):
            if end <= start:
                continue
            span = end - start
            l0, l1 = _ramped(wl, left, accel, start), _ramped(wl, left, accel, end)
            r0, r1 = _ramped(wr, right, accel, start), _ramped(wr, right, accel, end)
            v0, dv = (l0 + r0) / 2, ((l1 + r1) - (l0 + r0)) / 2
            w0, dw = (r0 - l0) / track, ((r1 - l1) - (r0 - l0)) / track
            for node, weight in GAUSS:
                u = node * span  # time into the piece
                v = v0 + dv * node
                heading = h + w0 * u + dw * node * u / 2
                x += weight * span * v * math.cos(heading)
                y += weight * span * v * math.sin(heading)
            h += (w0 + dw / 2) * span
            start = end
        self.wheels = (_ramped(wl, left, accel, period), _ramped(wr, right, accel, period))
        self.pose = (x, y, wrap(h))


def _ramped(now: float, goal: float, accel: float, t: float) -> float:
    """A wheel's speed `t` s after it was commanded `goal` at speed `now`, at acceleration `accel`."""
    step = accel * t
    return goal if abs(goal - now) <= step else now + math.copysign(step, goal - now)


# 3-point Gauss-Legendre on [0, 1]: (node, weight)
GAUSS = tuple((0.5 + 0.5 * z, w / 2) for z, w in ((-math.sqrt(0.6), 5 / 9), (0.0, 8 / 9), (math.sqrt(0.6), 5 / 9)))
