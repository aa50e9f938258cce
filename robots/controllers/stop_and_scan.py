"""Stop, scan a turn, turn, drive a leg, repeat; find the start first, by moving if need be.

How it works, in detail: docs/internals.md, `robots/controllers/stop_and_scan.py`.
"""

from __future__ import annotations

import math
from dataclasses import replace

from robots.api import Brief, Command, Controller, Observation, SensorEvent
from robots.toolkit.angles import Revolution, TurnWindow, wrap
from robots.toolkit.associate import predicted_angles
from robots.toolkit.motion import Pose, between, compose
from robots.toolkit.tracker import HitTracker

LEG = 0.6  # m driven between scans at most
APPROACH = 0.1  # m outside a goto goal's radius where the robot stops before its last leg (ours)
SETTLE = 0.3  # s standing still before a scan counts
AGREE = (0.25, 0.15)  # m, rad: a candidate this close to one of an earlier turn is that one
CONSISTENT = 16.3  # chi^2 of 3 degrees of freedom at 99.9 %: the filter agrees with a standing turn
SAME = 100.0  # chi^2 beyond which a standing turn's pose is not the filter's (a wrong one is tens of degrees off)
DRIFT = (0.1, 0.1)  # m, rad of odometry error per metre driven and per radian turned (slip)
CLEARANCE = 0.3  # m from the walls at the end of a move made to tell candidates apart (ours)
# moves to tell candidates apart, the shortest first (a turn on the spot, then a straight leg);
# the shortest of all comes last, when nothing longer is safe for every candidate
MOVES = [(math.radians(t), d) for d in (0.3, 0.45, 0.6, 0.15) for t in (0, 45, -45, 90, -90, 135, -135, 180)]


def agree(a: Pose, b: Pose, driven: float = 0.0, turned: float = 0.0) -> bool:
    """Whether poses `a` and `b` are one, allowing for the odometry of a move in between."""
    return math.dist(a[:2], b[:2]) <= AGREE[0] + DRIFT[0] * driven and abs(wrap(a[2] - b[2])) <= (
        AGREE[1] + DRIFT[1] * abs(turned)
    )


