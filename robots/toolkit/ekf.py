"""An extended Kalman filter that takes every laser event as its own update, at its own time.

State: x, y (m), heading (rad), the laser's phase relative to the body (rad) and its spin
rate (rad/s). Between events the robot moves as a unicycle with the wheel speeds its
controller commanded, and the laser phase advances at the estimated rate (so slow wobble
is tracked). A hit of beacon i says the beam pointed at it: heading + phase = bearing to i.
An index click says phase = 0. An encoder-latched angle says bearing - heading = angle.
Each update is gated: an innovation beyond `gate` standard deviations is rejected (a merged
pulse, another robot's laser, a false return); `hit_innovation` tells what a hit would say
before it is taken (to choose among pulses that several lasers made).
"""

from __future__ import annotations

import math

import numpy as np

from robots.toolkit.angles import wrap

TWO_PI = 2 * math.pi
_IDENTITY = np.eye(5)
_IDENTITY.flags.writeable = False


class BearingEKF:
    """The filter; `P` is the 5 x 5 covariance of (x, y, heading, phase, rate)."""

    def __init__(
        self,
        x: float,
        y: float,
        heading: float,
        phase: float,
        rate: float,
        var_xy: float,
        var_heading: float,
        var_sum: float,
        var_rate: float,
        q_xy: float = 1e-4,
        q_heading: float = 3e-3,
        q_drift: float = 0.0,
        wobble: float = 0.005,
        wobble_time: float = 1.0,
    ):
        """`rate` is the laser's nominal spin rate; its true rate wanders around it by a relative
        `wobble` with correlation time `wobble_time` (a mean-reverting process). Tying the rate
        to its nominal value is what lets the filter tell a robot that does not turn as
        commanded (a collision) from a laser that spins a little faster. Process noise: `q_xy`
        m^2 per metre moved, `q_heading` rad^2 per radian turned (slip in turns) and `q_drift`
        rad^2 per metre driven (wheels that do not match: a straight command curves)."""
        self.nominal = rate
        self.wobble_var = (wobble * rate) ** 2
        self.wobble_time = wobble_time
        self.s = np.array([x, y, heading, phase, rate], dtype=float)
        # heading and phase are often known only as a sum (the beam's world angle): correlate them
        cov_hp = (var_sum - 2 * var_heading) / 2 if var_heading > var_sum else 0.0
        var_phase = var_heading if var_heading > var_sum else var_sum
        P = np.diag([var_xy, var_xy, var_heading, var_phase, var_rate])
        P[2, 3] = P[3, 2] = cov_hp
        self.P = P
        self.q = (q_xy, q_heading, q_drift)
        self._F, self._Q = np.eye(5), np.zeros((5, 5))  # predict's Jacobian and noise, filled in each time

    @property
    def pose(self) -> tuple[float, float, float]:
        return float(self.s[0]), float(self.s[1]), wrap(float(self.s[2]))

    def variance(self, k: int) -> float:
        """The variance of state `k` (0 x, 1 y, 2 heading, 3 phase, 4 rate)."""
        return float(self.P[k, k])

    def widen(self, var_xy: float) -> None:
        """Add `var_xy` (m^2) to the variance of x and of y: the robot may have strayed that far."""
        self.P[0, 0] += var_xy
        self.P[1, 1] += var_xy

    def predict(self, dt: float, v: float, w: float) -> None:
        """Move for `dt` s at forward speed v and turn rate w (the commanded wheels)."""
        if dt <= 0:
            return
        x, y, h, phase, rate = self.s.tolist()
        mid = h + w * dt / 2
        a = math.exp(-dt / self.wobble_time)
        self.s = np.array(
            [
                x + v * math.cos(mid) * dt,
                y + v * math.sin(mid) * dt,
                h + w * dt,
                phase + rate * dt,
                self.nominal + (rate - self.nominal) * a,
            ]
        )
        F = self._F  # the identity but for the four entries set here (kept: no new array per event)
        F[0, 2] = -v * math.sin(mid) * dt
        F[1, 2] = v * math.cos(mid) * dt
        F[3, 4] = dt
        F[4, 4] = a
        q_xy, q_h, q_d = self.q
        moving = abs(v) + abs(w) * 0.05
        Q = self._Q  # diagonal: only its diagonal is set
        Q[0, 0] = Q[1, 1] = q_xy * moving * dt + 1e-12
        Q[2, 2] = (q_h * abs(w) + q_d * abs(v)) * dt + 1e-12
        Q[3, 3] = 1e-12
        Q[4, 4] = self.wobble_var * (1 - a * a)
        self.P = F @ self.P @ F.T + Q

    def _update(self, innovation: float, H: np.ndarray, r: float, gate: float) -> bool:
        S = float(H @ self.P @ H) + r
        if innovation * innovation > gate * gate * S:
            return False
        K = self.P @ H / S
        self.s = self.s + K * innovation
        column = K[:, None]
        I_KH = _IDENTITY - column * H  # (the products of np.outer)
        self.P = I_KH @ self.P @ I_KH.T + column * K * r  # Joseph form: stays symmetric
        return True

    def hit(self, bx: float, by: float, var: float, gate: float = 3.0) -> bool:
        """The beam points at beacon (bx, by) now. Returns whether the update was accepted."""
        return self._pointing(bx, by, self.s[3], 1.0, var, gate)

    def hit_innovation(self, bx: float, by: float, var: float) -> tuple[float, float]:
        """What a hit of beacon (bx, by) now would say, without taking it: the innovation (rad,
        the bearing less the beam's predicted angle) and its variance, for a hit noise `var`."""
        x, y, h, phase, _ = self.s.tolist()
        dx, dy = bx - x, by - y
        d2 = max(dx * dx + dy * dy, 1e-8)
        H = np.array([-dy / d2, dx / d2, 1.0, 1.0, 0.0])
        return wrap(math.atan2(dy, dx) - h - phase), float(H @ self.P @ H) + var

    def index(self, var: float, gate: float = 3.0) -> bool:
        """The laser points straight ahead now: phase = 0 (mod 2 pi)."""
        self.s[3] = wrap(self.s[3])  # a whole turn is no error: keep the phase near 0
        return self._update(-self.s[3], np.array([0, 0, 0, 1.0, 0]), var, gate)

    def relative(self, bx: float, by: float, angle: float, var: float, gate: float = 3.0) -> bool:
        """The laser, at `angle` from straight ahead (an encoder reading), points at (bx, by)."""
        return self._pointing(bx, by, angle, 0.0, var, gate)

    def _pointing(self, bx: float, by: float, offset: float, d_phase: float, var: float, gate: float) -> bool:
        """heading + offset = bearing to (bx, by), where the offset is the laser phase state
        (d_phase 1) or a measured angle (d_phase 0)."""
        x, y, h = self.s[:3].tolist()
        dx, dy = bx - x, by - y
        d2 = dx * dx + dy * dy
        if d2 < 1e-8:
            return False
        innovation = wrap(math.atan2(dy, dx) - h - offset)
        H = np.array([-dy / d2, dx / d2, 1.0, d_phase, 0.0])  # d(h + offset - bearing)/d(state)
        return self._update(innovation, H, var, gate)

    def confine(self, box: tuple[float, float, float, float]) -> None:
        """The position is known to lie in `box` (xmin, ymin, xmax, ymax), anywhere in it alike
        (a start region the rules announce): each coordinate's estimate becomes the mean and
        variance of its Gaussian cut to the box, taken in as a measurement that gives exactly
        those (so the rest of the state follows); well inside the box nothing changes."""
        for axis in (0, 1):
            mean, var = float(self.s[axis]), float(self.P[axis, axis])
            low, high = box[axis], box[axis + 2]
            cut_mean, cut_var = _cut(mean, var, low, high)
            if cut_var >= var * (1 - 1e-9):
                continue
            r = var * cut_var / (var - cut_var)  # a measurement's variance that leaves cut_var
            H = np.zeros(5)
            H[axis] = 1.0
            self._update(mean + (cut_mean - mean) * (var + r) / var - mean, H, r, math.inf)

    def agrees(self, other: BearingEKF, chi2: float) -> bool:
        """Whether another filter's pose (x, y, heading) is this one's within their joint
        uncertainty: the squared Mahalanobis distance of the difference is at most `chi2`."""
        d = other.s[:3] - self.s[:3]
        d[2] = wrap(float(d[2]))
        return float(d @ np.linalg.solve(self.P[:3, :3] + other.P[:3, :3], d)) <= chi2

    def predicted_bearing(self, bx: float, by: float) -> float:
        """Bearing of (bx, by) relative to the current beam direction (rad, wrapped)."""
        x, y, h, phase, _ = self.s
        return wrap(math.atan2(by - y, bx - x) - h - phase)


