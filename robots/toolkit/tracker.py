"""A robot's pose from its laser events and its own wheel commands, kept at every instant.

The EKF of robots.toolkit.ekf predicts with the wheel speeds the controller commanded (the
nominal ramped model of robots.toolkit.motion: the team cannot know its drive's true gains)
and takes each event at its own time, so the pose is exact at the control tick, not at the
last fix. A labelled hit says the beam points at that beacon; an encoder-latched angle says
where it pointed relative to the robot; an index click says it points straight ahead; an
unlabelled hit is taken as the beacon whose predicted bearing is nearest. Outliers go at
three levels:
- two hits at one instant are Bac's merged pulse ("the measured duration of any pulse was
  added to the next pulse duration"): both are dropped;
- the EKF gate rejects a hit whose bearing disagrees with the prediction (a false pulse, a
  merged pulse at another time, a pulse from a turning laser that the model does not follow);
- when hits keep failing the gate (half of the last `window` or more: the robot was pushed,
  or slipped more than the filter allows), or when every closed-form fix for over a
  revolution, the robot not turning, disagrees with the filter by more than 25 mm plus a revolution's travel (a filter that explains the
  pulses with a wrong laser phase and position), the tracker restarts from a closed-form fix. For labelled hits that is the
  fix of the last revolution that passes
  Bac's checks: a revolution runs from one pulse of an array to its next pulse, within the
  130 ms time-out (scaled to the laser's rate); its time must agree with the laser's period within its smallest pulse
  duration ("The algorithm selected the smallest pulse duration ... as a difference
  tolerance"); three of the four arrays are enough ("the system uses the remaining three
  pulses"). A fix with four arrays must also be self-consistent. Hardware without labels
  brings its own closed-form fix (`first_fix`), e.g. Vannoy's sector rule between index clicks.
Where every array also latches other robots' pulses (shared crosstalk), a pulse is no longer
its own by being labelled. The tracker notices it (an array firing twice within half a turn,
again and again) and from then on takes a pulse only if it falls where its own beam is
predicted (the EKF's gate, the nearest of the array's pulses close by, the others left alone:
not counted as failures); it is lost when its own have come from fewer than two arrays for `SILENCE` turns, and it
starts or restarts from the sets of pulses one laser near where it was (`one_laser`) could
have made: four arrays that fit one pose, or three when it knows well where it was.
A stopping robot can instead judge its standing turns itself: `fit_turn` is a filter of one
standing turn alone, as sure of the pose as that turn's geometry makes it (not a fixed guess),
and `adopt` restarts from it. A head at rest that latches the same angle again brings nothing
new: such a repeat is not taken twice. `odometry` is where the commanded wheels alone put the
robot, for carrying candidate poses along a move.
The heading is checked as Bac measured it, "by evaluating two consecutive positions": on a
straight run, once the filtered position has moved `track_check` (m), the direction of travel
must agree with the filtered heading within `heading_check` (rad), or the heading restarts
from it (a robot held by a wall or another robot turns less than it was told, and the laser's
own rate cannot tell that from a robot that turns). A robot whose heading is not known yet
(its sd above UNKNOWN_HEADING: no heading announced, and labelled pulses without an index tell
only the beam's world angle) is predicted to stay where it is, less sure of where the further
it drives (`WANDER`), since it could be driving any way; its first straight run gives it its heading.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Callable

from robots.api import Brief, SensorEvent
from robots.toolkit.angles import wrap
from robots.toolkit.associate import one_laser
from robots.toolkit.ekf import BearingEKF
from robots.toolkit.motion import Pose, Wheels, advance
from robots.toolkit.solvers import least_squares

# "the time-out limit, which was set to 130 ms", with the laser at 81 rad/s: 1.68 turns, the
# same share of a turn at any laser rate (a slower laser, as in the 31 rad/s line run, waits longer)
TIME_OUT_TURNS = 0.130 * 81.0 / (2 * math.pi)
STEADY_TURN = 0.3  # rad/s: turning slower, a closed-form fix may check the filter
UNKNOWN_HEADING = 0.5  # rad: a heading less sure than this (one sd) does not say which way the robot drives
LEARN_TRACK = 0.01  # m: "only when the distance between two consecutive positions was larger than 1 cm"
# s: a robot that drives a way it does not know moves, to its filter, as a random walk whose
# spread grows by the distance it drives in WANDER, so that the pulses lead its position
WANDER = 1.0
VAGUE = 1.0  # m^2, rad^2: the variances of a pose known only from the returns about to come
FIT_RESIDUAL = 0.02  # rad: a four-array revolution fits its pulses this well, or it is an outlier
# Other lasers on the table (Bac's arrays latch every robot's pulse): an array that fires again
# within CROWD_GAP of a turn, CROWD_EVIDENCE times within CROWD_WINDOW s, hears more than one laser
# (one laser alone does so only by a false pulse, a few a minute at most)
CROWD_GAP, CROWD_EVIDENCE, CROWD_WINDOW = 0.5, 3, 1.0
# Among other lasers' pulses the gate must be about as wide as the pulses really scatter: the
# default process noise, ample where every pulse is one's own, widens it several times over
# (on asabe-race, the middle 95 % of the innovations lie within 0.35-0.97 of their predicted sd); these
# bring it to 0.8-1.3 (q_heading rad^2 per rad turned, q_drift rad^2 per m driven)
CROWDED_Q = dict(q_heading=0.003, q_drift=0.002)
# s: and a robot driving a way it does not know spreads, between two of its pulses, about as far
# as it drives (WANDER's random walk would spread it three times as far in a turn)
CROWDED_WANDER = 0.1
CROWDED_RESTART_HEADING = 0.02  # rad^2 added to the heading's variance by a restart among others' pulses
BEAM_CHECK = 0.03  # rad: a fix's beam this far from the filter's says the filter follows another laser
# a restart among others' pulses waits for a second fix, CONFIRM_GAP to CONFIRM_WITHIN turns later,
# that lies as far from the first as the odometry moved (within CONFIRM m and CONFIRM_SLIP of it)
CONFIRM_GAP, CONFIRM_WITHIN, CONFIRM, CONFIRM_SLIP = 0.9, 3.0, 0.01, 0.2
SEPARATION = 3.0  # sd: a rival pulse this much further from the prediction is not its own
# sd: the gate among other lasers' pulses, whose sd is now what the pulses scatter (on asabe-race-shared,
# seeds 1-3, 99.8 % of a robot's own pulses fall within it, and 20 % fewer of the others' than within 4)
CROWDED_GATE = 3.0
# rad: but never wider than this, where others' pulses come too often (a filter that unsure of its
# beam takes a whole turn's pulses at once: a restart from `one_laser`)
WIDEST = 0.04
# turns in which fewer than TRACKING arrays gave a pulse of its own: the filter has lost its laser
# among the others (one array alone may be another laser in step with the filter's wrong phase)
SILENCE, TRACKING = 4.0, 3
PRIOR_MIN, PRIOR_MAX = 0.02, 0.15  # m: how far from where it was thought to be a restart may look
SURE_PRIOR = 0.05  # m: a prior this good may restart from three arrays among others' pulses


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
    `first_fix` replaces the labelled revolution fix for starts and restarts."""

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
        self.track_check, self.heading_check = track_check, heading_check
        self.first_fix = first_fix or self._labelled_fix
        self._own_fix = first_fix is None  # the labelled fix: it has no state, so it may be skipped
        self.field = brief.field
        self.start = brief.start  # where a first fix among other lasers' pulses looks (None once moved)
        self.crowded = False  # other lasers' pulses reach these arrays too (shared crosstalk)
        self.last_pulse: dict[str, float] = {}  # each array's last pulse, anyone's
        self.doubles: deque[float] = deque(maxlen=CROWD_EVIDENCE)  # when an array fired again within CROWD_GAP
        self.heard: list[tuple[float, str]] = []  # every labelled pulse of the last turns, anyone's
        self.own: dict[str, float] = {}  # crowded: when each array last gave a pulse taken as its own
        self.checked = -math.inf  # crowded: when a fix from anyone's pulses last checked the filter
        # crowded: the last fix that disagreed with the filter, to be confirmed before a restart:
        # (time, x, y, and the odometry's x, y then)
        self.candidate: tuple[float, float, float, float, float] | None = None
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
        self.run_from = None
        self.heard.clear()
        self.own.clear()
        self.candidate = None
        self.start = None  # carried elsewhere: the announced start says nothing of where

    @property
    def heading_sd(self) -> float:
        """The standard deviation of the heading (rad), inf before the first fix: a robot
        without a heading sensor learns its heading by moving (Bac's consecutive positions)."""
        return math.sqrt(float(self.ekf.P[2, 2])) if self.ekf else math.inf

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
        at = Counter(e.time for e in events if e.kind == "hit")
        pulses: dict[str, list[float]] = {}  # each array's pulse times in this period
        for e in events:
            if e.kind == "hit" and e.beacon is not None:
                pulses.setdefault(e.beacon, []).append(e.time)
        for e in events:
            if e.kind == "hit" and at[e.time] > 1:
                continue  # a merged pulse: two arrays reported at one instant
            if e.kind not in ("hit", "index") or (e.beacon is not None and e.beacon not in self.beacons):
                continue
            self._advance(e.time)
            if e.kind == "hit" and e.beacon is not None and self._own_fix:
                self._hear(e)
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
                var_xy=float(self.ekf.P[0, 0]),
                var_heading=0.05,
                var_sum=1e-4,
            )
            self.restarts += not unknown  # a heading learned is no restart
        self.run_from = (x, y)

    def _filter(
        self, x: float, y: float, heading: float, phase: float, var_xy: float, var_heading: float, var_sum: float
    ) -> BearingEKF:
        return BearingEKF(
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
            self.ekf.P[0, 0] += v * v * dt * wander
            self.ekf.P[1, 1] += v * v * dt * wander
        else:
            self.ekf.predict(dt, v, w)

    def _event(self, e: SensorEvent) -> None:
        if e.kind == "hit" and e.beacon is not None:
            self.recent.append((e.time, e.beacon))
            while self.recent[0][0] < e.time - 2 * self.time_out:
                self.recent.pop(0)
        ekf = self.ekf
        lost = ekf is None or not self._update(ekf, e)
        if not lost and self.disagree_since is None and abs(self.turn_rate) > STEADY_TURN and self._own_fix:
            return  # whatever the revolution's fix, it would change nothing (below): not worth solving
        self._check_fix(self.first_fix(e), ekf, lost, e.time)

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

    # ---- other lasers' pulses on the same arrays (shared crosstalk) ----------------------

    def _hear(self, e: SensorEvent) -> None:
        """Keep a labelled pulse (a start among others' pulses needs the whole turn before it
        noticed them), and count an array that fires again within `CROWD_GAP` of a turn; enough
        of them, and the tracker takes the table to be shared from now on."""
        assert e.beacon is not None
        self.heard.append((e.time, e.beacon))
        while self.heard[0][0] < e.time - 2 * self.time_out:
            self.heard.pop(0)
        last = self.last_pulse.get(e.beacon)
        self.last_pulse[e.beacon] = e.time
        if self.crowded or last is None or e.time - last >= CROWD_GAP * self.period:
            return
        self.doubles.append(e.time)
        if len(self.doubles) == CROWD_EVIDENCE and e.time - self.doubles[0] <= CROWD_WINDOW:
            self.crowded = True
            self.recent.clear()  # anyone's pulses: from now on, only its own
            self.q.update(CROWDED_Q)
            if self.ekf is not None:
                self.ekf.q = (self.q["q_xy"], self.q["q_heading"], self.q["q_drift"])
            self.own = dict.fromkeys(self.beacons, e.time)  # a running filter gets its silence's grace

    def _crowded_hit(self, e: SensorEvent, times: list[float]) -> None:
        """A labelled pulse that may be any laser's (`times`: its array's pulses this period)."""
        assert e.beacon is not None
        ekf = self.ekf
        mine = ekf is not None and self._mine(ekf, e, times)
        if mine:
            assert ekf is not None
            ekf.hit(*self.beacons[e.beacon], self.var, self.gate)
            self.recent.append((e.time, e.beacon))
            while self.recent[0][0] < e.time - 2 * self.time_out:
                self.recent.pop(0)
            self.own[e.beacon] = e.time
        tracking = ekf is not None and e.time - self.heard_from(TRACKING) <= SILENCE * self.period
        if tracking and self.candidate is None and e.time - self.checked < self.period:
            return  # a filter that tracks is checked once a turn
        found = self._crowded_fix(e.time)
        self.checked = e.time
        if found is None:
            return
        (x, y, beam), pulses = found
        if tracking and ekf is not None and self._agrees(ekf, x, y, beam):
            self.candidate = None
            return
        if self._confirmed(x, y, e.time):
            self._crowded_restart(x, y, beam)
            self.recent, self.own, self.candidate = pulses, {b: e.time for _, b in pulses}, None

    def _agrees(self, ekf: BearingEKF, x: float, y: float, beam: float) -> bool:
        """Whether a fix from anyone's pulses agrees with the filter: its position within
        `fix_check`, its beam within BEAM_CHECK of the filter's (a filter that took another
        laser's pulse for its own is off in its beam first). Turning, fixes are poor: no check."""
        if abs(self.turn_rate) > STEADY_TURN:
            return True
        off = abs(wrap(beam - float(ekf.s[2] + ekf.s[3])))
        return math.dist((x, y), ekf.pose[:2]) <= self.fix_check and off <= BEAM_CHECK

    def _confirmed(self, x: float, y: float, time: float) -> bool:
        """Whether a fix from anyone's pulses is confirmed by the one before it, a turn or more
        earlier (pulses of another turn): apart by as much as the robot's own wheels moved it
        meanwhile. Another robot near the prior makes its fixes too, but they move as it moves.
        This fix becomes the one the next must confirm."""
        last = self.candidate
        if last is not None and time - last[0] < CONFIRM_GAP * self.period:
            return False  # the same turn's pulses, much the same fix: it would confirm nothing
        self.candidate = (time, x, y, self.odometry[0], self.odometry[1])
        if last is None or time - last[0] > CONFIRM_WITHIN * self.period:
            return False
        moved = math.dist(self.odometry[:2], last[3:])
        return abs(math.dist((x, y), last[1:3]) - moved) <= CONFIRM + CONFIRM_SLIP * moved

    def _crowded_restart(self, x: float, y: float, beam: float) -> None:
        """Restart at a fix among other lasers' pulses. A filter lost there has mostly taken
        another laser's pulse for its own, which moves its beam, not its heading: the heading
        is kept, a little less sure (`_check_heading` still corrects a robot turned by a push)."""
        if self.ekf is None:
            self.restart(x, y, beam)
            return
        h, var = self.ekf.pose[2], float(self.ekf.P[2, 2]) + CROWDED_RESTART_HEADING
        self.ekf = self._filter(x, y, h, wrap(beam - h), var_xy=1e-4, var_heading=var, var_sum=1e-4)
        self.restarts += 1
        self.verdicts.clear()
        self.disagree_since = None

    def heard_from(self, arrays: int) -> float:
        """Since when pulses taken as its own have come from at least `arrays` arrays."""
        times = sorted(self.own.values(), reverse=True)
        return times[arrays - 1] if len(times) >= arrays else -math.inf

    def _mine(self, ekf: BearingEKF, e: SensorEvent, times: list[float]) -> bool:
        """Whether a pulse is this robot's own: within the EKF's gate of where its beam should
        meet that array, and clearly nearer to it than any other pulse of that array within the
        gate (`times`: those of this period; the earlier ones heard): two pulses both about where
        its own should be are two lasers in step, and neither can be told for its own."""
        assert e.beacon is not None
        innovation, var = ekf.hit_innovation(*self.beacons[e.beacon], self.var)
        gate = min(CROWDED_GATE * math.sqrt(var), WIDEST)
        if abs(innovation) > gate:
            return False
        rate = float(ekf.s[4]) + self.turn_rate  # how fast the predicted beam sweeps the world
        rivals = {t for t in times if t != e.time} | {t for t, b in self.heard if b == e.beacon and t != e.time}
        for t in rivals:
            if abs(t - e.time) < self.period / 4:
                other = wrap(innovation - rate * (t - e.time))  # that pulse's innovation
                if abs(other) <= gate and other * other - innovation * innovation < SEPARATION * SEPARATION * var:
                    return False
        return True

    def _prior(self, now: float) -> tuple[tuple[float, float], float]:
        """Where the robot should be, and within what radius (m), for a (re)start among other
        lasers' pulses: the filter's position, less sure the longer its own pulses have been
        missing; else the announced start; else anywhere on the field."""
        if self.ekf is not None:
            sd = math.sqrt(max(float(self.ekf.P[0, 0]), float(self.ekf.P[1, 1])))
            missing = self.top * (now - self.heard_from(TRACKING))
            return self.ekf.pose[:2], min(PRIOR_MAX, PRIOR_MIN + 3 * sd + missing)
        xmin, ymin, xmax, ymax = self.start.region if self.start and self.start.region else self.field
        if self.start is not None and self.start.region is None:
            return (self.start.x, self.start.y), PRIOR_MIN + self.start.position_spread
        return ((xmin + xmax) / 2, (ymin + ymax) / 2), PRIOR_MIN + math.dist((xmin, ymin), (xmax, ymax)) / 2

    def _crowded_fix(self, now: float) -> tuple[tuple[float, float, float], list[tuple[float, str]]] | None:
        """(x, y, beam world angle now) and its pulses, from the last turn's pulses that one
        laser near the prior could have made (`one_laser`): the set of four arrays that fits
        one pose nearest the prior, else, if the prior is sure enough, of three."""
        prior, radius = self._prior(now)
        reach = radius + max(map(abs, self.wheels.speeds)) * self.period  # and it moves while the turn lasts
        best: tuple[int, float, tuple[float, float, float], list[tuple[float, str]]] | None = None
        for pulses in one_laser(self.heard, self.beacons, prior, reach, self.omega + self.turn_rate):
            if best is not None and len(pulses) < best[0]:
                break
            if len(pulses) < 4 and radius > SURE_PRIOR:
                break
            fix = self._solve(pulses)
            if fix is None or math.dist(fix[:2], prior) > reach:
                continue
            far = math.dist(fix[:2], prior)
            if best is None or far < best[1]:
                best = (len(pulses), far, fix, pulses)
        return None if best is None else (best[2], best[3])

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
        fix = self.revolution_fix()
        return None if fix is None else (*fix, None)

    def revolution_fix(self) -> tuple[float, float, float] | None:
        """(x, y, beam world angle now) from the revolution that the newest hit closes, or None
        if it fails Bac's checks."""
        end, closing = self.recent[-1]
        before = [k for k, (t, b) in enumerate(self.recent[:-1]) if b == closing]
        if not before:
            return None
        begin = before[-1]
        duration = end - self.recent[begin][0]
        rate = abs(self.omega + self.turn_rate)  # the beam turns with the robot
        if duration > self.time_out:
            return None  # a pulse of the closing array itself went missing
        hits = self.recent[begin + 1 :]
        times = [self.recent[begin][0]] + [t for t, _ in hits]
        smallest = min(b - a for a, b in zip(times, times[1:]))
        if abs(duration - 2 * math.pi / rate) > smallest or len({b for _, b in hits}) != len(hits) or len(hits) < 3:
            return None
        return self._solve(hits)

    def _solve(self, hits: list[tuple[float, str]]) -> tuple[float, float, float] | None:
        """(x, y, beam world angle at the last hit) from one turn's hits of distinct arrays, by
        least squares; None if it fails, or if four or more fit it badly."""
        end = hits[-1][0]
        rate = abs(self.omega + self.turn_rate)  # the beam turns with the robot
        sign = math.copysign(1.0, self.omega + self.turn_rate)
        points = [self.beacons[b] for _, b in hits]
        bearings = [sign * rate * (t - end) for t, _ in hits]  # relative to the beam now
        fix = least_squares(points, bearings, sigma=1e-3)
        if not fix.ok:
            return None
        if (
            len(hits) > 3
            and max(
                abs(wrap(math.atan2(by - fix.y, bx - fix.x) - fix.heading - a)) for (bx, by), a in zip(points, bearings)
            )
            > FIT_RESIDUAL
        ):
            return None
        return fix.x, fix.y, fix.heading
