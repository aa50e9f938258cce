"""Small steering helpers shared by the reference controllers."""

from __future__ import annotations

import math


def next_waypoint(path: list[tuple[float, float]], index: int, x: float, y: float, within: float) -> int:
    """The index of the first waypoint from `index` on that (x, y) is not yet within `within` of."""
    while index < len(path) and math.dist((x, y), path[index]) < within:
        index += 1
    return index
