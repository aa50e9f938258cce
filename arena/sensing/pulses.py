"""Detected crossings as the hardware reads them (reflectors, sensor arrays, flash detectors):
when each pulse fires (the optics' offset, timing noise, the event clock), in each robot's
event order, with the laser's phase then and Bac's merged measurements; one compiled loop.
"""

from __future__ import annotations

import numpy as np

from arena.angles import TWO_PI
from arena.compiled import compiled, maximum, minimum
from arena.sensing.sensor_array import merge


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
    timing: np.ndarray,
    timing_at: np.ndarray,
    scale: float,
    w0: float,
    w1: float,
    omega: np.ndarray,
    reflector: bool,
    clock_hz: float,
    first_tick: float,
    direction: np.ndarray,
    merging: tuple[bool, int, float, np.uint64],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The detected crossings as read by the hardware (`Sensing._hits`), sorted by
    robot, time and beacon: which crossing each pulse is, its robot, beacon, clock reading and
    the laser's phase when it fired; and per robot, its pulse count and whether two of its
    pulses read one time. A pulse fires at t + offset, no earlier than the period's start;
    timing noise of std `scale` (0: none) jitters it within the period (w0, w1), each robot's
    pulses in crossing order drawing from row r of `timing` from `timing_at[r]` on
    (normals.Normals); a counter of `clock_hz` (0: none) truncates it,
    no earlier than `first_tick`; `merging` = (whether to, the number of arrays, the rate, the
    key) applies Bac's merged measurements (sensor_array.merge), with each robot's spin sign
    `direction`. No tuple holds an array: numba reads those slowly at each call."""
    source = np.flatnonzero(detected)
    m, n_robots = source.shape[0], omega.shape[0]
    fired, phase = np.empty(m), np.empty(m)
    rob, bea = robot[source], beacon[source]
    for j in range(m):
        fired[j] = maximum(t[source[j]] + offset[source[j]], w0)
    if scale > 0:
        for r in range(n_robots):
            for j in range(m):
                if rob[j] == r:
                    draw = 0.0 + scale * timing[r, timing_at[r]]  # as normal(0, scale) gives it
                    timing_at[r] += 1
                    fired[j] = minimum(maximum(fired[j] + draw, w0), w1)
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
        times[a] = maximum(v, first_tick)
    rob, bea, phase = rob[order], bea[order], phase[order]
    merge_on, n_beacons, rate, key = merging
    if merge_on and rate > 0 and m >= 2:
        turn = np.empty(m)
        for a in range(m):
            turn[a] = np.floor(phi[source[order[a]]] * direction[rob[a]] / TWO_PI)
        times, _ = merge(times, rob, bea, turn, n_beacons, rate, key)
    counts = np.zeros((2, n_robots), np.int64)  # per robot: its pulses, and whether two read one time
    for a in range(m):
        counts[0, rob[a]] += 1
        if a and rob[a] == rob[a - 1] and times[a] == times[a - 1]:
            counts[1, rob[a]] = 1
    return source[order], rob, bea, times, phase, counts
