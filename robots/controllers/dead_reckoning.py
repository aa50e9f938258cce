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

SUBSTEPS = 20  # integration steps per control period
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
        """Advance `pose` over one control period the way the drive ramps the wheels."""
        dt = self.brief.control_period / SUBSTEPS
        dv = self.brief.robot.max_wheel_accel * dt
        x, y, h = pose
        wl, wr = self.wheels
        for _ in range(SUBSTEPS):
            wl += max(-dv, min(dv, left - wl))
            wr += max(-dv, min(dv, right - wr))
            v, w = (wl + wr) / 2, (wr - wl) / self.brief.robot.track
            x += v * math.cos(h + w * dt / 2) * dt
            y += v * math.sin(h + w * dt / 2) * dt
            h = wrap(h + w * dt)
        self.wheels = (wl, wr)
        self.pose = (x, y, h)
