"""The best-practice controller: the toolkit's HitTracker, and smooth steering.

Every laser event is its own EKF update at its own time, predicted between events with the
commanded wheels (robots.toolkit.tracker): labelled hits, encoder angles, index clicks, and
unlabelled hits associated with the beacon whose predicted bearing is nearest. It starts,
and restarts when lost, from a closed-form fix: a labelled revolution (least squares), or
for unlabelled returns with an index, Vannoy's sector rule and the circle method. It reports
the filtered pose every step and follows the task's waypoints with a proportional heading
controller, slowing into each waypoint.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation, SensorEvent
from robots.toolkit.angles import IndexRevolutions, wrap
from robots.toolkit.associate import by_sectors
from robots.toolkit.solvers import circles
from robots.toolkit.steering import HeadingProbe, next_waypoint
from robots.toolkit.tracker import HitTracker

APPROACH = 2.0  # 1/s: the speed (m/s) is at most this times the distance (m) to the waypoint
CREEP = 0.03  # m/s


class Best(Controller):
    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.revolutions = IndexRevolutions(1.0 if brief.laser.angular_velocity > 0 else -1.0)
        labelled = brief.beacon_kind != "reflector"
        self.tracker = HitTracker(brief, first_fix=None if labelled else self._sector_fix)
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0
        self.trial = 0
        self.probe = HeadingProbe()  # drives straight to learn an unknown heading

    def _sector_fix(self, e: SensorEvent) -> tuple[float, float, float, float] | None:
        """Unlabelled returns between index clicks: Vannoy's sector rule and the circle method,
        from the last pose (or the announced start, or the field centre)."""
        for rev in self.revolutions.feed([e]):
            rel = [a for a, _ in rev.hits]  # counter-clockwise from straight ahead
            if len(rel) != len(self.beacons) or len(self.beacons) != 3:
                continue
            f = self.brief.field
            start = self.tracker.start  # the announced start, until a trial carries the robot away
            pose = self.tracker.pose or (start.pose if start and start.region is None else None)
            ref = pose[:2] if pose else ((f[0] + f[2]) / 2, (f[1] + f[3]) / 2)
            assoc = by_sectors([a % (2 * math.pi) for a in rel], self.beacons, ref)
            if assoc.ambiguous:
                continue
            fix = circles([self.beacons[b] for b in assoc.ids if b is not None], rel)
            if fix.ok:  # at the click the beam points straight ahead: its world angle is the heading
                return fix.x, fix.y, fix.heading, fix.heading
        return None

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # carried to a new pose: find it again
            self.trial = observation.trial
            self.tracker.reset()
            self.revolutions = IndexRevolutions(self.revolutions.sign)
            self.probe.reset()
        self.tracker.feed(observation.events, observation.time)
        pose = self.tracker.pose
        if pose is not None and self.probe.driving(pose[0], pose[1], self.tracker.heading_sd):
            left, right = CREEP, CREEP
        else:
            left, right = self._steer(pose)
        self.tracker.command(left, right)
        return Command(left, right, estimate=pose)

    def _steer(self, pose: tuple[float, float, float] | None) -> tuple[float, float]:
        if pose is None:
            return 0.0, 0.0
        x, y, h = pose
        self.target = next_waypoint(self.path, self.target, x, y, self.brief.task.radius / 2)
        if self.target >= len(self.path):
            return 0.0, 0.0
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - h)
        top, half = self.brief.robot.max_wheel_speed, self.brief.robot.track / 2
        if abs(error) > 0.5:
            w = max(-0.6 * top / half, min(0.6 * top / half, 2.0 * error))
            return -w * half, w * half
        v = min(0.8 * top, max(CREEP, APPROACH * math.dist((x, y), (tx, ty)))) * math.cos(error)
        w = 1.5 * error
        return max(-top, min(top, v - w * half)), max(-top, min(top, v + w * half))
