"""The ideal path of a waypoint task as a polyline (every robot's at once: `Paths`), and where
a robot's positions stand to it: the next point within a target's radius, and the distance to
the path (cross-track error). The loops are compiled (arena.compiled) with NumPy's bits: the
distances are scores.
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


class Paths:
    """Every robot's ideal path (a `Polyline`, or None where it has none) packed into one set
    of segment arrays, so that the distances of all robots' positions in a period's states are
    one compiled call, not a call and two copies per robot."""

    def __init__(self, lines: Sequence[Polyline | None]):
        present = [line for line in lines if line is not None]
        self.offsets = np.cumsum([0] + [0 if line is None else len(line.a) for line in lines], dtype=np.int64)
        self.a = np.ascontiguousarray(np.concatenate([line.a for line in present]) if present else np.empty((0, 2)))
        self.d = np.ascontiguousarray(np.concatenate([line.d for line in present]) if present else np.empty((0, 2)))
        self.n2 = np.concatenate([line.n2 for line in present]) if present else np.empty(0)

    def distances(self, states: np.ndarray, start: int, every: int, runs: list[tuple[int, int]]) -> list[list[float]]:
        """For each run (slot, end), `Polyline.distances` of robot `slot`'s positions in
        `states[start:end:every]` (world states: x and y in columns 3 slot and 3 slot + 1; `end`
        at most their number)."""
        slots, ends = np.array([s for s, _ in runs], np.int64), np.array([e for _, e in runs], np.int64)
        out = _run_distances(
            self.a, self.d, self.n2, self.offsets, np.ascontiguousarray(states), start, every, slots, ends
        )
        values, at = out.tolist(), 0
        runs_out = []
        for _, end in runs:
            count = len(range(start, end, every))
            runs_out.append(values[at : at + count])
            at += count
        return runs_out


@compiled(inline="always")
def _distance(a: np.ndarray, d: np.ndarray, n2: np.ndarray, first: int, last: int, x: float, y: float) -> float:
    """The least distance from (x, y) to a segment a[j] + t d[j] (t in [0, 1]), j from `first`
    to before `last`; as NumPy wrote it: t = clip(((x - ax) dx + (y - ay) dy) / |d|^2, 0, 1),
    then the length of the rest."""
    best = 0.0
    for j in range(first, last):
        rx, ry = x - a[j, 0], y - a[j, 1]
        v = (rx * d[j, 0] + ry * d[j, 1]) / n2[j]
        if v != v:
            t = v
        else:
            t = 1.0 if v > 1.0 else (0.0 if v < 0.0 else v)
        ex, ey = rx - t * d[j, 0], ry - t * d[j, 1]
        dist = np.sqrt(ex * ex + ey * ey)
        if j == first or dist != dist or (best == best and dist < best):
            best = dist
    return best


@compiled()
def _distances(a: np.ndarray, d: np.ndarray, n2: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Per point, its `_distance` to every segment."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _distance(a, d, n2, 0, a.shape[0], x[i], y[i])
    return out


@compiled()
def _run_distances(
    a: np.ndarray,
    d: np.ndarray,
    n2: np.ndarray,
    offsets: np.ndarray,
    states: np.ndarray,
    start: int,
    every: int,
    slots: np.ndarray,
    ends: np.ndarray,
) -> np.ndarray:
    """`Paths.distances`, one run after the other in one array: robot slots[k]'s positions in
    states[start:ends[k]:every] to its segments (offsets[slot] to offsets[slot + 1])."""
    total = 0
    for k in range(slots.shape[0]):
        total += len(range(start, ends[k], every))
    out = np.empty(total)
    n = 0
    for k in range(slots.shape[0]):
        s = slots[k]
        for i in range(start, ends[k], every):
            out[n] = _distance(a, d, n2, offsets[s], offsets[s + 1], states[i, 3 * s], states[i, 3 * s + 1])
            n += 1
    return out


@compiled()
def first_near(x: np.ndarray, y: np.ndarray, start: int, tx: float, ty: float, near: float) -> int:
    """The first index k >= start with hypot(x[k] - tx, y[k] - ty) <= near, or -1."""
    for k in range(start, x.shape[0]):
        if np.hypot(x[k] - tx, y[k] - ty) <= near:
            return k
    return -1
