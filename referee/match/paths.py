"""The ideal path of a waypoint task as a polyline, and where a robot's positions stand to it:
the next point within a target's radius, and the distance to the path (cross-track error).
The loops are compiled (arena.compiled) with NumPy's bits: the distances are scores.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from arena.compiled import compiled


class Polyline:
    """A path as arrays of segments, for fast distances to it."""

    def __init__(self, points: list[tuple[float, float]]):
        p = np.asarray(points, dtype=float)
        self.a = np.ascontiguousarray(p[:-1])
        self.d = np.ascontiguousarray(p[1:] - p[:-1])
        self.n2 = np.maximum((self.d**2).sum(axis=1), 1e-300)

    def distances(self, x: Sequence[float] | np.ndarray, y: Sequence[float] | np.ndarray) -> list[float]:
        """Distances (m) from each point (x[i], y[i]) to the polyline, at once. The points are
        copied contiguous: a single point of a strided column is contiguous to numba, a longer
        run is not, and one layout is one compiled loop (referee.match.warm readies it)."""
        x, y = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float)
        return _distances(self.a, self.d, self.n2, x, y).tolist()


@compiled()
def _distances(a: np.ndarray, d: np.ndarray, n2: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Per point, the least distance to a segment a[j] + t d[j] (t in [0, 1]); as NumPy wrote
    it: t = clip(((x - ax) dx + (y - ay) dy) / |d|^2, 0, 1), then the length of the rest."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        best = 0.0
        for j in range(a.shape[0]):
            rx, ry = x[i] - a[j, 0], y[i] - a[j, 1]
            v = (rx * d[j, 0] + ry * d[j, 1]) / n2[j]
            if v != v:
                t = v
            else:
                t = 1.0 if v > 1.0 else (0.0 if v < 0.0 else v)
            ex, ey = rx - t * d[j, 0], ry - t * d[j, 1]
            dist = np.sqrt(ex * ex + ey * ey)
            if j == 0 or dist != dist or (best == best and dist < best):
                best = dist
        out[i] = best
    return out


@compiled()
def first_near(x: np.ndarray, y: np.ndarray, start: int, tx: float, ty: float, near: float) -> int:
    """The first index k >= start with hypot(x[k] - tx, y[k] - ty) <= near, or -1."""
    for k in range(start, x.shape[0]):
        if np.hypot(x[k] - tx, y[k] - ty) <= near:
            return k
    return -1
