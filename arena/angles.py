"""Angles of the world, in one place: a full turn, a heading wrapped to (-pi, pi] (`wrap`) and
an array of angle differences wrapped to [-pi, pi] (`wrap_angle`, whose sign alone is read;
inside a compiled loop: arena.compiled.wrap_angle, the same arithmetic). The team side has its
own, in robots.toolkit.angles."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
_TURN, _PER_TURN = np.array(TWO_PI), np.array(1.0 / TWO_PI)  # 0-d: NumPy takes them faster than floats


def wrap(angle: float) -> float:
    """One angle wrapped to (-pi, pi]: a heading of -pi is reported as pi, so that two equal
    headings always read alike (`math.remainder` alone gives -pi for 3 pi or -pi)."""
    r = math.remainder(angle, TWO_PI)
    return math.pi if r == -math.pi else r


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angle differences wrapped to [-pi, pi], both ends possible (rounding is much cheaper than a float modulo; `rint` is
    what `np.round` calls for whole numbers, without its Python wrapper)."""
    return a - _TURN * np.rint(a * _PER_TURN)
