"""Stop, scan a full turn between index clicks, turn, drive a leg, repeat.

The navigation of robots whose closed-form fix needs a standing robot (Vannoy's BX-24 robot,
Ubersetzig's servo head, Simi's cart): subclasses supply `fix(revolution)`, the pose from one
standing revolution's returns. That fix starts the toolkit's HitTracker (and restarts it when
it is lost); from then on every return and index click is an EKF update, predicted between
them with the commanded wheels, so the pose is fused with odometry and kept at every tick.
A leg is planned once the robot has stood still for a full revolution.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation, SensorEvent
from robots.toolkit.angles import IndexRevolutions, Revolution, plausible, wrap
from robots.toolkit.tracker import HitTracker

LEG = 0.6  # m driven between scans at most
SETTLE = 0.3  # s standing still before a scan counts


class StopAndScan(Controller):
    BEARING_SIGMA = 2e-3  # rad: one return's bearing noise, as the hardware gives it

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.sign = 1.0 if brief.laser.angular_velocity > 0 else -1.0
        self.period = 2 * math.pi / abs(brief.laser.angular_velocity)
        self.revolutions = IndexRevolutions(self.sign)
        self.tracker = HitTracker(brief, bearing_sigma=self.BEARING_SIGMA, first_fix=self._first_fix)
        self.still_since = 0.0
        self.plan: list[tuple[float, float, float]] = []  # (until time, left, right)
        self.goal = brief.task.goal or (brief.task.path[-1] if brief.task.path else None)
        self.trial = 0

    def fix(self, rev: Revolution) -> tuple[float, float, float] | None:
        """The pose (x, y, heading) from one standing revolution, or None."""
        raise NotImplementedError

    def relative(self, rev: Revolution) -> list[float]:
        """Each return's angle counter-clockwise from straight ahead."""
        return [a for a, _ in rev.hits]

    def _first_fix(self, e: SensorEvent) -> tuple[float, float, float, float] | None:
        """A closed-form fix from a plausible revolution that ends with this click while the
        robot stands: at the click the beam points straight ahead, along the heading."""
        for rev in self.revolutions.feed([e]):
            if rev.start < self.still_since + SETTLE:
                continue
            if plausible(rev, self.period, 0.05 * self.period, max_hits=len(self.beacons)):
                pose = self.fix(rev)
                if pose is not None:
                    return pose[0], pose[1], pose[2], pose[2]
        return None

    def step(self, observation: Observation) -> Command:
        now = observation.time
        if observation.trial != self.trial:  # carried to a new pose, at rest: find it again
            self.trial = observation.trial
            self.tracker.reset()
            self.revolutions = IndexRevolutions(self.sign)
            self.plan, self.still_since = [], self.tracker.wheels.time
        self.tracker.feed(observation.events, now)
        if any(abs(s) > 1e-9 for s in self.tracker.wheels.speeds):
            self.still_since = now
        while self.plan and self.plan[0][0] <= now:
            self.plan.pop(0)
        if not self.plan and self.tracker.pose is not None and now >= self.still_since + SETTLE + self.period:
            self._plan(now)
        left, right = (self.plan[0][1], self.plan[0][2]) if self.plan else (0.0, 0.0)
        self.tracker.command(left, right)
        return Command(left, right, estimate=self.tracker.pose)

    def _plan(self, now: float) -> None:
        """Turn towards the goal, then drive a leg towards it, each as a trapezoid: command a
        wheel speed for (amount / rate), then stop while the wheels ramp down; with a linear
        ramp the two ramps add up to exactly one full-speed ramp time, so the robot turns or
        drives exactly the amount planned (up to slip)."""
        if self.goal is None or self.tracker.pose is None:
            return
        x, y, h = self.tracker.pose
        gx, gy = self.goal
        distance = math.dist((x, y), (gx, gy))
        if distance < self.brief.task.radius / 2:
            return
        turn = wrap(math.atan2(gy - y, gx - x) - h)
        top, track = self.brief.robot.max_wheel_speed, self.brief.robot.track
        accel = self.brief.robot.max_wheel_accel
        t = now
        if abs(turn) > 0.01:
            # slow enough that the command outlasts the ramp: spin <= sqrt(|turn| track accel / 2)
            spin = min(0.5 * top, math.sqrt(abs(turn) * track * accel / 2))
            t += abs(turn) * track / (2 * spin)
            self.plan.append((t, -math.copysign(spin, turn), math.copysign(spin, turn)))
            t += spin / accel
            self.plan.append((t, 0.0, 0.0))
        leg = min(LEG, distance)
        speed = min(0.6 * top, math.sqrt(leg * accel))
        t += leg / speed
        self.plan.append((t, speed, speed))
        t += speed / accel
        self.plan.append((t, 0.0, 0.0))
