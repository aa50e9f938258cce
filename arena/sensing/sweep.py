"""A batch's beam-beacon hits, in one compiled call (`sense`, decision 0050) of the laser
phases (spin), the vectors to the beacons and three stages: `candidates` finds every crossing,
drops those another robot's silhouette blocks or the kind's gates refuse, and gives each
detector's response there; `response` lets each sweep's light vary (`light_noise`) and applies
the optics (which sweeps fire, and how early); then `pulses` reads them as the hardware does
(the last two in one call, `fire`). Where a level has obstacles, pymunk's segment query runs
between `sense_candidates` and `fire`. Each robot's draws come in order from blocks drawn ahead
from its own streams (normals.Normals). The models are the kind modules' (reflector,
sensor_array, flash_detector, optics); here they run on one batch at once. `sense_period` is a
match's period in one call over state kept packed between periods, its glue and short loops
inlined: numba takes each array argument at a cost (decision 0053).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.compiled import compiled, maximum, minimum, wrap_angle
from arena.sensing.crossings import crossing_arrays, laser_to_beacons
from arena.sensing.occlusion import blocked
from arena.sensing.optics import sweep_optics
from arena.sensing.pulses import pulses
from arena.sensing.readout import first_tick_after, quiet
from arena.sensing.spin import laser_phases

REFLECTOR, SENSOR_ARRAY, FLASH_DETECTOR = 0, 1, 2
KIND_CODES = {"reflector": REFLECTOR, "sensor_array": SENSOR_ARRAY, "flash_detector": FLASH_DETECTOR}
# the parameters `candidates` reads, in this order (a missing one: its default)
GATES = (
    ("range", math.inf),
    ("max_incidence", math.pi),
    ("light_noise", 0.0),
    ("near_range", 0.0),
    ("far_range", 0.0),
    ("near_incidence", 0.0),
    ("far_incidence", 0.0),
    ("acceptance", math.inf),
    ("trigger_fraction", 0.0),
    ("beam_diameter", 0.0),
    ("beam_divergence", 0.0),
    ("aperture", 0.0),
)


def gates(p: Mapping[str, float], radius: float) -> np.ndarray:
    """The hardware parameters `candidates` takes (`GATES`), then the beacons' `radius`, as one array."""
    return np.array([*(float(p.get(name, default)) for name, default in GATES), radius])


def hardware(p: Mapping[str, float]) -> tuple[float, float, float, float, float]:
    """The optics' parameters (optics.sweep_optics): beam diameter, divergence, aperture,
    trigger fraction, rise time."""
    names = ("beam_diameter", "beam_divergence", "aperture", "trigger_fraction", "rise_time")
    return tuple(float(p.get(name, 0.0)) for name in names)  # type: ignore[return-value]


