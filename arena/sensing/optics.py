"""A beam of finite width sweeping a detector of finite width (the sensor arrays' and the flash
detectors' optics): the angle each sweep meets a detector at, and whether it fires and when
(how much of its usual light each sweep brings is arena.sensing.sweep's). Reflectors answer at
the exact crossing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.compiled import compiled, wrap_angle
from arena.sensing.crossings import Crossings


def incidence(c: Crossings, facing: np.ndarray) -> np.ndarray:
    """Angle between each beacon's facing direction and the direction back to the laser (rad)."""
    return incidences(c.bearing, facing, c.beacon)


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
    return sweep_optics(c.distance, c.beam_rate, np.cos(inc), sens, hardware)


@compiled()
def incidences(bearing: np.ndarray, facing: np.ndarray, beacon: np.ndarray) -> np.ndarray:
    """`incidence`'s loop: |wrap(bearing + pi - facing of the beacon)| per crossing."""
    n = bearing.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = abs(wrap_angle(bearing[i] + math.pi - facing[beacon[i]]))
    return out


@compiled()
def sweep_optics(
    distance: np.ndarray,
    beam_rate: np.ndarray,
    cos_incidence: np.ndarray,
    sens: np.ndarray,
    hardware: tuple[float, float, float, float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """`optics`' arithmetic: (detected, time offset) per crossing, for
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
