"""The best-practice controller: an EKF that takes every laser event at its own time.

It starts from one revolution solved in closed form (least squares on labelled hits;
Vannoy's sector rule and the circle method on unlabelled ones with an index), then feeds
each hit, index click and encoder angle to the EKF of robots.toolkit.ekf, predicting
between them with its own ramped wheel commands. Unlabelled hits are associated with the
beacon whose predicted bearing is nearest. It reports the filtered pose every step and
follows the task's waypoints.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation, SensorEvent
from robots.toolkit.associate import by_sectors
from robots.toolkit.ekf import BearingEKF
from robots.toolkit.motion import Wheels
from robots.toolkit.solvers import circles, least_squares
from robots.toolkit.steering import next_waypoint, wrap
from robots.toolkit.angles import IndexRevolutions

BEARING_VAR = 2e-3 ** 2  # rad^2 per event
GATE = 4.0  # standard deviations


class Best(Controller):
    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.omega = brief.laser.angular_velocity
        self.sign = 1.0 if self.omega > 0 else -1.0
        self.period = 2 * math.pi / abs(self.omega)
        self.wheels = Wheels(brief.robot.track, brief.robot.max_wheel_accel)
        self.ekf: BearingEKF | None = None
        self.first: list[SensorEvent] = []
        self.revolutions = IndexRevolutions(self.sign)
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0

    # ---- estimation ----------------------------------------------------------------------

    def _advance(self, time: float) -> None:
        dt, v, w = self.wheels.advance(time)
        if self.ekf:
            self.ekf.predict(dt, v, w)

    def _start(self, x: float, y: float, beam: float, heading: float | None) -> None:
        """Start the filter at (x, y) with the beam's world angle `beam` now."""
        known = heading if heading is not None else (self.brief.start[2] if self.brief.start else None)
        h = known if known is not None else 0.0
        self.ekf = BearingEKF(x, y, h, wrap(beam - h), self.omega, var_xy=1e-4,
                              var_heading=1e-4 if known is not None else 10.0, var_sum=1e-4,
                              var_rate=(0.005 * self.omega) ** 2)

    def _initialize(self, e: SensorEvent) -> None:
        labelled = e.kind == "hit" and e.beacon is not None
        if labelled:
            self.first.append(e)
            span = self.first[-1].time - self.first[0].time
            if span < self.period * 0.9 or len({h.beacon for h in self.first}) < 3:
                return
            t0 = self.first[0].time
            fix = least_squares([self.beacons[h.beacon] for h in self.first],
                                [self.omega * (h.time - t0) for h in self.first], sigma=2e-3)
            self.first = []
            if fix.ok:  # fix.heading is the beam's world angle at t0
                self._start(fix.x, fix.y, fix.heading + self.omega * (e.time - t0), None)
            return
        for rev in self.revolutions.feed([e]):  # unlabelled: a full revolution between clicks
            rel = [a for a, _ in rev.hits]  # counter-clockwise from straight ahead
            if len(rel) != len(self.beacons):
                continue
            ref = self.brief.start[:2] if self.brief.start else (
                (self.brief.field[0] + self.brief.field[2]) / 2, (self.brief.field[1] + self.brief.field[3]) / 2)
            assoc = by_sectors([a % (2 * math.pi) for a in rel], self.beacons, ref)
            if assoc.ambiguous or len(self.beacons) != 3:
                continue
            fix = circles([self.beacons[b] for b in assoc.ids], rel)
            if fix.ok:  # heading from the click: relative angles are measured from straight ahead
                self._start(fix.x, fix.y, fix.heading, fix.heading)

    def _event(self, e: SensorEvent) -> None:
        ekf = self.ekf
        if ekf is None:
            self._initialize(e)
            return
        if e.kind == "index":
            ekf.index(1e-6, GATE)
        elif e.kind == "hit" and e.angle is not None and e.beacon is not None:
            ekf.relative(*self.beacons[e.beacon], e.angle, BEARING_VAR, GATE)
        elif e.kind == "hit" and e.beacon is not None:
            ekf.hit(*self.beacons[e.beacon], BEARING_VAR, GATE)
        elif e.kind == "hit":  # unlabelled: the beacon the beam should be pointing at
            b = min(self.beacons, key=lambda k: abs(ekf.predicted_bearing(*self.beacons[k])))
            ekf.hit(*self.beacons[b], BEARING_VAR, GATE)

    # ---- control ---------------------------------------------------------------------------

    def step(self, observation: Observation) -> Command:
        for e in observation.events:
            self._advance(e.time)
            self._event(e)
        self._advance(observation.time)
        pose = self.ekf.pose if self.ekf else None
        left, right = self._steer(pose)
        self.wheels.command(left, right, self.brief.robot.max_wheel_speed)
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
            w = math.copysign(0.6 * top / half, error)
            return -w * half, w * half
        v = 0.8 * top * math.cos(error)
        w = 1.5 * error
        return max(-top, min(top, v - w * half)), max(-top, min(top, v + w * half))
