"""Bac, Grift & Menezes 2011: the corner-array table.

How it works, in detail: docs/internals.md, `robots/controllers/bac.py`.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.angles import BeaconRevolutions, Revolution, wrap
from robots.toolkit.motion import heading_change
from robots.toolkit.solvers import bac, total
from robots.toolkit.steering import HeadingProbe, next_waypoint
from robots.toolkit.tracker import HitTracker

DEAD_BAND, SPIN = 0.05, 0.3  # rad
CRUISE = 0.10  # m/s: "an average velocity of 0.10 m/s, with a peak velocity of 0.14 m/s"
# m/s: the fused controller's straight-line speed, the line run's "peak velocity of the robot was 0.17 m/s"
PEAK = 0.17
CREEP = 0.03  # m/s: the slowest straight-line speed, well above the servos' dead band
SPIN_SPEED = 0.12  # m/s: each wheel's speed in a spin turn (2.3 rad/s on the BOE-bot)
SWITCH = 0.6  # the next waypoint when the estimate is within this fraction of the task radius:
# the referee counts a waypoint on the true pose, so the switch keeps a margin for the estimate's error
PASSED = 0.9  # a waypoint behind the robot counts as passed within this fraction of the task radius
# laser turns between two checks against a revolution's fix of a fused pose that agreed with the last
CHECK_TURNS = 4.0


class BacSeed(Controller):
    """The paper's localization and guidance, as published."""

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.sign = 1.0 if brief.laser.angular_velocity > 0 else -1.0
        self.nominal = 2 * math.pi / abs(brief.laser.angular_velocity)
        # the table's corners as the paper names them: O at the origin, L along x, W along y
        xmin, ymin, xmax, ymax = brief.field
        corner = lambda cx, cy: min(self.beacons, key=lambda b: math.dist(self.beacons[b], (cx, cy)))  # noqa: E731
        self.o, self.a, self.c = corner(xmin, ymin), corner(xmax, ymin), corner(xmin, ymax)
        self.length, self.width = xmax - xmin, ymax - ymin
        self.origin = (xmin, ymin)
        self.revolutions = BeaconRevolutions(self.o)
        start = brief.start
        known = start is not None and start.region is None  # the announced start is worth taking
        self.position: tuple[float, float] | None = (start.x, start.y) if start and known else None
        self.heading: float | None = start.heading if start and known and start.heading_known else None
        self.last_for_heading = self.position
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0
        self.straight = self._straight_line()
        self.command = (0.0, 0.0)
        self.turn_until: float | None = None
        self.steady_from = 0.0  # revolutions starting earlier overlapped a rotation
        self.now = 0.0
        self.trial = 0

    def fix(self, rev: Revolution) -> tuple[float, float] | None:
        """(x, y) from one revolution, or None if Bac's checks reject it."""
        times = sorted(a for a, _ in rev.hits) + [2 * math.pi]
        durations = [b - a for a, b in zip(times, times[1:])]
        if abs(rev.period - self.nominal) > min(durations) / (2 * math.pi) * rev.period:
            return None  # "compared to a manually defined value": tolerance = smallest pulse duration
        # counter-clockwise from O; an unlabelled pulse leaves ccw short, so no fix
        ccw = {b: (self.sign * a) % (2 * math.pi) for a, b in rev.hits if b is not None}
        if len(ccw) != len(rev.hits) or len(ccw) < 3:
            return None
        if self.a in ccw and self.c in ccw:
            alpha, beta = ccw[self.a], 2 * math.pi - ccw[self.c]
            f = bac(alpha, beta, self.length, self.width)
            return (f.x + self.origin[0], f.y + self.origin[1]) if f.ok else None
        ids = list(ccw)[:3]  # a missing pulse: the three that remain
        f = total([self.beacons[b] for b in ids], [ccw[b] for b in ids])
        return (f.x, f.y) if f.ok else None

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # carried to a new pose: what it knew is void
            self.trial, self.position, self.heading, self.last_for_heading = observation.trial, None, None, None
            self.revolutions = BeaconRevolutions(self.o)
            self.command, self.turn_until, self.steady_from = (0.0, 0.0), None, self.now
        self.now = observation.time
        # a revolution during a rotation command sees the beam turn at the wrong rate: skip it
        revs = [r for r in self.revolutions.feed(observation.events) if r.start >= self.steady_from]
        fixes = [p for p in map(self.fix, revs) if p is not None]
        if fixes:  # this period's position: the mean of its revolutions' fixes
            p = (sum(f[0] for f in fixes) / len(fixes), sum(f[1] for f in fixes) / len(fixes))
            self.position = p
            forward = self.command[0] == self.command[1] > 0 and self.turn_until is None
            if self.last_for_heading is None or not forward:
                self.last_for_heading = p
            elif math.dist(p, self.last_for_heading) > 0.01:  # "larger than 1 cm"
                # measured from where this straight run began: the baseline grows as we drive
                self.heading = math.atan2(p[1] - self.last_for_heading[1], p[0] - self.last_for_heading[0])
        self.command = self._guide()
        # with no heading yet (a robot that has not moved), report the position with heading 0
        estimate = None if self.position is None else (*self.position, self.heading or 0.0)
        return Command(*self.command, estimate=estimate)

    def _straight_line(self) -> bool:
        """The paper's straight-line run: start and waypoints on one line, no steering at all."""
        if self.brief.start is None or len(self.path) < 2:
            return False
        x0, y0, _ = self.brief.start.pose
        (x1, y1) = self.path[-1]
        length = math.dist((x0, y0), (x1, y1))
        return length > 0 and all(
            abs((x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)) / length < 0.005 for px, py in self.path
        )

    def _guide(self) -> tuple[float, float]:
        if self.straight and self.brief.start:  # "started with both wheels set to move at the same velocity"
            x0, y0, _ = self.brief.start.pose
            x1, y1 = self.path[-1]
            done = self.position is not None and (
                (self.position[0] - x1) * (x1 - x0) + (self.position[1] - y1) * (y1 - y0) >= 0
            )
            while (
                self.position is not None
                and self.target < len(self.path)
                and math.dist(self.position, self.path[self.target]) < self.brief.task.radius
            ):
                self.target += 1
            return (0.0, 0.0) if done else (CRUISE, CRUISE)
        if self.turn_until is not None:  # a rotation command in progress
            if self.now < self.turn_until:
                return self.command
            self.turn_until = None
            self.steady_from = self.now + self.brief.control_period
            return 0.0, 0.0  # one period at rest: the wheels ramp down, the turn is complete
        if self.position is None:
            return 0.0, 0.0
        self.target = next_waypoint(self.path, self.target, *self.position, self.brief.task.radius)
        if self.target >= len(self.path):
            return 0.0, 0.0
        if self.heading is None:
            return CRUISE, CRUISE  # drive straight until two fixes give a heading
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - self.position[1], tx - self.position[0]) - self.heading)
        if abs(error) <= DEAD_BAND:  # no new command: keep driving straight
            return (CRUISE, CRUISE)
        # "whether the robot should rotate left or right and through how many degrees"
        track, top = self.brief.robot.track, self.brief.robot.max_wheel_speed
        if abs(error) <= SPIN:  # mode 1: hold one wheel, turn with the other
            v = 0.6 * top
            self.turn_until = self.now + abs(error) * track / v
            command = (0.0, v) if error > 0 else (v, 0.0)
        else:  # mode 2: a spin turn, wheels opposite
            w = 0.5 * top
            self.turn_until = self.now + abs(error) * track / (2 * w)
            command = (-w, w) if error > 0 else (w, -w)
        self.heading = wrap(self.heading + error)  # taken as achieved; fixes correct it later
        self.steady_from = float("inf")
        self.last_for_heading = None
        return command


