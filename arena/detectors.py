"""Detector hardware models: which geometric crossings become events, and how wrong they are.

Each model takes the crossings of one batch (already cleared of occlusion) and decides, with
the seed's limits and the optics of a finite beam on a finite detector, which are detected
and when they fire; then the shared error sources act on the survivors: angle quantization,
timing noise, clock quantization and Bac's merged measurements. Parameters and their seed figures
are listed in docs/sensors.md; `ideal` turns every noise and failure source off.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from arena import kernels
from arena.angles import TWO_PI
from arena.laser import Crossings

_erf = np.vectorize(math.erf, otypes=[float])  # the error function, elementwise

# Parameters that are noise or failure sources, and their values in ideal mode.
IDEAL_OVERRIDES: dict[str, float] = {
    "timing_noise": 0.0,
    "wobble": 0.0,
    "false_rate": 0.0,
    "merge_rate": 0.0,
    "brightness_noise": 0.0,
    "servo_jitter": 0.0,
    "quantization": 0,
    "counts_per_turn": 0,
    "range": math.inf,
    "max_incidence": math.pi / 2,
    "clock_hz": 0.0,
    "near_incidence": math.pi / 2,
    "far_incidence": math.pi / 2,
    "beam_diameter": 0.0,
    "beam_divergence": 0.0,
    "aperture": 0.0,
    "trigger_fraction": 0.0,
    "rise_time": 0.0,
    "acceptance": math.inf,
    "light_noise": 0.0,
    "spin_coupling": 0.0,
    "spin_time": 0.0,
    "placement_error": 0.0,
}


class Detection(NamedTuple):
    """One event for one robot's controller. `source` is the robot whose laser caused it
    (for replays only, never shown to a team). An immutable named tuple: a match makes
    hundreds per simulated second, and a tuple is several times cheaper to build than a
    frozen dataclass."""

    robot: int
    time: float
    kind: str  # hit | index | scan
    beacon: str | None = None
    angle: float | None = None
    samples: tuple[int, ...] = ()
    source: int = -1
    beam: tuple[float, float, float, float] | None = None  # laser (x, y) -> target (x, y), for replays


def effective_params(params: Mapping[str, float], ideal: bool) -> dict[str, float]:
    """The level's detector parameters, with every noise and failure source off if `ideal`."""
    out = dict(params)
    if ideal:
        out.update({k: v for k, v in IDEAL_OVERRIDES.items() if k in out})
    return out


def angle_noise(kind: str, p: Mapping[str, float], omega: float) -> float:
    """The std (rad) of one bearing measured by this hardware, from its parameters: timing
    jitter and the counter clock times the beam's rate, and angle quantization (a uniform
    step of q has std q / sqrt 12). Light turrets sample every 2 pi / N."""
    var = (abs(omega) * p.get("timing_noise", 0.0)) ** 2
    steps = [p.get("quantization", 0)]
    if kind == "flash_detector":
        steps.append(p.get("counts_per_turn", 0))
    if kind == "light":
        steps.append(p.get("samples_per_turn", 0))
    for n in steps:
        if n:
            var += (TWO_PI / n) ** 2 / 12
    if p.get("clock_hz", 0.0):
        var += (abs(omega) / p["clock_hz"]) ** 2 / 12
    return math.sqrt(var)


def incidence(c: Crossings, facing: np.ndarray) -> np.ndarray:
    """Angle between each beacon's facing direction and the direction back to the laser (rad)."""
    return kernels.incidence(c.bearing, facing, c.beacon)


