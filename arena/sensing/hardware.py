"""A level's detector hardware, whatever its kind: its parameters (every noise and failure
source off when `ideal`), the bearing noise they imply, and which kind's gates and response
apply to a batch's crossings (each kind's model is a module of its own: reflector,
sensor_array, flash_detector, light). Parameters and their seed figures are listed in
docs/sensors.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.angles import TWO_PI
from arena.sensing import flash_detector, reflector
from arena.sensing.crossings import Crossings
from arena.sensing.sensor_array import array_response

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


def visible(kind: str, c: Crossings, facing: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Which crossings pass the hardware's incidence and range gates (the optics decide the rest)."""
    if kind == "reflector":
        return reflector.visible(c, facing, p)
    if kind == "sensor_array":
        return np.ones(len(c), dtype=bool)  # its incidence falloff is the optics' `acceptance`
    if kind == "flash_detector":
        return flash_detector.visible(c, facing, p)
    raise ValueError(kind)


def sensitivity(
    kind: str, c: Crossings, inc: np.ndarray, p: Mapping[str, float], gain: np.ndarray | None = None
) -> np.ndarray:
    """The detector's response at this incidence, relative to a nominal detector head-on, times
    each beacon's `gain` (none: every detector nominal): a sensor array's phototransistors fall
    off as S = 2^-(incidence / acceptance)^2 (sensor_array.array_response), a flash detector's
    collector to the threshold at its measured limit (flash_detector.sensitivity)."""
    if kind == "flash_detector" and p.get("trigger_fraction", 0.0) > 0:
        out = flash_detector.sensitivity(c, inc, p)
    else:
        out = array_response(inc, p)
    return out if gain is None else out * gain[c.beacon]
