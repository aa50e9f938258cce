"""Detector hardware models: which geometric crossings become events, and how wrong they are.

Each model takes the crossings of one batch (already cleared of occlusion) and decides, with
the seed's limits, which are detected; then the shared error sources act on the survivors:
angle quantization, timing noise and clock quantization. Parameters and their seed figures
are listed in docs/sensors.md; `ideal` turns every noise and failure source off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from arena.laser import TWO_PI, Crossings, wrap_angle

# Parameters that are noise or failure sources, and their values in ideal mode.
IDEAL_OVERRIDES: dict[str, float] = {
    "timing_noise": 0.0, "wobble": 0.0, "false_rate": 0.0, "merge_rate": 0.0,
    "brightness_noise": 0.0, "servo_jitter": 0.0, "quantization": 0, "counts_per_turn": 0,
    "range": math.inf, "max_incidence": math.pi / 2, "max_tangential_speed": math.inf,
    "clock_hz": 0.0, "near_incidence": math.pi / 2, "far_incidence": math.pi / 2,
}


@dataclass(frozen=True)
class Detection:
    """One event for one robot's controller. `source` is the robot whose laser caused it
    (for replays only, never shown to a team)."""

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
    back = c.bearing + np.pi - facing[c.beacon]
    return np.abs(wrap_angle(back))


def visible(kind: str, c: Crossings, facing: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Which crossings the hardware of `kind` detects (before random errors)."""
    inc = incidence(c, facing)
    if kind == "reflector":
        return (c.distance <= p["range"]) & (inc <= p["max_incidence"])
    if kind == "sensor_array":
        # the spot sweeps the array face at |beam rate| * range / cos(incidence); the array
        # answers up to max_tangential_speed (270 m/s at normal incidence in the seed)
        speed = np.abs(c.beam_rate) * c.distance
        return (inc <= p["max_incidence"]) & (speed <= p["max_tangential_speed"] * np.cos(inc))
    if kind == "flash_detector":
        return inc <= flash_limit(c.distance, p)
    raise ValueError(kind)


def flash_limit(distance: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Simi's detectors: the largest detectable incidence falls linearly with range through
    (near_range, near_incidence) and (far_range, far_incidence), never below zero."""
    slope = (p["far_incidence"] - p["near_incidence"]) / (p["far_range"] - p["near_range"])
    return np.maximum(0.0, p["near_incidence"] + slope * (distance - p["near_range"]))


def quantize_angle(phase: np.ndarray, steps: float) -> np.ndarray:
    """Relative laser angle in [0, 2 pi), truncated to `steps` per turn (0: exact)."""
    rel = np.mod(phase, TWO_PI)
    if steps:
        q = TWO_PI / steps
        rel = np.floor(rel / q + 1e-9) * q
    return rel


def jitter(t: np.ndarray, p: Mapping[str, float], rng: np.random.Generator,
           window: tuple[float, float]) -> np.ndarray:
    """Gaussian timing noise of the detector, kept inside the batch `window` (no event is
    reported before the previous tick or after the one that delivers it)."""
    if p.get("timing_noise", 0.0) > 0:
        t = np.clip(t + rng.normal(0.0, p["timing_noise"], size=t.shape), *window)
    return t


def counter_clock(t: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Event times truncated to whole ticks of a `clock_hz` counter (none if 0)."""
    if p.get("clock_hz", 0.0) > 0:
        t = np.floor(t * p["clock_hz"] + 1e-6) / p["clock_hz"]
    return t


def merge_into_next(times: np.ndarray, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Bac's hardware error: with probability `rate` a pulse is merged into the next one of the
    same laser, so it is reported at the next pulse's time. The last pulse of a batch is never
    merged (its successor is not known yet)."""
    if rate <= 0 or len(times) < 2:
        return times
    merged = rng.random(len(times)) < rate
    merged[-1] = False
    out = times.copy()
    for i in np.nonzero(merged)[0][::-1]:  # from the back, so chains of merges land on the last
        out[i] = out[i + 1]
    return out


def brightness(delta: np.ndarray, distance: np.ndarray, visible_: np.ndarray,
               p: Mapping[str, float]) -> np.ndarray:
    """Osentoski's turret photoresistor on the 0 (bright) .. 255 (dark) scale, before noise.

    Each visible light adds a Gaussian beam profile (FWHM `beam_width`) around its bearing,
    saturating within `saturation_range`; lights add up, and the sum saturates at full brightness.
    `delta` and `distance` are (samples, lights)."""
    sigma = p["beam_width"] / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    near = np.minimum(1.0, (p["saturation_range"] / distance) ** 2)
    light = np.where(visible_, near * np.exp(-0.5 * (delta / sigma) ** 2), 0.0)
    return 255.0 * (1.0 - np.minimum(1.0, light.sum(axis=1)))