class Bac(Controller):
    """The paper's guidance (dead band, pivot and spin turns) on the HitTracker's fused pose."""

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.tracker = HitTracker(brief, check_turns=CHECK_TURNS, plain_floats=True)
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0
        self.turning: int | None = None  # +-1 pivot, +-2 spin: the turn in progress, if any
        self.trial = 0
        self.probe = HeadingProbe()  # drives straight to learn an unknown heading

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # carried to a new pose, at rest: find it again
            self.trial, self.turning = observation.trial, None
            self.tracker.reset()
            self.probe.reset()
        self.tracker.feed(observation.events, observation.time)
        pose = self.tracker.pose
        if pose is None:
            left, right = 0.0, 0.0
        elif self.probe.driving(pose[0], pose[1], self.tracker.heading_sd):
            left, right = CREEP, CREEP
        else:
            left, right = self._guide(pose)
        self.tracker.command(left, right)
        return Command(left, right, estimate=pose)

    def _guide(self, pose: tuple[float, float, float]) -> tuple[float, float]:
        x, y, h = pose
        within = SWITCH * self.brief.task.radius
        self.target = next_waypoint(self.path, self.target, x, y, within)
        while self.target < len(self.path) and self._passed(x, y, h):
            self.target += 1
        if self.target >= len(self.path):
            self.turning = None
            return 0.0, 0.0
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - h)  # the turn still to make, from now
        if self.turning is not None and abs(self.turning) == 1 and abs(error) > SPIN:
            self.turning = int(math.copysign(2, error))  # a pivot that fell behind becomes a spin
        cruise = self._speed(x, y, h, within)
        # what driving straight on still turns, as the wheels settle
        settling = heading_change(self.tracker.wheels, [(0.0, cruise, cruise)], self.brief.robot.max_wheel_speed)
        if self.turning is None:
            left = wrap(error - settling)
            near = math.dist((x, y), (tx, ty)) < 2 * within  # where a small offset is a large angle
            if abs(left) <= DEAD_BAND or (near and abs(left) <= SPIN):
                return cruise, cruise
            self.turning = int(math.copysign(1 if abs(left) <= SPIN else 2, left))
        return self._turn(self.turning, error, cruise)

    def _turn(self, mode: int, error: float, cruise: float) -> tuple[float, float]:
        """The wheel command of the turn in progress (`mode`, as in `turning`) for this control period. Its strength s
        (0..1) is solved so that this period plus the ramp back to driving straight at `cruise`
        turns exactly `error` (rad, from now) on the nominal wheel model; a turn longer than
        that goes at full strength and is solved again at the next tick."""
        wheels, top = self.tracker.wheels, self.brief.robot.max_wheel_speed
        period = self.brief.control_period

        def command(s: float) -> tuple[float, float]:
            if abs(mode) == 1:  # pivot: the inner wheel slows to a halt at s = 1
                inner, outer = cruise * (1 - s), cruise
            else:  # spin: wheels opposite at equal speed
                inner, outer = -SPIN_SPEED * s, SPIN_SPEED * s
            return (inner, outer) if mode > 0 else (outer, inner)

        def turned(s: float) -> float:  # signed along the turn's direction
            return math.copysign(1, mode) * heading_change(wheels, [(period, *command(s)), (0.0, cruise, cruise)], top)

        want = math.copysign(1, mode) * error
        if turned(1.0) <= want:
            return command(1.0)
        self.turning = None  # the turn ends within this period and the ramp back to straight
        lo, hi = 0.0, 1.0
        if turned(lo) >= want:
            return command(lo)
        for _ in range(30):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if turned(mid) < want else (lo, mid)
        return command((lo + hi) / 2)

    def _passed(self, x: float, y: float, h: float) -> bool:
        """A waypoint just missed: inside the task radius (with a margin for the estimate's
        error) and already behind the robot; circling back for it would only loop."""
        tx, ty = self.path[self.target]
        close = math.dist((x, y), (tx, ty)) < PASSED * self.brief.task.radius
        return close and abs(wrap(math.atan2(ty - y, tx - x) - h)) > math.pi / 2

    def _speed(self, x: float, y: float, h: float, within: float) -> float:
        """Straight-line speed: the peak, but slowing into a waypoint where a spin turn follows
        (the paper's robot turned on the spot), so that it arrives slowly and does not
        overshoot the corner by a control period's travel."""
        k = self.target
        if k + 1 >= len(self.path):
            return PEAK
        (tx, ty), (nx, ny) = self.path[k], self.path[k + 1]
        if abs(wrap(math.atan2(ny - ty, nx - tx) - h)) <= SPIN:
            return PEAK
        brake = 0.8 * self.brief.robot.max_wheel_accel  # a margin below the drive's limit: slip and latency
        ahead = sum(self.tracker.wheels.speeds) / 2 * self.brief.control_period  # before the next command
        room = max(0.0, math.dist((x, y), (tx, ty)) - within - ahead)
        return min(PEAK, max(CREEP, math.sqrt(2 * brake * room)))
