"""The sensing hot path's loops, compiled (numba), with NumPy's own numbers.

A control period's sensing is a few hundred small array operations, and NumPy's cost per call
outweighs the arithmetic. These kernels run those loops compiled, one call each, and give the
same bits as the NumPy expressions they replace (decision 0025):
- arithmetic is written in NumPy's order of operations; numba neither reorders nor fuses it
  (no fast-math, no fused multiply-add), and `hypot`, `sqrt` and `rint` are the C library's,
  as NumPy's are;
- `arctan2`, `arcsin`, `exp2` and `cos` stay NumPy calls between kernels: NumPy takes its own
  SIMD code for most of them on most processors, which differs from the C library's in the
  last bit;
- `np.maximum` and `np.minimum` keep their NaN rule (`_max`, `_min`), and a division by zero
  gives an infinity or a NaN, as in NumPy (`error_model="numpy"`), not an exception.
`tests/test_kernels.py` holds the NumPy expressions and compares bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal, TypeVar, cast

import numpy as np
from numba import njit

F = TypeVar("F", bound=Callable)

TWO_PI = 2.0 * math.pi
PER_TURN = 1.0 / TWO_PI
TINY = 1e-12
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)  # SplitMix64's constants
_MIX = np.uint64(0xD1B54A32D192ED03)
_MUL1, _MUL2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_LOW11 = np.uint64(0x7FF)


def compiled(inline: Literal["never", "always"] = "never") -> Callable[[F], F]:
    """numba's `njit` with NumPy's division rule, cached beside this module (or in the user's
    cache folder); where neither can be written, compiled afresh in each process instead."""

    def wrap(f: F) -> F:
        try:
            return cast(F, njit(cache=True, error_model="numpy", inline=inline)(f))
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return cast(F, njit(error_model="numpy", inline=inline)(f))

    return wrap


@compiled(inline="always")
def _max(a: float, b: float) -> float:
    """np.maximum of two floats: a NaN in either wins."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@compiled(inline="always")
def _min(a: float, b: float) -> float:
    """np.minimum of two floats: a NaN in either wins."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@compiled(inline="always")
def _wrap(a: float) -> float:
    """arena.angles.wrap_angle of one angle."""
    return a - TWO_PI * np.rint(a * PER_TURN)


@compiled(inline="always")
def _sign(v: float) -> float:
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v  # 0, -0 or NaN, as np.sign


@compiled()
def laser_to_beacons(x: np.ndarray, y: np.ndarray, bx: np.ndarray, by: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vectors from every laser (steps, robots) to every beacon: (steps, robots, beacons)."""
    k, r, b = x.shape[0], x.shape[1], bx.shape[0]
    dx, dy = np.empty((k, r, b)), np.empty((k, r, b))
    for i in range(k):
        for j in range(r):
            for m in range(b):
                dx[i, j, m] = bx[m] - x[i, j]
                dy[i, j, m] = by[m] - y[i, j]
    return dx, dy