@compiled(inline="always")
def candidates(
    x: np.ndarray,
    y: np.ndarray,
    h: np.ndarray,
    phi: np.ndarray,
    t: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    bearing: np.ndarray,
    body_x: np.ndarray,
    body_y: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    facing: np.ndarray,
    gain: np.ndarray,
    offset: np.ndarray,
    reach: np.ndarray,
    silhouette: np.ndarray,
    kind: int,
    g: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The crossings of the beams leaving from (x, y, h, phi) at the step ends t (dx, dy: the
    vectors from each laser to each beacon at each step end, and their `bearing`: `bearings`, or
    none: crossings.near_passes),
    and which of them may fire: not blocked by another robot's body (at `body_x`, `body_y`, with each robot's
    `reach` in a batch and `silhouette`: occlusion.blocked; the beacons' radius is `g`'s last),
    and through the gates of `kind` (reflector: range and incidence; flash detector without light
    noise: flash_detector.flash_limit). Beacons at (bx, by), facing `facing`, with each its
    `gain` (none: all nominal); `g` = gates(params, radius). Returns (robot, beacon, step, s,
    rows t x y phi beam_rate distance bearing qx qy cos-incidence response keep), the response
    relative to a nominal detector head-on (hardware.sensitivity)."""
    radius = g[12]
    robot, beacon, step, s, rows = crossing_arrays(x, y, h, phi, t, bx, by, offset, dx, dy, bearing)
    n = s.shape[0]
    px, py, distance, bearing = rows[1], rows[2], rows[5], rows[6]
    hidden, qx, qy = blocked(px, py, bx, by, beacon, radius, robot, step, s, body_x, body_y, reach, silhouette)
    out = np.empty((12, n))
    out[:7] = rows
    out[7], out[8] = qx, qy
    near, far, near_i, far_i, accept, eta = g[3], g[4], g[5], g[6], g[7], g[8]
    for c in range(n):
        inc = abs(wrap_angle(bearing[c] + math.pi - facing[beacon[c]]))
        keep = not hidden[c]
        cos_inc, response = 1.0, 1.0
        if kind == REFLECTOR:
            keep = keep and distance[c] <= g[0] and inc <= g[1]
        else:
            limit = 0.0
            if kind == FLASH_DETECTOR:
                slope = (far_i - near_i) / (far - near)
                limit = near_i + slope * (minimum(maximum(distance[c], near), far) - near)
                if not g[2] > 0:
                    keep = keep and inc <= limit
            cos_inc = math.cos(inc)
            if kind == FLASH_DETECTOR and eta > 0:
                w = g[9] + g[10] * distance[c]
                a = g[11] * math.cos(limit)
                at_limit = minimum(1.0, eta / (a / w if w > a else 1.0))
                response = at_limit ** ((inc / limit) ** 2) if limit > 0 else 0.0
            elif math.isfinite(accept):
                response = np.exp2(-((inc / accept) ** 2))
            if gain.shape[0]:
                response = response * gain[beacon[c]]
        out[9, c], out[10, c], out[11, c] = cos_inc, response, 1.0 if keep else 0.0
    return robot, beacon, step, s, out


@compiled(inline="always")
def response(
    robot: np.ndarray,
    rows: np.ndarray,
    light: np.ndarray,
    light_at: np.ndarray,
    sigma: float,
    optics_on: bool,
    hardware_: tuple[float, float, float, float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """Which of `candidates`' crossings (`rows`) fire, and how early: with light noise (`sigma`
    > 0), each kept sweep's response times exp(sigma x its draw), log-normal light: near a
    detector's limit the light hovers at the threshold, so such sweeps fire late or not at all
    (each robot's standard normals from row r of `light`, from `light_at[r]` on, in crossing
    order: normals.Normals), then the optics (optics.sweep_optics; none for reflectors:
    `optics_on` false). Returns (detected, time offset)."""
    n = robot.shape[0]
    sens = rows[10].copy()
    if sigma > 0:
        for c in range(n):
            if rows[11, c] > 0.0:  # kept
                r = robot[c]
                sens[c] = sens[c] * math.exp(sigma * light[r, light_at[r]])
                light_at[r] += 1
    if not optics_on:
        return rows[11] > 0.0, np.zeros(n)
    detected, offset = sweep_optics(rows[5], rows[4], rows[9], sens, hardware_)
    for c in range(n):
        detected[c] = detected[c] and rows[11, c] > 0.0
    return detected, offset


@compiled(inline="always")
def fire(
    robot: np.ndarray,
    beacon: np.ndarray,
    rows: np.ndarray,
    kind: int,
    light: np.ndarray,
    light_at: np.ndarray,
    sigma: float,
    optics: np.ndarray,
    timing: np.ndarray,
    timing_at: np.ndarray,
    clock: np.ndarray,
    omega: np.ndarray,
    direction: np.ndarray,
    merging: np.ndarray,
    key: np.uint64,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What `candidates`' crossings (robot, beacon, `rows`) become: `response`, then `pulses`
    (`optics` = `hardware(params)` as an array; `clock` = the timing noise's scale, the window's
    start and end, the clock's rate and its first tick; `merging` = whether, the number of
    arrays and the rate; `key` the merges' key). Returns the rows, the optics' offsets, and
    `pulses`' results: which crossing each pulse is, its robot, beacon, reading and phase, and
    per robot its count and whether two of its pulses read one time."""
    hardware_ = (optics[0], optics[1], optics[2], optics[3], optics[4])
    detected, shift = response(robot, rows, light, light_at, sigma, kind != REFLECTOR, hardware_)
    source, rob, bea, times, phase, counts = pulses(
        rows[0], shift, detected, robot, beacon, rows[3], timing, timing_at, clock[0], clock[1], clock[2], omega,
        kind == REFLECTOR, clock[3], clock[4], direction, (merging[0] > 0, int(merging[1]), merging[2], key),
    )  # fmt: skip
    return rows, shift, source, rob, bea, times, phase, counts