def visible(kind: str, c: Crossings, facing: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Which crossings pass the hardware's incidence and range gates (the optics decide the rest)."""
    if kind == "reflector":
        return (c.distance <= p["range"]) & (incidence(c, facing) <= p["max_incidence"])
    if kind == "sensor_array":
        return np.ones(len(c), dtype=bool)  # its incidence falloff is the optics' `acceptance`
    if kind == "flash_detector":
        if p.get("light_noise", 0.0) > 0:  # a soft limit: the optics decide, sweep by sweep
            return np.ones(len(c), dtype=bool)
        return incidence(c, facing) <= flash_limit(c.distance, p)
    raise ValueError(kind)


def flash_limit(distance: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Simi's detectors: the largest detectable incidence, measured at two ranges ("44 deg at
    1 foot away and 27 deg at 7 feet away"), linear between and held beyond them: nothing
    outside the measured ranges is extrapolated."""
    d = np.clip(distance, p["near_range"], p["far_range"])
    slope = (p["far_incidence"] - p["near_incidence"]) / (p["far_range"] - p["near_range"])
    return p["near_incidence"] + slope * (d - p["near_range"])


def sensitivity(
    kind: str, c: Crossings, inc: np.ndarray, p: Mapping[str, float], gain: np.ndarray | None = None
) -> np.ndarray:
    """The detector's response at this incidence, relative to a nominal detector head-on, times
    each beacon's `gain` (none: every detector nominal).

    A sensor array's phototransistors fall off as S = 2^-(incidence / acceptance)^2. Simi's
    collector loses light with incidence ("a reduction in the laser beam intensity due to
    poor reflectivity on the plexiglass and an increase in the number of ricochets"); its
    response falls the same way, scaled so that it just reaches the trigger threshold at the
    measured limit (flash_limit): S = S_limit^((incidence / limit)^2)."""
    if kind == "flash_detector" and p.get("trigger_fraction", 0.0) > 0:
        limit = flash_limit(c.distance, p)
        w = spot_width(c.distance, p)
        a = p.get("aperture", 0.0) * np.cos(limit)
        with np.errstate(divide="ignore", invalid="ignore"):
            s_limit = np.minimum(1.0, p["trigger_fraction"] / np.where(w > a, a / w, 1.0))
            out = np.where(limit > 0, s_limit ** ((inc / limit) ** 2), 0.0)
    else:
        out = array_response(inc, p)
    return out if gain is None else out * gain[c.beacon]


def array_response(inc: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """A nominal sensor array's response at this incidence, relative to head-on:
    2^-(incidence / acceptance)^2 (1 without an acceptance)."""
    acc = p.get("acceptance", math.inf)
    return np.exp2(-((inc / acc) ** 2)) if math.isfinite(acc) else np.ones(np.shape(inc))


def array_fire_chance(
    distance: np.ndarray, speed: np.ndarray, inc: np.ndarray, gain: float, p: Mapping[str, float]
) -> np.ndarray:
    """The chance that one sweep of a sensor array of this `gain` fires, at this range, beam
    speed across it (|beam rate| x range) and incidence: what `optics` asks of the response S x f
    (f the sweep's light factor, log-normal with std `light_noise` of its log), in closed form.

    The light must reach the threshold at all, S f min(1, a / w) >= eta, and stay above it for
    `rise_time`, (w + a - 2 eta w / (S f)) / v >= rise: so f >= need / S with need = eta w /
    min(w, a) or 2 eta w / (w + a - v rise), the larger (never, if v rise >= w + a), and the
    chance is Phi(ln(S / need) / light_noise); with no light noise, 1 or 0."""
    w = spot_width(distance, p)
    a = p.get("aperture", 0.0) * np.cos(inc)
    eta, sigma = p.get("trigger_fraction", 0.0), p.get("light_noise", 0.0)
    s = gain * array_response(inc, p)
    room = w + a - speed * p.get("rise_time", 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(room > 0, np.maximum(eta * w / np.minimum(w, a), 2 * eta * w / room), np.inf)
        margin = np.log(s / need)
    if not sigma > 0:
        return (margin >= 0).astype(float)
    return 0.5 * (1.0 + _erf(margin / (sigma * math.sqrt(2.0))))


def spot_width(distance: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """The beam's width at this range: exit diameter plus full divergence x range."""
    return p.get("beam_diameter", 0.0) + p.get("beam_divergence", 0.0) * distance


def optics(c: Crossings, inc: np.ndarray, sens: np.ndarray, p: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """A beam of finite width sweeping a detector of finite width: (detected, time offset).

    The spot is a top-hat of width w (spot_width); the detector presents aperture x
    cos(incidence) across it and answers with relative sensitivity `sens`. As the spot
    sweeps at v = |beam rate| x range, the light on the detector (a fraction of the beam)
    rises with the overlap; the comparator fires when it reaches `trigger_fraction`, at an
    overlap x = trigger_fraction w / sens. The pulse needs that much light at all, and for
    at least `rise_time` (Simi's sizing rule); it fires x - (w + a) / 2 of travel before the
    spot is centred on the detector: the time offset returned (negative: early). Zero widths
    give the exact crossing."""
    hardware = (
        float(p.get("beam_diameter", 0.0)),
        float(p.get("beam_divergence", 0.0)),
        float(p.get("aperture", 0.0)),
        float(p.get("trigger_fraction", 0.0)),
        float(p.get("rise_time", 0.0)),
    )
    return kernels.optics(c.distance, c.beam_rate, np.cos(inc), sens, hardware)


def quantize_angle(phase: np.ndarray, steps: float) -> np.ndarray:
    """Relative laser angle in [0, 2 pi), truncated to `steps` per turn (0: exact)."""
    rel = np.mod(phase, TWO_PI)
    if steps:
        q = TWO_PI / steps
        rel = np.floor(rel / q + 1e-9) * q
    return rel


def step_time(t: np.ndarray, phase: np.ndarray, omega: np.ndarray, steps: float, start: float) -> np.ndarray:
    """When a stepped head (`steps` per turn) reached the step it read each return at: it sees a
    return while it stands at a step, so the time says no more of the angle than the step does.
    `phase` is the laser's phase at `t` and `omega` its rate; no earlier than `start`, the
    period's (a head turning clockwise reaches a step at its far edge)."""
    q = TWO_PI / steps
    rel = np.mod(phase, TWO_PI)
    into = rel - np.floor(rel / q + 1e-9) * q
    back = np.where(omega > 0, into, q - into)
    return np.maximum(t - back / np.abs(omega), start)


def jitter(t: np.ndarray, noise: np.ndarray, window: tuple[float, float]) -> np.ndarray:
    """Event times `t` (never -0) moved by the detector's timing noise, kept inside the batch
    `window` (no event is reported before the previous tick or after the one that delivers
    it): np.clip's arithmetic, as minimum(maximum()), which NumPy dispatches faster."""
    return np.minimum(np.maximum(t + noise, window[0]), window[1])


def counter_clock(t: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Event times truncated to whole ticks of a `clock_hz` counter (none if 0)."""
    if p.get("clock_hz", 0.0) > 0:
        t = np.floor(t * p["clock_hz"] + 1e-6) / p["clock_hz"]
    return t


def first_tick_after(t: float, p: Mapping[str, float]) -> float:
    """The earliest time after `t` that the event clock can read (the next counter tick, or
    the next float if there is no counter)."""
    if p.get("clock_hz", 0.0) > 0:
        return (math.floor(t * p["clock_hz"] + 1e-6) + 1) / p["clock_hz"]
    return math.nextafter(t, math.inf)


def brightness(delta: np.ndarray, distance: np.ndarray, visible_: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Osentoski's turret photoresistor on the 0 (bright) .. 255 (dark) scale, before noise.

    Each visible light adds a Gaussian beam profile (FWHM `beam_width`) around its bearing,
    saturating within `saturation_range`; lights add up, and the sum saturates at full brightness.
    `delta` and `distance` are (samples, lights)."""
    sigma = p["beam_width"] / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    near = np.minimum(1.0, (p["saturation_range"] / distance) ** 2)
    light = np.where(visible_, near * np.exp(-0.5 * (delta / sigma) ** 2), 0.0)
    return 255.0 * (1.0 - np.minimum(1.0, light.sum(axis=1)))