def _cut(mean: float, var: float, low: float, high: float) -> tuple[float, float]:
    """The mean and variance of N(mean, var) cut to [low, high] (a truncated normal)."""
    sd = math.sqrt(var)
    a, b = (low - mean) / sd, (high - mean) / sd
    pdf = lambda z: math.exp(-z * z / 2) / math.sqrt(2 * math.pi)  # noqa: E731
    cdf = lambda z: (1 + math.erf(z / math.sqrt(2))) / 2  # noqa: E731
    mass = cdf(b) - cdf(a)
    if mass < 1e-9:  # all but nothing outside: the nearer edge, as sure as the estimate was
        return min(max(mean, low), high), var
    shift = (pdf(a) - pdf(b)) / mass
    spread = (a * pdf(a) - b * pdf(b)) / mass
    return mean + sd * shift, var * max(1e-9, 1 + spread - shift * shift)


_UPPER = [(i, j) for i in range(5) for j in range(i, 5)]  # the covariance's upper triangle, row by row
_DIAGONAL = [_UPPER.index((k, k)) for k in range(5)]


class FloatEKF(BearingEKF):
    """The same filter with its state and covariance kept as plain floats (the covariance as its
    15 distinct entries), its prediction and updates written out term by term: at 5 x 5
    NumPy's call overhead is most of the cost, so this is several times cheaper per event. It
    equals BearingEKF up to rounding (its update takes P - P H' H P / S, the Joseph form's value
    in exact arithmetic), so a controller that takes it gets other bits. `s` and `P` read (and
    set) as arrays."""

    @property
    def s(self) -> np.ndarray:
        return np.array(self._s)

    @s.setter
    def s(self, value: np.ndarray) -> None:
        self._s = [float(v) for v in value]

    @property
    def P(self) -> np.ndarray:
        full = np.empty((5, 5))
        for (i, j), v in zip(_UPPER, self._u):
            full[i, j] = full[j, i] = v
        return full

    @P.setter
    def P(self, value: np.ndarray) -> None:
        self._u = [float(value[i, j]) for i, j in _UPPER]

    @property
    def pose(self) -> tuple[float, float, float]:
        return self._s[0], self._s[1], wrap(self._s[2])

    def variance(self, k: int) -> float:
        return self._u[_DIAGONAL[k]]

    def widen(self, var_xy: float) -> None:
        self._u[0] += var_xy
        self._u[_DIAGONAL[1]] += var_xy

    def predict(self, dt: float, v: float, w: float) -> None:
        """As BearingEKF's, F P F' + Q written out: F is the identity but for (0, 2), (1, 2),
        (3, 4) and (4, 4)."""
        if dt <= 0:
            return
        x, y, h, phase, rate = self._s
        mid = h + w * dt / 2
        a = math.exp(-dt / self.wobble_time)
        c, s = math.cos(mid), math.sin(mid)
        self._s = [
            x + v * c * dt,
            y + v * s * dt,
            h + w * dt,
            phase + rate * dt,
            self.nominal + (rate - self.nominal) * a,
        ]
        f02, f12 = -v * s * dt, v * c * dt
        p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = self._u
        c02, c12, c04, c14, c34 = p02 + f02 * p22, p12 + f12 * p22, p04 + f02 * p24, p14 + f12 * p24, p34 + dt * p44
        q_xy, q_h, q_d = self.q
        q = q_xy * (abs(v) + abs(w) * 0.05) * dt + 1e-12
        self._u = [
            p00 + f02 * p02 + f02 * c02 + q,
            p01 + f02 * p12 + f12 * c02,
            c02,
            p03 + f02 * p23 + dt * c04,
            a * c04,
            p11 + f12 * p12 + f12 * c12 + q,
            c12,
            p13 + f12 * p23 + dt * c14,
            a * c14,
            p22 + (q_h * abs(w) + q_d * abs(v)) * dt + 1e-12,
            p23 + dt * p24,
            a * p24,
            p33 + dt * p34 + dt * c34 + 1e-12,
            a * c34,
            a * a * p44 + self.wobble_var * (1 - a * a),
        ]

    def _gain(self, h0: float, h1: float, h2: float, h3: float, h4: float) -> tuple[float, ...]:
        """P H' (five terms) and H P H', for H = (h0, ..., h4)."""
        p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = self._u
        a0 = p00 * h0 + p01 * h1 + p02 * h2 + p03 * h3 + p04 * h4
        a1 = p01 * h0 + p11 * h1 + p12 * h2 + p13 * h3 + p14 * h4
        a2 = p02 * h0 + p12 * h1 + p22 * h2 + p23 * h3 + p24 * h4
        a3 = p03 * h0 + p13 * h1 + p23 * h2 + p33 * h3 + p34 * h4
        a4 = p04 * h0 + p14 * h1 + p24 * h2 + p34 * h3 + p44 * h4
        return a0, a1, a2, a3, a4, a0 * h0 + a1 * h1 + a2 * h2 + a3 * h3 + a4 * h4

    def _update(self, innovation: float, H: np.ndarray | list[float], r: float, gate: float) -> bool:
        a0, a1, a2, a3, a4, hph = self._gain(*H)
        S = hph + r
        if innovation * innovation > gate * gate * S:
            return False
        g = innovation / S
        x, y, h, phase, rate = self._s
        self._s = [x + a0 * g, y + a1 * g, h + a2 * g, phase + a3 * g, rate + a4 * g]
        b0, b1, b2, b3, b4 = a0 / S, a1 / S, a2 / S, a3 / S, a4 / S
        p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = self._u
        self._u = [
            p00 - a0 * b0,
            p01 - a0 * b1,
            p02 - a0 * b2,
            p03 - a0 * b3,
            p04 - a0 * b4,
            p11 - a1 * b1,
            p12 - a1 * b2,
            p13 - a1 * b3,
            p14 - a1 * b4,
            p22 - a2 * b2,
            p23 - a2 * b3,
            p24 - a2 * b4,
            p33 - a3 * b3,
            p34 - a3 * b4,
            p44 - a4 * b4,
        ]
        return True

    def hit_innovation(self, bx: float, by: float, var: float) -> tuple[float, float]:
        x, y, h, phase, _ = self._s
        dx, dy = bx - x, by - y
        d2 = max(dx * dx + dy * dy, 1e-8)
        return wrap(math.atan2(dy, dx) - h - phase), self._gain(-dy / d2, dx / d2, 1.0, 1.0, 0.0)[5] + var

    def index(self, var: float, gate: float = 3.0) -> bool:
        self._s[3] = wrap(self._s[3])
        return self._update(-self._s[3], [0.0, 0.0, 0.0, 1.0, 0.0], var, gate)

    def _pointing(self, bx: float, by: float, offset: float, d_phase: float, var: float, gate: float) -> bool:
        x, y, h = self._s[:3]
        dx, dy = bx - x, by - y
        d2 = dx * dx + dy * dy
        if d2 < 1e-8:
            return False
        innovation = wrap(math.atan2(dy, dx) - h - offset)
        return self._update(innovation, [-dy / d2, dx / d2, 1.0, d_phase, 0.0], var, gate)

    def hit(self, bx: float, by: float, var: float, gate: float = 3.0) -> bool:
        return self._pointing(bx, by, self._s[3], 1.0, var, gate)
