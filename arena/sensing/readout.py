"""What a detector's electronics read, whatever its kind: the event clock (a counter, or none),
the encoder's angle latch, and when spurious pulses come (shiny surfaces, stray light,
electrical noise).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.angles import TWO_PI


def quantize_angle(phase: np.ndarray, steps: float) -> np.ndarray:
    """Relative laser angle in [0, 2 pi), truncated to `steps` per turn (0: exact)."""
    rel = np.mod(phase, TWO_PI)
    if steps:
        q = TWO_PI / steps
        rel = np.floor(rel / q + 1e-9) * q
    return rel


def counter_clock(t: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Event times truncated to whole ticks of a `clock_hz` counter (none if 0)."""
    if p.get("clock_hz", 0.0) > 0:
        t = np.floor(t * p["clock_hz"] + 1e-6) / p["clock_hz"]
    return t


def first_tick_after(t: float, clock_hz: float) -> float:
    """The earliest time after `t` that the event clock (a counter of `clock_hz`, or none if 0)
    can read: the next counter tick, or the next float."""
    if clock_hz > 0:
        return (math.floor(t * clock_hz + 1e-6) + 1) / clock_hz
    return math.nextafter(t, math.inf)


def false_times(g: np.random.Generator, rate: float, t0: float, t1: float) -> np.ndarray:
    """When spurious pulses come between `t0` and `t1`: a Poisson process in time at `rate`
    (per s), sorted; none drawn past the count when there are none."""
    count = g.poisson(rate * (t1 - t0))
    if not count:
        return np.zeros(0)
    return np.sort(g.uniform(t0, t1, size=count))