@compiled()
def passes(
    beam: np.ndarray, bearing: np.ndarray, shift: np.ndarray, shifted: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the wrapped angle d = beam - bearing (+ shift) passes zero within a step, in
    (step, robot, beacon) order: those indices and the linear first guess of the instant."""
    k, r, b = bearing.shape
    d = np.empty((k, r, b))
    for i in range(k):
        for j in range(r):
            for m in range(b):
                v = beam[i, j] - bearing[i, j, m]
                if shifted:
                    v = v + shift[i, j, m]
                d[i, j, m] = _wrap(v)
    count = 0
    for pass_ in range(2):  # count, then fill
        if pass_ == 1:
            step, robot, beacon = np.empty(count, np.int64), np.empty(count, np.int64), np.empty(count, np.int64)
            s = np.empty(count)
            count = 0
        for i in range(k - 1):
            for j in range(r):
                for m in range(b):
                    d0, d1 = d[i, j, m], d[i + 1, j, m]
                    s0, s1 = _sign(d0), _sign(d1)
                    if s0 != 0.0 and s1 != s0 and abs(d1 - d0) < math.pi:
                        if pass_ == 1:
                            step[count], robot[count], beacon[count] = i, j, m
                            s[count] = d0 / (d0 - d1)
                        count += 1
    return step, robot, beacon, s


@compiled()
def crossing_steps(
    step: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    beam: np.ndarray,
    phi: np.ndarray,
) -> np.ndarray:
    """Per crossing, its step as rows: laser -> beacon at the start (ex0, ey0), the changes over
    the step (ddx, ddy, d beam, d phase) and the start's beam angle and phase: (8, crossings)."""
    out = np.empty((8, step.shape[0]))
    for n in range(step.shape[0]):
        i, j, m = step[n], robot[n], beacon[n]
        out[0, n], out[1, n] = dx[i, j, m], dy[i, j, m]
        out[2, n] = x[i + 1, j] - x[i, j]
        out[3, n] = y[i + 1, j] - y[i, j]
        out[4, n] = beam[i + 1, j] - beam[i, j]
        out[5, n] = phi[i + 1, j] - phi[i, j]
        out[6, n], out[7, n] = beam[i, j], phi[i, j]
    return out


@compiled()
def toward(rows: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Laser -> beacon at fraction `s` of each crossing's step."""
    n = s.shape[0]
    ex, ey = np.empty(n), np.empty(n)
    for c in range(n):
        ex[c] = rows[0, c] - s[c] * rows[2, c]
        ey[c] = rows[1, c] - s[c] * rows[3, c]
    return ex, ey


@compiled()
def first_guesses(
    beam: np.ndarray,
    bearing: np.ndarray,
    shift: np.ndarray,
    shifted: bool,
    dx: np.ndarray,
    dy: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    phi: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`passes`, then `crossing_steps` and `toward` of the first guesses, in one call: (step,
    robot, beacon, s, rows, ex, ey)."""
    step, robot, beacon, s = passes(beam, bearing, shift, shifted)
    rows = crossing_steps(step, robot, beacon, dx, dy, x, y, beam, phi)
    ex, ey = toward(rows, s)
    return step, robot, beacon, s, rows, ex, ey


@compiled()
def offset_ratio(ex: np.ndarray, ey: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """clip(offset / range, -1, 1): what the beam's offset asks of arcsin."""
    n = ex.shape[0]
    out = np.empty(n)
    for c in range(n):
        r = math.sqrt(ex[c] * ex[c] + ey[c] * ey[c])
        out[c] = _min(_max(offset[c] / r, -1.0), 1.0)
    return out


@compiled()
def newton_step(
    rows: np.ndarray,
    s: np.ndarray,
    ex: np.ndarray,
    ey: np.ndarray,
    bearing: np.ndarray,
    offset: np.ndarray,
    shift: np.ndarray,
    shifted: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Newton step of each crossing's instant, clipped to its step (arena.laser), and
    laser -> beacon there (`toward`)."""
    n = s.shape[0]
    out = np.empty(n)
    for c in range(n):
        ddx, ddy, da = rows[2, c], rows[3, c], rows[4, c]
        r2 = ex[c] * ex[c] + ey[c] * ey[c]
        f = rows[6, c] + s[c] * da - bearing[c]
        slope = da - (ey[c] * ddx - ex[c] * ddy) / r2
        if shifted:
            o = offset[c]
            r = math.sqrt(r2)
            f = f + shift[c]
            slope = slope + o * (ex[c] * ddx + ey[c] * ddy) / (r2 * r * math.sqrt(_max(1.0 - o * o / r2, 1e-12)))
        f = _wrap(f)
        out[c] = _min(_max(s[c] - f / (1.0 if slope == 0.0 else slope), 0.0), 1.0)
    ex, ey = toward(rows, out)
    return out, ex, ey


@compiled()
def crossing_values(
    rows: np.ndarray,
    s: np.ndarray,
    exs: np.ndarray,
    eys: np.ndarray,
    step: np.ndarray,
    beacon: np.ndarray,
    t: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
) -> np.ndarray:
    """Per crossing at its instant (laser -> beacon there: exs, eys): laser -> beacon, time,
    laser (x, y), phase, the beam's world rate and the range, as rows (8, crossings)."""
    n = s.shape[0]
    out = np.empty((8, n))
    for c in range(n):
        ddx, ddy = rows[2, c], rows[3, c]
        ex, ey = exs[c], eys[c]
        d2 = ex * ex + ey * ey
        k = step[c]
        dt = t[k + 1] - t[k]
        out[0, c], out[1, c] = ex, ey
        out[2, c] = t[k] + s[c] * dt
        out[3, c] = bx[beacon[c]] - ex
        out[4, c] = by[beacon[c]] - ey
        out[5, c] = rows[7, c] + s[c] * rows[5, c]
        out[6, c] = (rows[4, c] - (ey * ddx - ex * ddy) / d2) / dt
        out[7, c] = math.sqrt(d2)
    return out


@compiled()
def blocked(
    px: np.ndarray,
    py: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    radius: float,
    robot: np.ndarray,
    step: np.ndarray,
    s: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    reach: np.ndarray,
    silhouette: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whether each segment from a laser (px, py) to the near edge (qx, qy) of a beacon of
    `radius` at (bx, by) passes through another robot's silhouette at that instant (fraction
    `s` of step `step` of the trajectory x, y). A robot whose circle, grown by its `reach`
    in the batch, misses the segment at the batch start is not tested exactly. Returns
    (blocked, qx, qy)."""
    n, robots = px.shape[0], x.shape[1]
    qx, qy = np.empty(n), np.empty(n)
    out = np.zeros(n, np.bool_)
    for i in range(n):
        vx, vy = bx[i] - px[i], by[i] - py[i]
        d = math.hypot(vx, vy)
        shrink = (d - radius) / _max(d, TINY) if d > radius else 0.0
        qx[i], qy[i] = px[i] + vx * shrink, py[i] + vy * shrink
        if robots < 2:
            continue
        ux, uy = qx[i] - px[i], qy[i] - py[i]
        length2 = ux * ux + uy * uy
        for o in range(robots):
            if o == robot[i]:
                continue
            cx, cy = x[0, o], y[0, o]
            u = _min(_max(((cx - px[i]) * ux + (cy - py[i]) * uy) / length2, 0.0), 1.0)
            if not math.hypot(px[i] + u * ux - cx, py[i] + u * uy - cy) <= reach[o]:
                continue
            k = step[i]
            ox = x[k, o] + s[i] * (x[k + 1, o] - x[k, o])
            oy = y[k, o] + s[i] * (y[k + 1, o] - y[k, o])
            u = ((ox - px[i]) * ux + (oy - py[i]) * uy) / (length2 if length2 > 0.0 else 1.0)
            u = _min(_max(u, 0.0), 1.0)
            if math.hypot(px[i] + u * ux - ox, py[i] + u * uy - oy) <= silhouette[o]:
                out[i] = True
                break
    return out, qx, qy


@compiled()
def revolution_hash(key: np.uint64, robot: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """64 random bits per (match key, robot, revolution): SplitMix64's finaliser, a counter-based
    hash, so a revolution's draw does not depend on which control period its pulses fall in."""
    n = robot.shape[0]
    out = np.empty(n, np.uint64)
    for i in range(n):
        z = key + np.uint64(robot[i]) * _GOLDEN + np.uint64(np.int64(turn[i])) * _MIX
        z = (z ^ (z >> _S30)) * _MUL1
        z = (z ^ (z >> _S27)) * _MUL2
        out[i] = z ^ (z >> _S31)
    return out


@compiled()
def merge(
    times: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    turn: np.ndarray,
    n_beacons: int,
    rate: float,
    key: np.uint64,
) -> tuple[np.ndarray, bool]:
    """Bac's hardware error: "occasionally the measured duration of any pulse was added to the
    next pulse duration. If, for example, pulse T_1 and T_2 read 15 and 20 ms, respectively,
    T_2 was occasionally processed as 35 ms" ("about 3.4% of all incoming measurements").

    A measurement is one laser revolution; with probability `rate` (the high 53 bits of
    `revolution_hash`) one of its pulses (array drawn uniformly: the low 11 bits) loses its own
    edge and is reported at the time of the pulse before it, so the duration before it reads 0
    and the one after it reads the sum of both. `times` are sorted by (robot, time); a pulse
    whose predecessor fell in an earlier control period is left alone (its time was already
    delivered). Returns the new times and whether any merged."""
    h = revolution_hash(key, robot, turn)
    out = times.copy()
    changed = False
    for i in range(1, times.shape[0]):
        if np.float64(h[i] >> _S11) * 2.0**-53 >= rate:
            continue
        if np.int64(h[i] & _LOW11) % n_beacons != beacon[i] or robot[i] != robot[i - 1]:
            continue
        out[i] = times[i - 1]
        changed = True
    return out, changed


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
    wobble: tuple[float, float, np.ndarray, np.ndarray],
    spin: tuple[float, float, np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unwrapped laser phases at the step ends (arena.sensing.Sensing._phases): the steady rate
    `omega`, times 1 + the wobble when `noise` has rows (`wobble` = the noise's scale, the
    decay per step, its powers, the wobble before), plus the spin lag when the spin's decay
    per step is not negative (`spin` = that decay, (1 - decay) x coupling, its powers, the lag
    and the body's yaw rate before). Returns the phases and the wobble, lag and yaw rate after."""
    steps, n = heading.shape[0] - 1, omega.shape[0]
    rate = np.empty((steps, n))
    for k in range(steps):
        rate[k] = omega
    scale, a, powers, last_wobble = wobble
    if noise.shape[0]:
        w = first_order(a, powers, last_wobble, scale * noise)
        for k in range(steps):
            for r in range(n):
                rate[k, r] = omega[r] * (1.0 + w[k, r])
        last_wobble = w[steps - 1].copy()
    a, coupled, powers, last_lag, last_body = spin
    if a >= 0.0:
        body = np.empty((steps, n))
        drive = np.empty((steps, n))
        for k in range(steps):
            for r in range(n):
                body[k, r] = (heading[k + 1, r] - heading[k, r]) / dt
                change = body[k, r] - (last_body[r] if k == 0 else body[k - 1, r])
                drive[k, r] = -a * change
                if coupled != 0.0:  # a zero coupling adds only signed zeros, which vanish in the sums
                    drive[k, r] = drive[k, r] - coupled * body[k, r]
        lag = first_order(a, powers, last_lag, drive)
        for k in range(steps):
            for r in range(n):
                rate[k, r] = rate[k, r] + lag[k, r]
        last_lag, last_body = lag[steps - 1].copy(), body[steps - 1].copy()
    phi = np.empty((steps + 1, n))
    for r in range(n):
        acc = 0.0
        phi[0, r] = 0.0 + phi0[r]
        for k in range(steps):
            v = rate[k, r] * dt
            acc = v if k == 0 else acc + v
            phi[k + 1, r] = acc + phi0[r]
    return phi, last_wobble, last_lag, last_body


@compiled()
def _before(robot: np.ndarray, fired: np.ndarray, beacon: np.ndarray, i: int, j: int) -> bool:
    """Whether pulse i sorts strictly before pulse j: by robot, firing time, beacon."""
    if robot[i] != robot[j]:
        return robot[i] < robot[j]
    if fired[i] != fired[j]:
        return fired[i] < fired[j]
    return beacon[i] < beacon[j]


@compiled()
def pulses(
    t: np.ndarray,
    offset: np.ndarray,
    detected: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    phi: np.ndarray,
    draws: np.ndarray,
    window: tuple[float, float],
    omega: np.ndarray,
    reflector: bool,
    clock_hz: float,
    first_tick: float,
    merging: tuple[bool, np.ndarray, int, float, np.uint64],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The detected crossings as read by the hardware (arena.sensing.Sensing._hits), sorted by
    robot, time and beacon: which crossing each pulse is, its robot, beacon, clock reading and
    the laser's phase when it fired; and per robot, its pulse count and whether two of its
    pulses read one time. A pulse fires at t + offset, no earlier than the period's start;
    `draws` (one timing-noise draw per pulse, grouped by robot in crossing order; none: no
    noise) jitter it within the period; a counter of `clock_hz` (0: none) truncates it, no
    earlier than `first_tick`; `merging` = (whether to, each robot's spin sign, the number of
    arrays, the rate, the key) applies Bac's merged measurements (arena.detectors)."""
    w0, w1 = window
    source = np.flatnonzero(detected)
    m, n_robots = source.shape[0], omega.shape[0]
    fired, phase = np.empty(m), np.empty(m)
    rob, bea = robot[source], beacon[source]
    for j in range(m):
        fired[j] = _max(t[source[j]] + offset[source[j]], w0)
    if draws.shape[0]:
        k = 0
        for r in range(n_robots):
            for j in range(m):
                if rob[j] == r:
                    fired[j] = _min(_max(fired[j] + draws[k], w0), w1)
                    k += 1
    for j in range(m):
        i = source[j]
        phase[j] = phi[i] + (fired[j] - (fired[j] if reflector else t[i])) * omega[rob[j]]
    order = np.arange(m)
    for a in range(1, m):  # insertion sort: stable, as np.lexsort
        j = order[a]
        b = a
        while b > 0 and _before(rob, fired, bea, j, order[b - 1]):
            order[b] = order[b - 1]
            b -= 1
        order[b] = j
    times = np.empty(m)
    for a in range(m):
        v = fired[order[a]]
        if clock_hz > 0:
            v = np.floor(v * clock_hz + 1e-6) / clock_hz
        times[a] = _max(v, first_tick)
    rob, bea, phase = rob[order], bea[order], phase[order]
    merge_on, direction, n_beacons, rate, key = merging
    if merge_on and rate > 0 and m >= 2:
        turn = np.empty(m)
        for a in range(m):
            turn[a] = np.floor(phi[source[order[a]]] * direction[rob[a]] / TWO_PI)
        times, _ = merge(times, rob, bea, turn, n_beacons, rate, key)
    counts = np.zeros(n_robots, np.int64)
    tied = np.zeros(n_robots, np.bool_)
    for a in range(m):
        counts[rob[a]] += 1
        if a and rob[a] == rob[a - 1] and times[a] == times[a - 1]:
            tied[rob[a]] = True
    return source[order], rob, bea, times, phase, np.stack((counts, tied.astype(np.int64)))


@compiled()
def incidence(bearing: np.ndarray, facing: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """arena.detectors.incidence: |wrap(bearing + pi - facing of the beacon)| per crossing."""
    n = bearing.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = abs(_wrap(bearing[i] + math.pi - facing[beacon[i]]))
    return out


@compiled()
def optics(
    distance: np.ndarray,
    beam_rate: np.ndarray,
    cos_incidence: np.ndarray,
    sens: np.ndarray,
    hardware: tuple[float, float, float, float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """arena.detectors.optics' arithmetic: (detected, time offset) per crossing, for
    `hardware` = (beam diameter, divergence, aperture, trigger fraction, rise time)."""
    diameter, divergence, aperture, eta, rise = hardware
    n = distance.shape[0]
    ok, out = np.empty(n, np.bool_), np.empty(n)
    for i in range(n):
        r = distance[i]
        v = abs(beam_rate[i]) * r
        w = diameter + divergence * r
        a = aperture * cos_incidence[i]
        lit, across = sens[i] > 0.0, w + a
        peak = sens[i] * (a / w if w > a else 1.0)
        x = eta * w / sens[i] if lit else math.inf
        dwell = (across - 2.0 * x) / v
        offset = (x - across / 2.0) / v if v > 0.0 else 0.0
        ok[i] = peak >= eta * (1 - 1e-9) and lit and dwell >= rise
        out[i] = offset if ok[i] else 0.0
    return ok, out
