"""Small steering helpers shared by the reference controllers."""

from __future__ import annotations

import math


def wrap(angle: float) -> float:
    """An angle wrapped to [-pi, pi]."""
    return math.remainder(angle, 2 * math.pi)


def next_waypoint(path: list[tuple[float, float]], index: int, x: float, y: float, within: float) -> int:
    """The index of the first waypoint from `index` on that (x, y) is not yet within `within` of."""
    while index < len(path) and math.dist((x, y), path[index]) < within:
        index += 1
    return index
