"""Other lasers' pulses on a robot's own arrays (shared crosstalk), for robots.toolkit.tracker.

Where every array also latches other robots' pulses, a pulse is no longer its own by being
labelled. `Crowd` notices it (an array firing twice within half a turn, again and again) and
from then on tells the tracker which pulses are its own: those that fall where its own beam is
predicted (the EKF's gate, the nearest of the array's pulses close by, the others left alone:
not counted as failures). The filter is lost when its own have come from fewer than `TRACKING`
arrays for `SILENCE` turns, and it starts or restarts from the sets of pulses one laser near
where it was (`one_laser`) could have made: four arrays that fit one pose, or three when it
knows well where it was.
"""

from __future__ import annotations

import math
from collections import deque

from robots.api import Brief, SensorEvent, StartInfo
from robots.toolkit.angles import wrap
from robots.toolkit.associate import one_laser
from robots.toolkit.ekf import BearingEKF
from robots.toolkit.motion import Pose
from robots.toolkit.revolution import STEADY_TURN, TurnFix, turn_fix

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
# as it drives (the tracker's WANDER random walk would spread it three times as far in a turn)
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

Pulses = list[tuple[float, str]]  # labelled pulses (time, array), in time order


class Crowd:
    """What one robot's arrays hear of other lasers: whether the table is `shared`, which
    pulses are its own, and the fix its filter restarts from among the others' pulses.

    `beacons` are the arrays' positions, `period` a laser turn (s), `time_out` how long a
    revolution may last (s), `fix_check` how far (m) a fix may lie from the filter and agree."""

    def __init__(
        self, brief: Brief, beacons: dict[str, tuple[float, float]], period: float, time_out: float, fix_check: float
    ):
        self.beacons, self.period, self.time_out, self.fix_check = beacons, period, time_out, fix_check
        self.omega = brief.laser.angular_velocity
        self.top = brief.robot.max_wheel_speed
        self.field = brief.field
        self.shared = False  # other lasers' pulses reach these arrays too
        self.last_pulse: dict[str, float] = {}  # each array's last pulse, anyone's
        self.doubles: deque[float] = deque(maxlen=CROWD_EVIDENCE)  # when an array fired again within CROWD_GAP
        self.heard: Pulses = []  # every labelled pulse of the last turns, anyone's
        self.own: dict[str, float] = {}  # shared: when each array last gave a pulse taken as its own
        self.checked = -math.inf  # shared: when a fix from anyone's pulses last checked the filter
        # shared: the last fix that disagreed with the filter, to be confirmed before a restart:
        # (time, x, y, and the odometry's x, y then)
        self.candidate: tuple[float, float, float, float, float] | None = None

    def reset(self) -> None:
        """Forget the pulses heard and taken: the robot was carried elsewhere (a shared table
        stays shared)."""
        self.heard.clear()
        self.own.clear()
        self.candidate = None

    def hear(self, time: float, beacon: str) -> bool:
        """Keep a labelled pulse (a start among others' pulses needs the whole turn before it
        noticed them), and count an array that fires again within `CROWD_GAP` of a turn; True
        when enough of them make the table shared, from now on."""
        self.heard.append((time, beacon))
        while self.heard[0][0] < time - 2 * self.time_out:
            self.heard.pop(0)
        last = self.last_pulse.get(beacon)
        self.last_pulse[beacon] = time
        if self.shared or last is None or time - last >= CROWD_GAP * self.period:
            return False
        self.doubles.append(time)
        if len(self.doubles) == CROWD_EVIDENCE and time - self.doubles[0] <= CROWD_WINDOW:
            self.shared = True
            self.own = dict.fromkeys(self.beacons, time)  # a running filter gets its silence's grace
            return True
        return False

    def mine(self, ekf: BearingEKF, e: SensorEvent, times: list[float], bearing_var: float, turn_rate: float) -> bool:
        """Whether a pulse is this robot's own: within the EKF's gate of where its beam should
        meet that array, and clearly nearer to it than any other pulse of that array within the
        gate (`times`: those of this period; the earlier ones heard): two pulses both about where
        its own should be are two lasers in step, and neither can be told for its own.
        `bearing_var` is one pulse's bearing variance, `turn_rate` the robot's own (rad/s)."""
        assert e.beacon is not None
        innovation, var = ekf.hit_innovation(*self.beacons[e.beacon], bearing_var)
        gate = min(CROWDED_GATE * math.sqrt(var), WIDEST)
        if abs(innovation) > gate:
            return False
        rate = float(ekf.s[4]) + turn_rate  # how fast the predicted beam sweeps the world
        rivals = {t for t in times if t != e.time} | {t for t, b in self.heard if b == e.beacon and t != e.time}
        for t in rivals:
            if abs(t - e.time) < self.period / 4:
                other = wrap(innovation - rate * (t - e.time))  # that pulse's innovation
                if abs(other) <= gate and other * other - innovation * innovation < SEPARATION * SEPARATION * var:
                    return False
        return True

    def heard_from(self, arrays: int) -> float:
        """Since when pulses taken as its own have come from at least `arrays` arrays."""
        times = sorted(self.own.values(), reverse=True)
        return times[arrays - 1] if len(times) >= arrays else -math.inf

    def restart_fix(
        self,
        now: float,
        ekf: BearingEKF | None,
        start: StartInfo | None,
        speeds: tuple[float, float],
        turn_rate: float,
        odometry: Pose,
    ) -> tuple[TurnFix, Pulses] | None:
        """The fix (and its pulses) the filter `ekf` must restart from at `now`, or None: a
        filter that tracks its own pulses is checked once a turn against a fix from anyone's
        (`_fix`), and restarts when they disagree; one that has lost them restarts at any fix.
        Either way the fix must be confirmed by the one before it (`_confirmed`). `start` is the
        announced start, `speeds` the commanded wheels (m/s), `odometry` where they put it."""
        tracking = ekf is not None and now - self.heard_from(TRACKING) <= SILENCE * self.period
        if tracking and self.candidate is None and now - self.checked < self.period:
            return None  # a filter that tracks is checked once a turn
        found = self._fix(now, ekf, start, speeds, turn_rate)
        self.checked = now
        if found is None:
            return None
        x, y, beam = found[0]
        if tracking and ekf is not None and self._agrees(ekf, x, y, beam, turn_rate):
            self.candidate = None
            return None
        if not self._confirmed(x, y, now, odometry):
            return None
        self.own, self.candidate = {b: now for _, b in found[1]}, None
        return found

    def _agrees(self, ekf: BearingEKF, x: float, y: float, beam: float, turn_rate: float) -> bool:
        """Whether a fix from anyone's pulses agrees with the filter: its position within
        `fix_check`, its beam within BEAM_CHECK of the filter's (a filter that took another
        laser's pulse for its own is off in its beam first). Turning, fixes are poor: no check."""
        if abs(turn_rate) > STEADY_TURN:
            return True
        off = abs(wrap(beam - float(ekf.s[2] + ekf.s[3])))
        return math.dist((x, y), ekf.pose[:2]) <= self.fix_check and off <= BEAM_CHECK

    def _confirmed(self, x: float, y: float, time: float, odometry: Pose) -> bool:
        """Whether a fix from anyone's pulses is confirmed by the one before it, a turn or more
        earlier (pulses of another turn): apart by as much as the robot's own wheels moved it
        meanwhile. Another robot near the prior makes its fixes too, but they move as it moves.
        This fix becomes the one the next must confirm."""
        last = self.candidate
        if last is not None and time - last[0] < CONFIRM_GAP * self.period:
            return False  # the same turn's pulses, much the same fix: it would confirm nothing
        self.candidate = (time, x, y, odometry[0], odometry[1])
        if last is None or time - last[0] > CONFIRM_WITHIN * self.period:
            return False
        moved = math.dist(odometry[:2], last[3:])
        return abs(math.dist((x, y), last[1:3]) - moved) <= CONFIRM + CONFIRM_SLIP * moved

    def _prior(self, ekf: BearingEKF | None, now: float, start: StartInfo | None) -> tuple[tuple[float, float], float]:
        """Where the robot should be, and within what radius (m), for a (re)start among other
        lasers' pulses: the filter's position, less sure the longer its own pulses have been
        missing; else the announced start; else anywhere on the field."""
        if ekf is not None:
            sd = math.sqrt(max(ekf.variance(0), ekf.variance(1)))
            missing = self.top * (now - self.heard_from(TRACKING))
            return ekf.pose[:2], min(PRIOR_MAX, PRIOR_MIN + 3 * sd + missing)
        xmin, ymin, xmax, ymax = start.region if start and start.region else self.field
        if start is not None and start.region is None:
            return (start.x, start.y), PRIOR_MIN + start.position_spread
        return ((xmin + xmax) / 2, (ymin + ymax) / 2), PRIOR_MIN + math.dist((xmin, ymin), (xmax, ymax)) / 2

    def _fix(
        self, now: float, ekf: BearingEKF | None, start: StartInfo | None, speeds: tuple[float, float], turn_rate: float
    ) -> tuple[TurnFix, Pulses] | None:
        """(x, y, beam world angle now) and its pulses, from the last turn's pulses that one
        laser near the prior could have made (`one_laser`): the set of four arrays that fits
        one pose nearest the prior, else, if the prior is sure enough, of three."""
        prior, radius = self._prior(ekf, now, start)
        reach = radius + max(map(abs, speeds)) * self.period  # and it moves while the turn lasts
        turning = self.omega + turn_rate  # the beam turns with the robot
        best: tuple[int, float, TurnFix, Pulses] | None = None
        for pulses in one_laser(self.heard, self.beacons, prior, reach, turning):
            if best is not None and len(pulses) < best[0]:
                break
            if len(pulses) < 4 and radius > SURE_PRIOR:
                break
            fix = turn_fix(pulses, self.beacons, turning)
            if fix is None or math.dist(fix[:2], prior) > reach:
                continue
            far = math.dist(fix[:2], prior)
            if best is None or far < best[1]:
                best = (len(pulses), far, fix, pulses)
        return None if best is None else (best[2], best[3])
