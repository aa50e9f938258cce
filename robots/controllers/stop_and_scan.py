"""Stop, scan a full turn between index clicks, fix, turn, drive a leg, repeat.

The navigation of robots whose fix needs a standing robot (Vannoy's BX-24 robot, Ubersetzig's
servo head): subclasses supply `fix(revolution)`, the pose from one revolution's returns.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.angles import IndexRevolutions, Revolution, plausible
from robots.toolkit.motion import Wheels
from robots.toolkit.steering import wrap

LEG = 0.6  # m driven between scans at most
SETTLE = 0.3  # s standing still before a scan counts
MAX_JUMP = 0.3  # m between a fix and the dead-reckoned pose
MAX_FAILED_SCANS = 3  # then drive on by dead reckoning


class StopAndScan(Controller):
    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.sign = 1.0 if brief.laser.angular_velocity > 0 else -1.0
        self.period = 2 * math.pi / abs(brief.laser.angular_velocity)
        self.revolutions = IndexRevolutions(self.sign)
        self.wheels = Wheels(brief.robot.track, brief.robot.max_wheel_accel)
        self.pose: tuple[float, float, float] | None = None
        self.still_since = 0.0
        self.failed = 0  # scans in a row without a believable fix
        self.plan: list[tuple[float, float, float]] = []  # (until time, left, right)
        self.goal = brief.task.goal or (brief.task.path[-1] if brief.task.path else None)

    def fix(self, rev: Revolution) -> tuple[float, float, float] | None:
        """The pose (x, y, heading) from one standing revolution, or None."""
        raise NotImplementedError

    def relative(self, rev: Revolution) -> list[float]:
        """Each return's angle counter-clockwise from straight ahead."""
        return [a for a, _ in rev.hits]

    def step(self, observation: Observation) -> Command:
        now = observation.time
        revs = self.revolutions.feed(observation.events)
        dt, v, w = self.wheels.advance(now)
        if self.pose is not None and dt:
            x, y, h = self.pose
            self.pose = (x + v * math.cos(h + w * dt / 2) * dt, y + v * math.sin(h + w * dt / 2) * dt, wrap(h + w * dt))
        moving = any(abs(s) > 1e-9 for s in self.wheels.speeds)
        if moving:
            self.still_since = now
        if not self.plan:
            for rev in revs:
                if rev.start < self.still_since + SETTLE:
                    continue
                pose = self.fix(rev) if plausible(rev, self.period, 0.05 * self.period,
                                                  max_hits=len(self.beacons)) else None
                if pose is not None and self._believable(pose):
                    self.pose, self.failed = pose, 0
                    self._plan(now)
                else:
                    self.failed += 1
                    if self.failed >= MAX_FAILED_SCANS and self.pose is not None:
                        self.failed = 0  # "lost: can't find 3 targets": go on by dead reckoning
                        self._plan(now)
        left, right = 0.0, 0.0
        while self.plan and self.plan[0][0] <= now:
            self.plan.pop(0)
        if self.plan:
            _, left, right = self.plan[0]
        self.wheels.command(left, right, self.brief.robot.max_wheel_speed)
        return Command(left, right, estimate=self.pose)

    def _believable(self, pose: tuple[float, float, float]) -> bool:
        """A fix far from where dead reckoning says we are is a wrong association (a false
        return standing in for a lost target): rejected, and the next scan decides."""
        if self.pose is None:
            return True
        return math.dist(pose[:2], self.pose[:2]) < MAX_JUMP and abs(wrap(pose[2] - self.pose[2])) < 0.5

    def _plan(self, now: float) -> None:
        """Turn towards the goal, then drive a leg towards it, each as a trapezoid: command a
        wheel speed for (amount / rate), then stop while the wheels ramp down; with a linear
        ramp the two ramps add up to exactly one full-speed ramp time, so the robot turns or
        drives exactly the amount planned (up to slip)."""
        if self.goal is None or self.pose is None:
            return
        x, y, h = self.pose
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
