"""The starter controller: `laserarena new NAME` copies this file. It uses only the public API.

It localizes from labelled beacon hits (sensor arrays, flash detectors): within one laser
revolution the beam's world angle grows as alpha0 + omega * t, so each hit of beacon i at
time t_i says  bearing(robot -> beacon i) = alpha0 + omega * t_i.  Three or more beacons give
x, y and alpha0 by a few Gauss-Newton steps. Between fixes it dead-reckons from its own
wheel commands; its heading comes from consecutive fixes more than 1 cm apart (as Bac et al.
did). It steers to each waypoint in turn and reports its estimate, which the referee scores.
"""

from __future__ import annotations

import math

from robots.api import Brief, Command, Controller, Observation


def wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


MAX_RESIDUAL = 0.01  # rad: a hit further off than this is an outlier (e.g. a merged pulse)
MAX_TURN_FOR_FIX = 0.3  # rad/s


def fix(hits: list[tuple[float, str]], beacons: dict[str, tuple[float, float]], omega: float,
        guess: tuple[float, float], velocity: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float] | None:
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
        hits = hits[:worst] + hits[worst + 1:]
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
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(a)
    if abs(d) < 1e-18:
        return None
    return [det([[b[r] if c == k else a[r][c] for c in range(3)] for r in range(3)]) / d for k in range(3)]


class Starter(Controller):
    """Localize on labelled beacons, dead-reckon between fixes, follow the waypoints."""

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.beacons = {b.id: (b.x, b.y) for b in brief.beacons}
        self.omega = brief.laser.angular_velocity
        self.period = 2 * math.pi / abs(self.omega)
        xmin, ymin, xmax, ymax = brief.field
        start = brief.start or ((xmin + xmax) / 2, (ymin + ymax) / 2, 0.0)
        self.pose = start  # (x, y, heading): our belief
        self.last_fix = None  # (x, y) of the previous fix, for heading
        self.hits: list[tuple[float, str]] = []
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0
        self.wheels = (0.0, 0.0)
        self.fixed = False

    def step(self, observation: Observation) -> Command:
        self._localize(observation)
        # report an estimate once we have a fix, or from the start if the rules announce it
        estimate = self.pose if self.fixed or self.brief.start else None
        left, right = self._steer()
        self._predict(left, right)
        return Command(left, right, estimate=estimate)

    def _localize(self, observation: Observation) -> None:
        self.hits += [(e.time, e.beacon) for e in observation.events if e.kind == "hit" and e.beacon]
        self.hits = [h for h in self.hits if h[0] > observation.time - self.period]
        # the beam turns at the laser's rate plus the robot's own turn rate; while we turn
        # hard that rate is poorly known, so we dead-reckon through turns instead
        turn = (self.wheels[1] - self.wheels[0]) / self.brief.robot.track
        if abs(turn) > MAX_TURN_FOR_FIX:
            return
        speed = (self.wheels[0] + self.wheels[1]) / 2
        velocity = (speed * math.cos(self.pose[2]), speed * math.sin(self.pose[2]))
        found = fix(self.hits, self.beacons, self.omega + turn, self.pose[:2], velocity)
        if found is None:
            return
        # the fix is for the last hit's time: carry it forward to now
        lag = observation.time - self.hits[-1][0]
        x, y = found[0] + velocity[0] * lag, found[1] + velocity[1] * lag
        heading = self.pose[2]
        straight = min(self.wheels) > 0 and abs(self.wheels[1] - self.wheels[0]) < 0.01
        if self.last_fix is None or not straight:
            self.last_fix = (x, y)
        elif math.dist(self.last_fix, (x, y)) > 0.01:  # Bac: heading from fixes over 1 cm apart
            heading = math.atan2(y - self.last_fix[1], x - self.last_fix[0])
            self.last_fix = (x, y)
        self.pose = (x, y, heading)
        self.fixed = True

    def _steer(self) -> tuple[float, float]:
        x, y, h = self.pose
        while self.target < len(self.path) and math.dist((x, y), self.path[self.target]) < self.brief.task.radius / 2:
            self.target += 1
        if self.target >= len(self.path):
            return 0.0, 0.0
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - h)
        top, half = self.brief.robot.max_wheel_speed, self.brief.robot.track / 2
        if abs(error) > 0.3:  # turn on the spot
            w = math.copysign(0.5 * top / half, error)
            return -w * half, w * half
        v, w = 0.7 * top, 0.5 * error / self.brief.control_period
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
