"""The spinning lasers' phases relative to their bodies, batch by batch.

The spin rate relative to the body wobbles as an Ornstein-Uhlenbeck process (relative std
`wobble`, correlation time `wobble_time`), and it answers the body's turns (Bac: "the laser
angular velocity was not constant while the robot turned"): the rotor's inertia keeps its rate
in the world when the body's yaw rate changes, so the relative rate first drops by that change,
then the motor brings it back, with time constant `spin_time`, to its steady value less
`spin_coupling` x the body's yaw rate. Both recursions run compiled (arena.compiled).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.compiled import compiled
from arena.sensing.normals import NO_DRAWS, Normals

_NO_ROWS = np.zeros((0, 0))  # a kernel's array argument that is not there


class Spin:
    """Every robot's laser phase, wobble and spin lag across batches (steady rate `omega`, rad/s;
    physics step `dt`; `streams`: each robot's wobble stream)."""

    def __init__(
        self,
        omega: np.ndarray,
        dt: float,
        params: Mapping[str, float],
        streams: list[np.random.Generator],
        at: np.ndarray | None = None,
    ):
        n = len(omega)
        self.omega, self.dt, self.params, self.streams = omega, dt, params, streams
        # the state a batch moves on, as rows of one block (what sweep.sense_period takes):
        self.live = np.zeros((4, n))
        self.phi = self.live[0]  # unwrapped laser phase; 0 = straight ahead at t = 0
        self.wobble = self.live[1]
        self.spin_lag = self.live[2]  # the laser's relative rate minus its steady value (rad/s)
        self.body_rate = self.live[3]  # the body's yaw rate in the last step (rad/s)
        self._powers: dict[tuple[float, tuple], np.ndarray] = {}  # (a, batch shape) -> a^1..a^n per row
        self._models: dict[int, tuple] = {}  # batch length -> `model`
        # the wobble's draws, drawn ahead (`at`: where to keep each robot's position in them)
        self._noise = Normals(streams, at=at) if params["wobble"] > 0 else None

    def moved(self) -> None:
        """The robots were carried to new poses: no body turn carries over into the next batch."""
        self.body_rate[:] = 0.0

    def phases(self, heading: np.ndarray) -> np.ndarray:
        """Unwrapped laser phases at the step ends, from the body headings there (steps + 1,
        robots); the last row is where the next batch starts."""
        return laser_phases(self.omega, self.dt, self.phi, heading, *self.drive(len(heading) - 1), *self.state())

    def drive(self, steps: int) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray, float, float, np.ndarray]:
        """What moves the phases through a batch of `steps` steps, as `laser_phases` takes it after
        the headings: the wobble's standard normals (normals.Normals' block and positions, each
        robot's from its own stream; none without wobble), their scale, decay and powers, then
        the spin lag's decay (negative: none), coupling and powers. All but the draws depend
        only on `steps` (`model`)."""
        return (*self.draws(steps), *self.model(steps))

    def model(self, steps: int) -> tuple[float, float, np.ndarray, float, float, np.ndarray]:
        """`drive` but the draws, for batches of `steps` steps: kept per batch length."""
        model = self._models.get(steps)
        if model is None:
            model = self._models[steps] = self._model_of(steps)
        return model

    def draws(self, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """The wobble's block of draws and each robot's position in it, with a batch of `steps`
        steps' need left (none without wobble: normals.NO_DRAWS)."""
        return self._noise.ready(steps) if self._noise else NO_DRAWS

    def refill(self, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """`draws`, every robot's row looked at now (normals.Normals.refill)."""
        return self._noise.refill(steps) if self._noise else NO_DRAWS

    def _model_of(self, steps: int) -> tuple[float, float, np.ndarray, float, float, np.ndarray]:
        """`model`, made."""
        n = len(self.omega)
        p = self.params
        scale, decay, powers = 0.0, 0.0, _NO_ROWS
        if p["wobble"] > 0:
            decay = math.exp(-self.dt / p["wobble_time"])
            scale, powers = math.sqrt(1 - decay * decay) * p["wobble"], self._powers_of(decay, (steps, n))
        lag_decay, coupled, lag_powers = -1.0, 0.0, _NO_ROWS  # a negative decay: no lag
        if p.get("spin_time", 0.0) > 0:
            lag_decay = math.exp(-self.dt / p["spin_time"])
            coupled = (1 - lag_decay) * p.get("spin_coupling", 0.0)
            lag_powers = self._powers_of(lag_decay, (steps, n))
        return scale, decay, powers, lag_decay, coupled, lag_powers

    def state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The wobble, spin lag and body yaw rate a batch starts from, as `laser_phases` takes them
        last (and updates in place)."""
        return self.wobble, self.spin_lag, self.body_rate

    def _powers_of(self, a: float, shape: tuple[int, int]) -> np.ndarray:
        """a^1..a^steps per row for a batch of `shape` (cached), or none where a^steps
        underflows (`first_order` then takes the recursion)."""
        key = (a, shape)
        powers = self._powers.get(key)
        if powers is None:
            if a ** shape[0] < 1e-150:
                powers = _NO_ROWS
            else:
                powers = np.broadcast_to(
                    a ** np.arange(1, shape[0] + 1)[:, None], shape
                ).copy()  # writeable: one compiled form
            self._powers[key] = powers
        return powers


@compiled()
def first_order(a: float, powers: np.ndarray, y0: np.ndarray, drive: np.ndarray) -> np.ndarray:
    """y[k] = a y[k-1] + drive[k] for k = 1..steps from y[0] = y0, per column. With `powers`
    (a^1..a^steps per row) in closed form, y[k] = a^k (y0 + sum_j<=k a^-j drive[j]), as NumPy
    summed it; with none (a^k would underflow), by the recursion."""
    steps, n = drive.shape
    out = np.empty((steps, n))
    for r in range(n):
        if powers.shape[0] == 0:
            y = y0[r]
            for k in range(steps):
                y = a * y + drive[k, r]
                out[k, r] = y
            continue
        acc = 0.0
        for k in range(steps):
            q = drive[k, r] / powers[k, r]
            acc = q if k == 0 else acc + q
            out[k, r] = powers[k, r] * (y0[r] + acc)
    return out


@compiled()
def laser_phases(
    omega: np.ndarray,
    dt: float,
    phi0: np.ndarray,
    heading: np.ndarray,
    noise: np.ndarray,
    noise_at: np.ndarray,
    scale: float,
    a: float,
    powers: np.ndarray,
    lag_decay: float,
    coupled: float,
    lag_powers: np.ndarray,
    wobble: np.ndarray,
    lag: np.ndarray,
    body_rate: np.ndarray,
) -> np.ndarray:
    """Unwrapped laser phases at the step ends (`Spin.phases`), from the phase a batch starts
    from (`phi0`): the steady rate `omega`, times 1 + the wobble when `noise` has rows (robot
    r's standard normals from row r, at `noise_at[r]` on, which moves past them: normals.Normals;
    their `scale`, the decay per step `a`, its `powers`), plus the spin lag when `lag_decay`
    (per step) is not negative (with (1 - decay) x coupling `coupled`, its powers). The spin's
    state (`phi0`, `wobble`, `lag` and the body's yaw rate `body_rate`) is moved on in place to
    the batch's end. Plain arguments, no tuples: numba reads a tuple of arrays far slower at
    each call."""
    steps, n = heading.shape[0] - 1, omega.shape[0]
    rate = np.empty((steps, n))
    for k in range(steps):
        for r in range(n):  # element by element: a row's view would cost a reference count each step
            rate[k, r] = omega[r]
    if noise.shape[0]:
        drive = np.empty((steps, n))
        for r in range(n):
            at = noise_at[r]
            for k in range(steps):
                drive[k, r] = scale * noise[r, at + k]
            noise_at[r] = at + steps
        w = first_order(a, powers, wobble, drive)
        for k in range(steps):
            for r in range(n):
                rate[k, r] = omega[r] * (1.0 + w[k, r])
        wobble[:] = w[steps - 1]
    if lag_decay >= 0.0:
        body = np.empty((steps, n))
        drive = np.empty((steps, n))
        for k in range(steps):
            for r in range(n):
                body[k, r] = (heading[k + 1, r] - heading[k, r]) / dt
                change = body[k, r] - (body_rate[r] if k == 0 else body[k - 1, r])
                drive[k, r] = -lag_decay * change
                if coupled != 0.0:  # a zero coupling adds only signed zeros, which vanish in the sums
                    drive[k, r] = drive[k, r] - coupled * body[k, r]
        lags = first_order(lag_decay, lag_powers, lag, drive)
        for k in range(steps):
            for r in range(n):
                rate[k, r] = rate[k, r] + lags[k, r]
        lag[:] = lags[steps - 1]
        body_rate[:] = body[steps - 1]
    phi = np.empty((steps + 1, n))
    for r in range(n):
        acc = 0.0
        phi[0, r] = 0.0 + phi0[r]
        for k in range(steps):
            v = rate[k, r] * dt
            acc = v if k == 0 else acc + v
            phi[k + 1, r] = acc + phi0[r]
    phi0[:] = phi[steps]
    return phi