@compiled(inline="always")
def sense_candidates(
    x: np.ndarray,
    y: np.ndarray,
    h: np.ndarray,
    t: np.ndarray,
    body_x: np.ndarray,
    body_y: np.ndarray,
    omega: np.ndarray,
    dt: float,
    phi0: np.ndarray,
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
    bx: np.ndarray,
    by: np.ndarray,
    facing: np.ndarray,
    gain: np.ndarray,
    offset: np.ndarray,
    reach: np.ndarray,
    silhouette: np.ndarray,
    kind: int,
    g: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A batch's laser phases and crossings in one call: `spin.laser_phases` (the phases, the
    spin's state moved on in place; its arguments from `omega` to `body_rate`), the vectors
    from the lasers at (x, y) to the beacons, then `candidates` with the bodies at `body_x`,
    `body_y` and no grid of bearings (one is taken only where a beam may pass:
    crossings.near_passes). Returns the phases (steps + 1, robots), and `candidates`' robot,
    beacon and rows."""
    phi = laser_phases(
        omega, dt, phi0, h, noise, noise_at, scale, a, powers, lag_decay, coupled, lag_powers, wobble, lag, body_rate
    )
    dx, dy = laser_to_beacons(x, y, bx, by)
    bearing = np.empty((0, 0, 0))  # none: taken only where a beam may pass (crossings.near_passes)
    robot, beacon, _, _, rows = candidates(
        x, y, h, phi, t, dx, dy, bearing, body_x, body_y, bx, by, facing, gain, offset, reach, silhouette, kind, g
    )
    return phi, robot, beacon, rows


@compiled(inline="always")
def pulse_rows(
    rows: np.ndarray,
    shift: np.ndarray,
    source: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    times: np.ndarray,
    phase: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """`fire`'s pulses as two blocks, what Python unpacks at once: each pulse's robot and beacon
    (2, pulses), and its reading, phase, where its laser was (x, y), its beacon's centre (x, y)
    and the optics' offset (7, pulses)."""
    m = source.shape[0]
    ids, out = np.empty((2, m), np.int64), np.empty((7, m))
    for j in range(m):
        c = source[j]
        ids[0, j], ids[1, j] = robot[j], beacon[j]
        out[0, j], out[1, j] = times[j], phase[j]
        out[2, j], out[3, j] = rows[1, c], rows[2, c]
        out[4, j], out[5, j] = bx[beacon[j]], by[beacon[j]]
        out[6, j] = shift[c]
    return ids, out


@compiled(inline="always")
def batch_poses(
    last: np.ndarray, states: np.ndarray, t0: float, t_end: float, dt: float, xyh: np.ndarray, t: np.ndarray
) -> None:
    """A batch's poses and times, in the buffers `xyh` (x, y, heading: each (steps + 1, robots))
    and `t` (steps + 1): the world's `last` state, then `states` (a row per step, each robot's
    x, y, heading in turn); the step ends at `t0 + i dt`, the last exactly `t_end`. `last` then
    holds the batch's last state, where the next begins."""
    k, n = states.shape[0], xyh.shape[2]
    for j in range(n):
        xyh[0, 0, j], xyh[1, 0, j], xyh[2, 0, j] = last[3 * j], last[3 * j + 1], last[3 * j + 2]
    for i in range(k):
        for j in range(n):
            xyh[0, i + 1, j], xyh[1, i + 1, j], xyh[2, i + 1, j] = (
                states[i, 3 * j],
                states[i, 3 * j + 1],
                states[i, 3 * j + 2],
            )
        t[i] = t0 + float(i) * dt
    t[k] = t_end
    if k:
        last[:] = states[k - 1]


@compiled()
def sense(
    x: np.ndarray,
    y: np.ndarray,
    h: np.ndarray,
    t: np.ndarray,
    body_x: np.ndarray,
    body_y: np.ndarray,
    omega: np.ndarray,
    dt: float,
    phi0: np.ndarray,
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
    bx: np.ndarray,
    by: np.ndarray,
    facing: np.ndarray,
    gain: np.ndarray,
    offset: np.ndarray,
    reach: np.ndarray,
    silhouette: np.ndarray,
    kind: int,
    g: np.ndarray,
    light: np.ndarray,
    light_at: np.ndarray,
    sigma: float,
    optics: np.ndarray,
    timing: np.ndarray,
    timing_at: np.ndarray,
    clock: np.ndarray,
    direction: np.ndarray,
    merging: np.ndarray,
    key: np.uint64,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A batch's sensing of beacons in one compiled call where nothing but robots can block a
    beam: `sense_candidates` then `fire` (its arguments from `light` on). Returns the phases,
    the pulses (`pulse_rows`' two blocks), and per robot its count of pulses and whether two of
    them read one time (`fire`'s)."""
    phi, robot, beacon, rows = sense_candidates(
        x, y, h, t, body_x, body_y, omega, dt, phi0, noise, noise_at, scale, a, powers, lag_decay, coupled, lag_powers,
        wobble, lag, body_rate, bx, by, facing, gain, offset, reach, silhouette, kind, g,
    )  # fmt: skip
    rows, shift, source, rob, bea, times, phase, counts = fire(
        robot, beacon, rows, kind, light, light_at, sigma, optics, timing, timing_at, clock, omega, direction,
        merging, key,
    )  # fmt: skip
    ids, told = pulse_rows(rows, shift, source, rob, bea, times, phase, bx, by)
    return phi, ids, told, counts


# `sense_period`'s scalars, one array (`period_params`): where each is
P_DT, P_SCALE, P_DECAY, P_LAG_DECAY, P_COUPLED, P_KIND, P_SIGMA, P_TIMING, P_CLOCK_HZ = range(9)
P_MERGING = 9  # three: whether to merge, the number of arrays, the rate
P_GAIN, P_OFFSET = 12, 13  # whether the beacons' gains, and the beams' offsets, are there
P_GATES = 14  # `gates`' 13
P_OPTICS = P_GATES + len(GATES) + 1  # `hardware`'s 5
P_NEEDS = P_OPTICS + 5  # two: a robot's need of wobble draws, and of light and timing draws, in a period
P_FALSE_RATE = P_NEEDS + 2  # false pulses per second (readout.FalseClock)
P_SIZE = P_FALSE_RATE + 1


def period_params(
    dt: float,
    drive: tuple[float, float, float, float],
    kind: int,
    sigma: float,
    timing: float,
    clock_hz: float,
    merging: np.ndarray,
    present: tuple[bool, bool],
    gates_: np.ndarray,
    optics: np.ndarray,
    needs: tuple[int, int],
    false_rate: float,
) -> np.ndarray:
    """`sense_period`'s scalars as one array: the step, the spin's `drive` (the wobble's scale
    and decay, the lag's decay and coupling: spin.Spin.model), the detector `kind`, the light
    noise `sigma`, the timing noise's scale, the event clock's rate, the merges (`fire`'s
    `merging`), whether gains and offsets are `present`, `gates_` (`gates`), `optics`
    (`hardware`), a robot's `needs` of draws in a period (of the wobble's, and of the light's
    and the timing's: normals.Normals), and the `false_rate` of false pulses."""
    p = np.empty(P_SIZE)
    p[:P_MERGING] = (dt, *drive, kind, sigma, timing, clock_hz)
    p[P_MERGING : P_MERGING + 3] = merging
    p[P_GAIN], p[P_OFFSET] = present
    p[P_GATES:P_OPTICS] = gates_
    p[P_OPTICS:P_NEEDS] = optics
    p[P_NEEDS : P_NEEDS + 2] = needs
    p[P_FALSE_RATE] = false_rate
    return p


@compiled(inline="always")
def short(values: np.ndarray, at: np.ndarray, need: float) -> bool:
    """Whether a robot's row of a block of draws (normals.Normals: `values`, each row read from
    `at[r]` on) holds less than `need` (a block of no rows: none is drawn)."""
    if values.shape[0] == 0:
        return False
    for r in range(at.shape[0]):
        if values.shape[1] - at[r] < need:
            return True
    return False


@compiled()
def sense_period(
    last: np.ndarray,
    states: np.ndarray,
    t0: float,
    t_end: float,
    poses: np.ndarray,
    t: np.ndarray,
    spin: np.ndarray,
    at: np.ndarray,
    noise: np.ndarray,
    light: np.ndarray,
    timing: np.ndarray,
    clocks: np.ndarray,
    powers: np.ndarray,
    lag_powers: np.ndarray,
    robots: np.ndarray,
    beacons: np.ndarray,
    p: np.ndarray,
    counts: np.ndarray,
    ids: np.ndarray,
    told: np.ndarray,
    key: np.uint64,
) -> tuple[int, bool, bool]:
    """A control period's sensing where beams leave from the bodies and nothing but robots
    blocks them, in one call over state kept between periods: `batch_poses` (from `last`,
    `states` and the times `t0`, `t_end` into `poses`' first three rows and `t`), then `sense`'s
    stages (`sense_candidates`, `fire`, `pulse_rows`: `sense` itself takes too many arguments
    for numba to inline).
    Its results are written in place: the phases into `poses`' fourth row; per robot its count
    of pulses, and whether two read one time, into `counts` (2, robots); the pulses
    (`pulse_rows`' two blocks) into the first columns of `ids` and `told`, which have room for
    as many as there may be crossings. Its arguments are packed, as numba takes and gives each
    array at a cost: `spin` (4, robots) is the spin's phase, wobble, lag and body rate, moved on
    in place (spin.Spin); `at` (4, robots) each robot's position in the blocks of draws `noise`,
    `light` and `timing` (normals.Normals), then in its false pulses' block of uniforms, a row
    of `clocks` (readout.FalseClock; no rows: the caller's clocks); `robots` (5, robots) the
    spin rates, spin signs, reaches, silhouettes and beam offsets; `beacons` (4, beacons) x, y,
    facing and gain; `p` the scalars (`period_params`). Returns the number of pulses; whether a
    robot's row of draws now holds less than a period's need (`short`: the caller refills the
    blocks before the next period, and need not look at them otherwise); and whether the
    period was quiet for every false pulses' clock (readout.quiet: if not, the caller asks
    each clock)."""
    batch_poses(last, states, t0, t_end, p[P_DT], poses[:3], t)
    x, y, h = poses[0], poses[1], poses[2]
    none = np.empty(0)
    gain = beacons[3] if p[P_GAIN] > 0 else none
    offset = robots[4] if p[P_OFFSET] > 0 else none
    clock_hz = p[P_CLOCK_HZ]
    clock = np.array([p[P_TIMING], t[0], t[t.shape[0] - 1], clock_hz, first_tick_after(t[0], clock_hz)])
    bx, by, omega, kind = beacons[0], beacons[1], robots[0], int(p[P_KIND])
    phi, robot, beacon, rows = sense_candidates(
        x, y, h, t, x, y, omega, p[P_DT], spin[0], noise, at[0], p[P_SCALE], p[P_DECAY], powers, p[P_LAG_DECAY],
        p[P_COUPLED], lag_powers, spin[1], spin[2], spin[3], bx, by, beacons[2], gain, offset, robots[2], robots[3],
        kind, p[P_GATES:P_OPTICS],
    )  # fmt: skip
    rows, shift, source, rob, bea, times, phase, count = fire(
        robot, beacon, rows, kind, light, at[1], p[P_SIGMA], p[P_OPTICS:P_NEEDS], timing, at[2], clock, omega,
        robots[1], p[P_MERGING : P_MERGING + 3], key,
    )  # fmt: skip
    found, read = pulse_rows(rows, shift, source, rob, bea, times, phase, bx, by)
    poses[3] = phi
    counts[:] = count
    m = found.shape[1]
    ids[:, :m] = found
    told[:, :m] = read
    need, hits = p[P_NEEDS], p[P_NEEDS + 1]
    running_short = short(noise, at[0], need) or short(light, at[1], hits) or short(timing, at[2], hits)
    return m, running_short, quiet(clocks, at[3], p[P_FALSE_RATE], t0, t_end)
