"""A robot's pose from its laser events and its own wheel commands, kept at every instant.

How it works, in detail: docs/internals.md, `robots/toolkit/tracker.py`.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

from robots.api import Brief, SensorEvent
from robots.toolkit.angles import wrap
from robots.toolkit.crowd import CROWDED_Q, CROWDED_RESTART_HEADING, CROWDED_WANDER, Crowd
from robots.toolkit.ekf import BearingEKF, FloatEKF
from robots.toolkit.motion import Pose, Wheels, advance
from robots.toolkit.revolution import STEADY_TURN, TIME_OUT_TURNS, revolution_fix

UNKNOWN_HEADING = 0.5  # rad: a heading less sure than this (one sd) does not say which way the robot drives
LEARN_TRACK = 0.01  # m: "only when the distance between two consecutive positions was larger than 1 cm"
# s: a robot that drives a way it does not know moves, to its filter, as a random walk whose
# spread grows by the distance it drives in WANDER, so that the pulses lead its position
WANDER = 1.0
VAGUE = 1.0  # m^2, rad^2: the variances of a pose known only from the returns about to come


# A closed-form fix from an event and those before it: (x, y, the beam's world angle now,
# the heading if the hardware tells it, else None), or None (also when it has started or
# dropped the filter itself, with `adopt` or `reset`).
FirstFix = Callable[[SensorEvent], "tuple[float, float, float, float | None] | None"]


class HitTracker:
    """The pose (x, y, heading) of one robot from its laser events and wheel commands.

    `bearing_sigma` is one hit's bearing noise (rad), `gate` the EKF gate (standard
    deviations); when `lost_after` of the last `window` hits failed the gate, it restarts;
    `q_heading` (rad^2 per rad turned) and `q_drift` (rad^2 per m driven) say how far the
    drive may stray from its commands in heading; `wobble` is the laser's relative rate
    noise (its correlation time 1 s, BearingEKF); `latched_sigma`, if given, is the noise of an
    angle the head latches itself (a stepped head), where it differs from a timed one's.
    `first_fix` replaces the labelled revolution fix for starts and restarts. A filter that is
    not lost and agreed with the last labelled fix is checked against one at most once every
    `check_turns` laser turns (0: at every hit): solving a fix costs more than the filter's
    update. `plain_floats` runs the filter as FloatEKF, several times cheaper (the same filter
    up to rounding)."""

    def __init__(
        self,
        brief: Brief,
        bearing_sigma: float = 2e-3,
        gate: float = 5.0,
        lost_after: int = 8,
        window: int = 16,
        q_xy: float = 2e-4,
        q_heading: float = 0.03,
        q_drift: float = 0.02,
        track_check: float = 0.02,
        heading_check: float = 0.5,
        wobble: float = 0.005,
        latched_sigma: float | None = None,
        first_fix: FirstFix | None = None,
        check_turns: float = 0.0,
        plain_floats: bool = False,
    ):
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.omega = brief.laser.angular_velocity
        self.period = 2 * math.pi / abs(self.omega)
        self.time_out = TIME_OUT_TURNS * self.period
        self.top = brief.robot.max_wheel_speed
        self.wheels = Wheels(brief.robot.track, brief.robot.max_wheel_accel)
        # where the commanded wheels alone say the robot is, from (0, 0, 0) at the start: the
        # motion between two times, whatever the filter did meanwhile
        self.odometry: Pose = (0.0, 0.0, 0.0)
        self.readings: set[tuple[str | None, float]] = set()  # latched angles read where the odometry stands
        self.readings_at = self.odometry
        self.var, self.gate, self.lost_after = bearing_sigma**2, gate, lost_after
        self.latched_var = self.var if latched_sigma is None else latched_sigma**2
        self.q = dict(q_xy=q_xy, q_heading=q_heading, q_drift=q_drift)
        self.wobble = wobble
        self.turn_rate = 0.0  # the robot's own turn rate (rad/s) over the last prediction
        self.recent: list[tuple[float, str]] = []  # hits of the last revolutions, for a restart
        self.verdicts: deque[bool] = deque(maxlen=window)  # the last hits: did they pass the gate?
        self.restarts = 0
        # a closed-form fix this far from the filter is a disagreement (a fix averages a
        # revolution's motion, so the margin grows by one revolution's travel at top speed)
        self.fix_check = 0.025 + self.top * self.period
        self.disagree_since: float | None = None  # since when every closed-form fix disagrees
        self.check_every = check_turns * self.period
        self.checked = -math.inf  # when a closed-form fix last checked the filter
        self.filter_class = FloatEKF if plain_floats else BearingEKF
        self.track_check, self.heading_check = track_check, heading_check
        self.first_fix = first_fix or self._labelled_fix
        self._own_fix = first_fix is None  # the labelled fix: it has no state, so it may be skipped
        self.start = brief.start  # where a first fix among other lasers' pulses looks (None once moved)
        self.crowd = Crowd(brief, self.beacons, self.period, self.time_out, self.fix_check)
        self.run_from: tuple[float, float] | None = None  # where the current straight run began
        self.ekf: BearingEKF | None = None
        start = brief.start
        if start is not None and start.region is None and start.heading_known:
            # the rules announce the start pose: the filter starts there, as unsure as the
            # announced spread (uniform: its variance is a third of the square of its half-width);
            # the beam's angle comes with the first hit. Otherwise the first fix starts it.
            self.ekf = self._filter(
                *start.pose,
                0.0,
                var_xy=max(1e-6, start.position_spread**2 / 4),
                var_heading=max(1e-4, start.heading_spread**2 / 3),
                var_sum=10.0,
            )

    def reset(self) -> None:
        """Forget the pose: the robot was carried elsewhere and set down at rest at the time of
        the last `feed` (a localize trial began); the next fix starts the filter again."""
        self.wheels = Wheels(self.wheels.track, self.wheels.accel, self.wheels.time)
        self.ekf = None
        self.readings.clear()
        self.recent.clear()
        self.verdicts.clear()
        self.turn_rate = 0.0
        self.disagree_since = None
        self.checked = -math.inf
        self.run_from = None
        self.crowd.reset()
        self.start = None  # carried elsewhere: the announced start says nothing of where

    @property
    def crowded(self) -> bool:
        """Whether other lasers' pulses reach these arrays too (shared crosstalk): once
        noticed, for good."""
        return self.crowd.shared

    @property
    def heading_sd(self) -> float:
        """The standard deviation of the heading (rad), inf before the first fix: a robot
        without a heading sensor learns its heading by moving (Bac's consecutive positions)."""
        return math.sqrt(self.ekf.variance(2)) if self.ekf else math.inf

    @property
    def pose(self) -> tuple[float, float, float] | None:
        """The pose now (at the time of the last `feed`), or None before the first fix."""
        return self.ekf.pose if self.ekf else None

    def command(self, left: float, right: float) -> None:
        """The wheel command just sent to the drive (m/s), effective now."""
        straight = left == right > 0 and self.wheels.speeds[0] == self.wheels.speeds[1]
        if not straight or self.ekf is None:
            self.run_from = None
        elif self.run_from is None:
            self.run_from = self.ekf.pose[:2]
        self.wheels.command(left, right, self.top)

    def feed(self, events: tuple[SensorEvent, ...] | list[SensorEvent], now: float) -> None:
        """Take one control period's events (in time order) and carry the pose to `now`."""
        seen: set[float] = set()
        tied: set[float] = set()  # instants of two hits or more
        pulses: dict[str, list[float]] = {}  # each array's pulse times in this period
        for e in events:
            if e.kind == "hit":
                (tied if e.time in seen else seen).add(e.time)
                if e.beacon is not None:
                    pulses.setdefault(e.beacon, []).append(e.time)
        for e in events:
            if e.kind == "hit" and e.time in tied:
                continue  # a merged pulse: two arrays reported at one instant
            if e.kind not in ("hit", "index") or (e.beacon is not None and e.beacon not in self.beacons):
                continue
            self._advance(e.time)
            if e.kind == "hit" and e.beacon is not None and self._own_fix and self.crowd.hear(e.time, e.beacon):
                self._share()
            if self.crowded and e.kind == "hit" and e.beacon is not None:
                self._crowded_hit(e, pulses[e.beacon])
            else:
                self._event(e)
        self._advance(now)
        self._check_heading()

    def _check_heading(self) -> None:
        """Bac's heading from consecutive positions, as a check on the filter's heading."""
        if self.run_from is None or self.ekf is None:
            return
        x, y, h = self.ekf.pose
        unknown = self.heading_sd > UNKNOWN_HEADING
        # an unknown heading is taken at Bac's "larger than 1 cm"; a known one is checked over `track_check`
        if math.dist((x, y), self.run_from) <= (min(self.track_check, LEARN_TRACK) if unknown else self.track_check):
            return
        travel = math.atan2(y - self.run_from[1], x - self.run_from[0])
        if unknown or abs(wrap(travel - h)) > self.heading_check:  # keep the beam's world angle, turn the heading
            self.ekf = self._filter(
                x,
                y,
                travel,
                wrap(h + self.ekf.s[3] - travel),
                var_xy=self.ekf.variance(0),
                var_heading=0.05,
                var_sum=1e-4,
            )
            self.restarts += not unknown  # a heading learned is no restart
        self.run_from = (x, y)

    def _filter(
        self, x: float, y: float, heading: float, phase: float, var_xy: float, var_heading: float, var_sum: float
    ) -> BearingEKF:
        return self.filter_class(
            x,
            y,
            heading,
            phase,
            self.omega,
            var_xy=var_xy,
            var_heading=var_heading,
            var_sum=var_sum,
            var_rate=(self.wobble * self.omega) ** 2,
            wobble=self.wobble,
            **self.q,
        )

    def _advance(self, time: float) -> None:
        dt, v, w = self.wheels.advance(time)
        if dt > 0:
            self.turn_rate = w
            self.odometry = advance(self.odometry, dt, v, w)
        if self.ekf is None:
            return
        if v and self.heading_sd > UNKNOWN_HEADING:  # driving, but which way: any, as far as it knows
            self.ekf.predict(dt, 0.0, w)
            wander = CROWDED_WANDER if self.crowded else WANDER
            self.ekf.widen(v * v * dt * wander)
        else:
            self.ekf.predict(dt, v, w)

    def _keep(self, time: float, beacon: str) -> None:
        """A hit among those of the last revolutions, for a restart."""
        self.recent.append((time, beacon))
        while self.recent[0][0] < time - 2 * self.time_out:
            self.recent.pop(0)

    def _event(self, e: SensorEvent) -> None:
        if e.kind == "hit" and e.beacon is not None:
            self._keep(e.time, e.beacon)
        ekf = self.ekf
        lost = ekf is None or not self._update(ekf, e)
        if not lost and self.disagree_since is None and abs(self.turn_rate) > STEADY_TURN and self._own_fix:
            return  # whatever the revolution's fix, it would change nothing (below): not worth solving
        if not lost and self.disagree_since is None and self._own_fix and e.time - self.checked < self.check_every:
            return  # agreed with a fix lately enough (one that disagrees is followed at every hit)
        fix = self.first_fix(e)
        if fix is not None:
            self.checked = e.time
        self._check_fix(fix, ekf, lost, e.time)

    def _check_fix(
        self, fix: tuple[float, float, float, float | None] | None, ekf: BearingEKF | None, lost: bool, time: float
    ) -> None:
        """Restart from a closed-form fix if the filter is lost, or if every fix has
        disagreed with it for over a revolution."""
        if fix is None:
            return
        if ekf is None or lost or self._wrong(fix[:2], ekf, time):
            self.restart(*fix)

    def _wrong(self, fix: tuple[float, float], ekf: BearingEKF, time: float) -> bool:
        """Whether every closed-form fix, this one the last, has disagreed with the filter
        for over a revolution."""
        if abs(self.turn_rate) > STEADY_TURN or math.dist(fix, ekf.pose[:2]) <= self.fix_check:
            self.disagree_since = None  # agreed, or turning: the laser lags its motor, fixes are poor
        elif self.disagree_since is None:
            self.disagree_since = time
        elif time - self.disagree_since > self.period:
            # every fix far off for over a revolution: not one bad pulse shared by a few
            # overlapping revolutions, but a filter that is wrong
            return True
        return False

    def _share(self) -> None:
        """The arrays turned out to hear other lasers too: from now on, only its own pulses
        count, and the filter is told how little they really scatter."""
        self.recent.clear()  # anyone's pulses: from now on, only its own
        self.q.update(CROWDED_Q)
        if self.ekf is not None:
            self.ekf.q = (self.q["q_xy"], self.q["q_heading"], self.q["q_drift"])

    def _crowded_hit(self, e: SensorEvent, times: list[float]) -> None:
        """A labelled pulse that may be any laser's (`times`: its array's pulses this period)."""
        assert e.beacon is not None
        ekf = self.ekf
        if ekf is not None and self.crowd.mine(ekf, e, times, self.var, self.turn_rate):
            ekf.hit(*self.beacons[e.beacon], self.var, self.gate)
            self._keep(e.time, e.beacon)
            self.crowd.own[e.beacon] = e.time
        found = self.crowd.restart_fix(e.time, ekf, self.start, self.wheels.speeds, self.turn_rate, self.odometry)
        if found is not None:
            self._crowded_restart(*found[0])
            self.recent = found[1]

    def _crowded_restart(self, x: float, y: float, beam: float) -> None:
        """Restart at a fix among other lasers' pulses. A filter lost there has mostly taken
        another laser's pulse for its own, which moves its beam, not its heading: the heading
        is kept, a little less sure (`_check_heading` still corrects a robot turned by a push)."""
        if self.ekf is None:
            self.restart(x, y, beam)
            return
        h, var = self.ekf.pose[2], self.ekf.variance(2) + CROWDED_RESTART_HEADING
        self.ekf = self._filter(x, y, h, wrap(beam - h), var_xy=1e-4, var_heading=var, var_sum=1e-4)
        self.restarts += 1
        self.verdicts.clear()
        self.disagree_since = None

    def _update(self, ekf: BearingEKF, e: SensorEvent) -> bool:
        """The EKF update of `ekf` for one event; False once the filter is lost."""
        if e.angle is not None:
            if self.odometry != self.readings_at:
                self.readings, self.readings_at = set(), self.odometry
            if (e.beacon, e.angle) in self.readings:
                return True  # a head at rest latches the same angle again: nothing new
            self.readings.add((e.beacon, e.angle))
        ok = self._measure(ekf, e)
        if e.kind == "index":
            return True  # a click is no evidence of being lost or not
        self.verdicts.append(ok)
        return ok or not self.lost

    def _measure(self, ekf: BearingEKF, e: SensorEvent) -> bool:
        """The EKF update of `ekf` for one event; False if the gate refused it."""
        if e.kind == "index":
            return ekf.index(self.var, self.gate)
        if e.beacon is None:  # unlabelled: the beacon the beam should be pointing at
            beacon = min(self.beacons, key=lambda k: abs(ekf.predicted_bearing(*self.beacons[k])))
        else:
            beacon = e.beacon
        bx, by = self.beacons[beacon]
        if e.angle is not None:
            return ekf.relative(bx, by, e.angle, self.latched_var, self.gate)
        return ekf.hit(bx, by, self.var, self.gate)

    @property
    def lost(self) -> bool:
        """Whether `lost_after` of the last hits failed the gate."""
        return self.verdicts.count(False) >= self.lost_after

    def restart(self, x: float, y: float, beam: float, heading: float | None = None) -> None:
        """(Re)start the filter at (x, y) with the beam's world angle `beam` now, and the
        heading if known; otherwise the last heading (or 0) with a wide variance, for the
        motion to correct."""
        if heading is not None:
            self.ekf = self._filter(x, y, heading, wrap(beam - heading), var_xy=1e-4, var_heading=1e-3, var_sum=1e-4)
        elif self.ekf is None:  # nothing known of the heading yet
            self.ekf = self._filter(x, y, 0.0, beam, var_xy=1e-4, var_heading=10.0, var_sum=1e-4)
        else:  # lost: keep the heading, but let the next metres of motion correct it
            h = self.ekf.pose[2]
            self.ekf = self._filter(x, y, h, wrap(beam - h), var_xy=1e-4, var_heading=0.3, var_sum=1e-4)
            self.restarts += 1
        self.verdicts.clear()
        self.disagree_since = None

    def fit_turn(self, x: float, y: float, beam: float, heading: float, turn: list[SensorEvent]) -> BearingEKF:
        """A filter of the last turn of a standing robot alone (`turn`: its events in time
        order, the last now), around (x, y, heading), that turn's closed-form fix, with the
        beam's world angle `beam` now: knowing nothing at the turn's start, then taking each
        event as an update, it is as sure of its pose as that turn makes it (its geometry, its
        heading tied to its position), not as sure as a fixed guess. `adopt` makes it the filter."""
        now = self.wheels.time
        phase = beam - heading - self.omega * (now - turn[0].time)  # the laser's angle at the turn's start
        ekf = self._filter(x, y, heading, phase, var_xy=VAGUE, var_heading=VAGUE, var_sum=VAGUE)
        last = turn[0].time
        for e in turn:
            ekf.predict(e.time - last, 0.0, 0.0)
            last = e.time
            self._measure(ekf, e)
        ekf.predict(now - last, 0.0, 0.0)
        return ekf

    def adopt(self, ekf: BearingEKF) -> None:
        """(Re)start from this filter (one of `fit_turn`)."""
        if self.ekf is not None:
            self.restarts += 1
        self.ekf = ekf
        self.verdicts.clear()
        self.disagree_since = None

    def _labelled_fix(self, e: SensorEvent) -> tuple[float, float, float, None] | None:
        if e.kind != "hit" or e.beacon is None or not self.recent:
            return None
        fix = revolution_fix(self.recent, self.beacons, self.omega + self.turn_rate, self.time_out)
        return None if fix is None else (*fix, None)