class StopAndScan(Controller):
    BEARING_SIGMA = 2e-3  # rad: one timed return's bearing noise, as the hardware gives it
    LATCHED_SIGMA: float | None = None  # rad: a latched angle's noise, if not the same
    ANGLE_STEP = 0.0  # rad: a latched angle is truncated to whole steps of this (0: none)
    SLACK = 0.05  # m: a standing fix may lie this far outside where the robot can be
    DITHERS = 0  # a stepped head's standing turns added at each stop, each after turning by DITHER,
    DITHER = 0.0  # rad, on the spot: the same returns fall at other places in the steps

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.sign = 1.0 if brief.laser.angular_velocity > 0 else -1.0
        self.period = 2 * math.pi / abs(brief.laser.angular_velocity)
        self.window = TurnWindow(self.sign, self.period)
        self.window.restart(0.0)  # the robot stands from the start
        self.tracker = HitTracker(
            brief,
            bearing_sigma=self.BEARING_SIGMA,
            latched_sigma=self.LATCHED_SIGMA,
            # the heading checked against the direction of travel over a good part of a leg: the
            # few returns of a slow laser move the filtered position by centimetres at a time
            track_check=LEG / 2,
            # a turn on the spot slips by a few per cent of it (docs/drive.md: 3 +- 2 %), and a
            # stray return some tens of degrees from a reflector must not pass for it after one
            q_heading=0.005,
            gate=4.0,
            wobble=0.002,  # a head that keeps its rate: "tracking at the correct speed" (Vannoy; size ours)
            first_fix=self._judge,
        )
        self.still_since = -SETTLE  # the robot stands at the start
        self.plan: list[tuple[float, float, float]] = []  # (until time, left, right)
        self.goal = brief.task.goal or (brief.task.path[-1] if brief.task.path else None)
        self.trial = 0
        self.dithers = 0  # dithering turns made at this stop
        self.stepped = False  # the head latches its angles in steps
        # where the robot may be: the announced start region at first, the field after it
        self.box = brief.start.region if brief.start and brief.start.region else brief.field
        self.hypotheses: list[Pose] = []  # the candidates still in the running, as last seen
        self.seen_at: Pose = self.tracker.odometry  # the odometry when they were seen
        self.seen_end = -math.inf  # and the end of the turn they were seen in
        self.confirmed = -math.inf  # when a standing turn last agreed with the filter or started it
        self.fresh: float | None = None  # the end of the one turn the filter rests on, till another confirms it

    def candidates(self, rev: Revolution) -> list[Pose]:
        """Every pose (x, y, heading) that fits one standing turn's returns inside `self.box`."""
        raise NotImplementedError

    def relative(self, rev: Revolution) -> list[float]:
        """Each return's angle counter-clockwise from straight ahead."""
        return [a for a, _ in rev.hits]

    def inside(self, x: float, y: float) -> bool:
        """Whether (x, y) lies in the box the robot may be in, or near enough for a fix's error."""
        xmin, ymin, xmax, ymax = self.box
        slack = self.SLACK
        return xmin - slack <= x <= xmax + slack and ymin - slack <= y <= ymax + slack

    def _judge(self, e: SensorEvent) -> None:
        """Judge the standing turn that ends with this event against the filter, or against the
        candidates still in the running; (re)start the filter when one pose is left (the
        tracker's `first_fix`, which starts and drops the filter itself)."""
        rev = self.window.feed(e)
        if self.plan:
            return None  # moving, or about to
        pose = self.tracker.pose
        checked = pose is not None and self.fresh is None and self.confirmed >= self.still_since
        if rev is None or not rev.hits or (checked and e.kind != "index"):
            return None  # a filter confirmed at this stop is checked once a turn, at the click
        hits = [h.time for h in self.window.events if h.kind == "hit"]
        if not self.window.whole and pose is not None:
            return None  # a filter is judged by a whole turn of standing
        beam = 0.0 if e.kind == "index" else rev.hits[-1][0]  # where the beam points now
        found = self.candidates(rev)
        if not found or (pose is not None and self._check(found, e.time, beam, min(hits))):
            return None
        self._search(found, e.time, beam, hits)
        return None

    def _check(self, found: list[Pose], now: float, beam: float, first: float) -> bool:
        """Whether a standing turn (its candidates `found`, its first return at `first`) bears the
        filter out: one of its candidates must be the filter's pose within their joint
        uncertainty. A filter nearly so, or lost in its own eyes, restarts from the turn; a fresh
        one is confirmed by a turn that shares no return with its own. A filter that the turn
        denies (a wrong start, a bad scan, a push) is dropped: the turn's candidates take over."""
        ekf = self.tracker.ekf
        assert ekf is not None
        for x, y, h in sorted(found, key=lambda c: math.dist(c[:2], ekf.pose[:2])):
            turn = self.tracker.fit_turn(x, y, h + beam, h, self.window.events)
            if ekf.agrees(turn, SAME):
                if self.tracker.lost or not ekf.agrees(turn, CONSISTENT):
                    self.tracker.adopt(turn)  # a filter gone astray, as this turn says: start again from it
                self.confirmed = now
                if self.fresh is not None and first > self.fresh:
                    self.fresh = None
                return True
        self.tracker.reset()
        self.hypotheses, self.fresh = [], None
        return False

    def _search(self, found: list[Pose], now: float, beam: float, hits: list[float]) -> None:
        """A standing turn while lost: keep the candidates that agree with those of an earlier
        turn (carried along by the odometry of the move since); start the filter when one is
        left, fresh if no earlier turn bears it out."""
        odometry = self.tracker.odometry
        confirmed = False
        if self.hypotheses:
            driven, left, turned = between(self.seen_at, odometry)
            moved = [compose(h, (driven, left, turned)) for h in self.hypotheses]
            kept = [c for c in found if any(agree(c, m, math.hypot(driven, left), turned) for m in moved)]
            if kept and min(hits) <= self.seen_end:
                return  # the same returns again: nothing new
            confirmed = bool(kept)
            found = kept or found  # none: the earlier candidates were wrong, start again from these
        self.hypotheses, self.seen_at, self.seen_end = found, odometry, now
        if len(found) > 1:
            return
        x, y, h = found[0]
        turn = self.tracker.fit_turn(x, y, h + beam, h, self.window.events)
        if self.box != self.brief.field:  # still in the start region, anywhere in it as far as the rules say
            turn.confine(self.box)
            self.box = self.brief.field
        self.tracker.adopt(turn)
        self.hypotheses, self.confirmed = [], now
        self.fresh = None if confirmed else now

    def step(self, observation: Observation) -> Command:
        now = observation.time
        if observation.trial != self.trial:  # carried to a new pose, at rest: find it again
            self.trial = observation.trial
            self.tracker.reset()
            self.window.restart(self.tracker.wheels.time)  # set down at rest: no settling
            self.plan, self.hypotheses, self.fresh = [], [], None
            self.box = self.brief.field
            self.still_since = self.tracker.wheels.time - SETTLE
        events = observation.events
        if self.ANGLE_STEP and any(e.angle is not None for e in events):
            self.stepped = True  # the step read holds the angle anywhere in it: take its middle
            events = tuple(
                e if e.angle is None else replace(e, angle=(e.angle + self.ANGLE_STEP / 2) % (2 * math.pi))
                for e in events
            )
        self.tracker.feed(events, now)
        if any(abs(s) > 1e-9 for s in self.tracker.wheels.speeds):
            self.still_since = now
            self.window.restart(now + SETTLE)
        while self.plan and self.plan[0][0] <= now:
            self.plan.pop(0)
        if not self.plan and now >= self.still_since + SETTLE:
            if self.tracker.pose is None:
                if len(self.hypotheses) > 1 and self.seen_end >= self.still_since:
                    self._plan_apart(now)
            elif self.stepped and self.confirmed >= self.still_since and self.dithers < self.DITHERS and self.goal:
                self.dithers += 1  # another look at the returns from a little further round
                self._drive(now, self.DITHER, 0.0)
            elif self.fresh is None and (
                self.confirmed >= self.still_since or now >= self.still_since + SETTLE + 2 * self.period
            ):  # confirmed at this stop, or no turn has shown enough returns to judge it
                self.dithers = 0
                self._plan(now)
        left, right = (self.plan[0][1], self.plan[0][2]) if self.plan else (0.0, 0.0)
        self.tracker.command(left, right)
        return Command(left, right, estimate=self.tracker.pose)

    def _plan(self, now: float) -> None:
        """Turn towards the goal, then drive a leg towards it. A goto robot arrives wherever it
        stands within the radius, so it stops last just outside it (APPROACH beyond), then drives
        the short rest of the way at once, already facing the goal: the stop that ends that leg
        is the arrival."""
        if self.goal is None or self.tracker.pose is None:
            return
        x, y, h = self.tracker.pose
        gx, gy = self.goal
        distance = math.dist((x, y), (gx, gy))
        task = self.brief.task
        if task.kind != "goto":
            if distance >= task.radius / 2:
                self._drive(now, wrap(math.atan2(gy - y, gx - x) - h), min(LEG, distance))
            return
        if distance < task.accuracy:
            return
        outside = distance - task.radius - APPROACH
        leg = min(LEG, outside) if outside > APPROACH / 2 else distance
        self._drive(now, wrap(math.atan2(gy - y, gx - x) - h), leg)

    def _plan_apart(self, now: float) -> None:
        """A short move (a turn, then a straight leg) that ends at least CLEARANCE inside the
        field for every candidate, chosen so that afterwards no candidate's pose, moved by the
        odometry, fits the turn another one would see; the shortest such, else the one that
        leaves the fewest pairs alike."""
        self.box = xmin, ymin, xmax, ymax = self.brief.field  # the robot is about to leave its start
        safe = (xmin + CLEARANCE, ymin + CLEARANCE, xmax - CLEARANCE, ymax - CLEARANCE)
        best: tuple[int, float, float] | None = None
        for turn, distance in MOVES:
            ends = [compose(c, (distance * math.cos(turn), distance * math.sin(turn), turn)) for c in self.hypotheses]
            if not all(safe[0] <= x <= safe[2] and safe[1] <= y <= safe[3] for x, y, _ in ends):
                continue
            alike = sum(
                any(agree(other, c, distance, turn) for c in self._seen_from(truth))
                for truth in ends
                for other in ends
                if other is not truth
            )
            if best is None or alike < best[0]:
                best = (alike, turn, distance)
        if best is not None:
            self._drive(now, best[1], best[2])

    def _seen_from(self, pose: Pose) -> list[Pose]:
        """The candidates of the turn a robot standing at `pose` would see, without noise."""
        angles = predicted_angles(self.beacons, pose)
        return self.candidates(Revolution(0.0, self.period, tuple((a, None) for a in angles)))

    def _drive(self, now: float, turn: float, leg: float) -> None:
        """Turn by `turn`, then drive `leg`, each as a trapezoid: command a wheel speed for
        (amount / rate), then stop while the wheels ramp down; with a linear ramp the two ramps
        add up to exactly one full-speed ramp time, so the robot turns or drives exactly the
        amount planned (up to slip)."""
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
        if leg <= 0:
            return
        speed = min(0.6 * top, math.sqrt(leg * accel))
        t += leg / speed
        self.plan.append((t, speed, speed))
        t += speed / accel
        self.plan.append((t, 0.0, 0.0))
