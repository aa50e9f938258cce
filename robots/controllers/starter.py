"""A waypoint follower with a filter of its own (`ref:starter`), in one file on the public API.
The starter kit `laserarena new` writes is the tutorial's robot (`tutorial`).

It has three parts; change one at a time and watch the score.

How it works, in detail: docs/internals.md, `robots/controllers/starter.py`.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation


def wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


MAX_RESIDUAL = 0.01  # rad: a hit further off than this is an outlier (e.g. a merged pulse)
MAX_TURN_FOR_FIX = 1.0  # rad/s: turning faster, the beam's rate is too uncertain for a fix
POSITION_GAIN = 0.5  # how far each fix pulls the position estimate towards it
HEADING_GAIN = 0.6  # how far the direction of travel pulls the heading estimate towards it
TRAVEL = 0.03  # m driven before the direction of travel is trusted
MAX_TRAVEL_TURN = 0.15  # rad: a stretch that turned more than this is not a straight line
APPROACH = 1.5  # 1/s: the speed (m/s) is at most this times the distance (m) to the waypoint
CREEP = 0.03  # m/s: the slowest speed, well above the servos' dead band
WINDOW = 1.0  # laser revolutions of hits in one fix (longer: more hits, but more motion in them)
STEER = 1.5  # rad/s of turn per rad of heading error while driving
SPIN_ABOVE = 0.5  # rad: heading errors above this turn on the spot
MAX_JUMP = 0.10  # m: a fix further than this from the estimate needs a second one to agree


def fix(
    hits: list[tuple[float, str]],
    beacons: dict[str, tuple[float, float]],
    omega: float,
    guess: tuple[float, float],
    velocity: tuple[float, float] = (0.0, 0.0),
) -> tuple[float, float] | None:
    """Position at the last hit's time from one revolution's hits [(time, beacon id)]: a
    least-squares fit of bearing_i = alpha0 + omega * t_i, with the robot moving at `velocity`
    meanwhile. Two hits at the same instant are a merged pulse (Bac's hardware error): both
    go. Hits that do not fit are dropped, worst first. None without three beacons."""
    times = [t for t, _ in hits]
    hits = [h for h in hits if times.count(h[0]) == 1]
    trimmed = False
    while len({b for _, b in hits}) >= 3:
        found = _gauss_newton(hits, beacons, omega, guess, velocity)
        if found is None:
            return None
        (x, y), residuals, converged = found
        worst = max(range(len(hits)), key=lambda i: abs(residuals[i]))
        if converged and abs(residuals[worst]) <= MAX_RESIDUAL:
            # three hits always fit exactly: after trimming, only a redundant fit is evidence
            return (x, y) if len(hits) > 3 or not trimmed else None
        hits = hits[:worst] + hits[worst + 1 :]
        trimmed = True
    return None


def _gauss_newton(hits, beacons, omega, guess, velocity):
    x, y = guess
    t0, t_ref = hits[0][0], hits[-1][0]
    vx, vy = velocity
    alpha = math.atan2(beacons[hits[0][1]][1] - y, beacons[hits[0][1]][0] - x)
    for _ in range(10):
        # normal equations of the 3-unknown least squares (x, y, alpha)
        jtj = [[0.0] * 3 for _ in range(3)]
        jtr = [0.0] * 3
        residuals = []
        for t, b in hits:
            bx, by = beacons[b]
            # where the laser was at time t, if it is at (x, y) at t_ref
            dx, dy = bx - (x - vx * (t_ref - t)), by - (y - vy * (t_ref - t))
            d2 = dx * dx + dy * dy
            if d2 < 1e-6:
                return None
            r = wrap(math.atan2(dy, dx) - alpha - omega * (t - t0))
            residuals.append(r)
            row = (dy / d2, -dx / d2, -1.0)  # d(residual)/d(x, y, alpha)
            for i in range(3):
                jtr[i] += row[i] * r
                for j in range(3):
                    jtj[i][j] += row[i] * row[j]
        step = solve3(jtj, [-v for v in jtr])
        if step is None:
            return None
        x, y, alpha = x + step[0], y + step[1], alpha + step[2]
        if math.hypot(step[0], step[1]) < 1e-7:
            return (x, y), residuals, True
    return (x, y), residuals, False


def solve3(a: list[list[float]], b: list[float]) -> list[float] | None:
    """Solve a 3x3 linear system by Cramer's rule; None if it is singular."""

    def det(m: list[list[float]]) -> float:
        return (
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        )

    d = det(a)
    if abs(d) < 1e-18:
        return None
    return [det([[b[r] if c == k else a[r][c] for c in range(3)] for r in range(3)]) / d for k in range(3)]


class Starter(Controller):
    """Localize on labelled beacons, fuse with odometry, follow the waypoints."""

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.omega = brief.laser.angular_velocity
        self.period = 2 * math.pi / abs(self.omega)
        xmin, ymin, xmax, ymax = brief.field
        # the announced start (docs/api.md: its spread says how far off it may be), else the field's centre
        start = brief.start.pose if brief.start else ((xmin + xmax) / 2, (ymin + ymax) / 2, 0.0)
        self.pose = start  # (x, y, heading): our belief
        self.anchor = start  # the pose where the current stretch of travel began
        self.doubtful: tuple[float, float] | None = None  # a far fix waiting for a second opinion
        self.hits: list[tuple[float, str]] = []
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0
        self.wheels = (0.0, 0.0)
        # an exactly announced start is worth reporting at once; otherwise wait for the first fix
        self.fixed = brief.start is not None and brief.start.region is None and brief.start.position_spread == 0
        self.trial = 0

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # a localize level carried us to a new pose: start over
            self.trial, self.fixed, self.hits, self.wheels = observation.trial, False, [], (0.0, 0.0)
        self._localize(observation)
        # report an estimate once we know where we are
        estimate = self.pose if self.fixed else None
        left, right = self._steer()
        self._predict(left, right)
        return Command(left, right, estimate=estimate)

    def _localize(self, observation: Observation) -> None:
        self.hits += [(e.time, e.beacon) for e in observation.events if e.kind == "hit" and e.beacon]
        # the hits of the last revolution: every beacon once
        self.hits = [h for h in self.hits if h[0] > observation.time - WINDOW * self.period]
        # the beam turns at the laser's rate plus the robot's own turn rate; while we turn
        # hard that rate is poorly known, so we dead-reckon through turns instead
        turn = (self.wheels[1] - self.wheels[0]) / self.brief.robot.track
        if abs(turn) > MAX_TURN_FOR_FIX:
            self.anchor = self.pose
            return
        speed = (self.wheels[0] + self.wheels[1]) / 2
        velocity = (speed * math.cos(self.pose[2]), speed * math.sin(self.pose[2]))
        found = fix(self.hits, self.beacons, self.omega + turn, self.pose[:2], velocity)
        if found is None:
            return
        # the fix is for the last hit's time: carry it forward to now
        lag = observation.time - self.hits[-1][0]
        fx, fy = found[0] + velocity[0] * lag, found[1] + velocity[1] * lag
        x, y, heading = self.pose
        if not self.fixed:  # the first fix: take it whole
            self.pose, self.anchor, self.fixed = (fx, fy, heading), (fx, fy, heading), True
            return
        if math.dist((fx, fy), (x, y)) > MAX_JUMP:  # far off: believe it only if the next fix agrees
            agree = self.doubtful is not None and math.dist(self.doubtful, (fx, fy)) < MAX_JUMP / 2
            self.doubtful = (fx, fy)
            if not agree:
                return
            x, y = fx, fy
        self.doubtful = None
        x, y = x + POSITION_GAIN * (fx - x), y + POSITION_GAIN * (fy - y)
        # the heading: the direction of travel since the anchor is the mean heading over the stretch
        ax, ay, ah = self.anchor
        if abs(wrap(heading - ah)) > MAX_TRAVEL_TURN or speed <= 0:
            self.anchor = (x, y, heading)  # a turn, or backwards: start a new stretch
        elif math.dist((ax, ay), (x, y)) > TRAVEL:
            travel = math.atan2(y - ay, x - ax)
            heading = wrap(heading + HEADING_GAIN * wrap(travel - (ah + wrap(heading - ah) / 2)))
            self.anchor = (x, y, heading)
        self.pose = (x, y, heading)

    def _steer(self) -> tuple[float, float]:
        x, y, h = self.pose
        while self.target < len(self.path) and math.dist((x, y), self.path[self.target]) < self.brief.task.radius / 2:
            self.target += 1
        if self.target >= len(self.path):
            return 0.0, 0.0
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - h)
        top, half = self.brief.robot.max_wheel_speed, self.brief.robot.track / 2
        period = self.brief.control_period
        if abs(error) > SPIN_ABOVE:  # turn on the spot, slowing as the error shrinks
            w = max(-0.5 * top / half, min(0.5 * top / half, 0.5 * error / period))
            return -w * half, w * half
        v, w = 0.7 * top, STEER * error
        nxt = self.path[self.target + 1] if self.target + 1 < len(self.path) else None
        if nxt is None or abs(wrap(math.atan2(nxt[1] - ty, nxt[0] - tx) - h)) > SPIN_ABOVE:
            # slow down into a waypoint where we must turn on the spot (or stop): a robot
            # that overshoots it may end up against a wall
            v = min(v, max(CREEP, APPROACH * math.dist((x, y), (tx, ty))))
        return max(-top, min(top, v - w * half)), max(-top, min(top, v + w * half))

    def _predict(self, left: float, right: float) -> None:
        """Dead-reckon one control period ahead from the wheel commands."""
        n, dt = 10, self.brief.control_period / 10
        dv = self.brief.robot.max_wheel_accel * dt
        x, y, h = self.pose
        wl, wr = self.wheels
        for _ in range(n):
            wl += max(-dv, min(dv, left - wl))
            wr += max(-dv, min(dv, right - wr))
            v, w = (wl + wr) / 2, (wr - wl) / self.brief.robot.track
            x, y, h = x + v * math.cos(h) * dt, y + v * math.sin(h) * dt, wrap(h + w * dt)
        self.wheels = (wl, wr)
        self.pose = (x, y, h)
