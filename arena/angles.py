"""Angles of the world, in one place: a full turn, and wrapping to (-pi, pi] for one angle or
an array of them (inside a compiled loop: arena.compiled.wrap_angle, the same arithmetic; the
team side has its own, in robots.toolkit.angles)."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
_TURN, _PER_TURN = np.array(TWO_PI), np.array(1.0 / TWO_PI)  # 0-d: NumPy takes them faster than floats


def wrap(angle: float) -> float:
    """One angle wrapped to [-pi, pi]."""
    return math.remainder(angle, TWO_PI)


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi] (rounding is much cheaper than a float modulo; `rint` is
    what `np.round` calls for whole numbers, without its Python wrapper)."""
    return a - _TURN * np.rint(a * _PER_TURN)
