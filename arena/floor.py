"""The floor: its tilt, which leans each robot so its beam leaves beside its base, and the tiles
an experimenter carried a robot by, whose grid is not the map's.

Simi names both: "the floor tiles are not perfectly 12 inches apart and they are not perfectly
perpendicular to each other", and "tilt in the floor causing the entire motor assembly to be
tilted as well. This, however, means that the base of the motor assembly is at a different
location than the top of the assembly where the laser beam actually exists." A robot's pose is
its base (what the score compares against); its beam leaves `laser.height` above it, along the
floor's normal there. Both are drawn once per match from its random tree (each from a stream
of its own), and `--ideal` has neither.
"""

from __future__ import annotations

import math

import numpy as np

from arena.compiled import compiled
from arena.rng import RandomTree
from levels.model import Floor, Pose, Tiles

WAVES = 32  # plane waves in a tilt field: enough for its slopes to be nearly Gaussian (ours)


class Tilt:
    """A floor's height as a smooth Gaussian random field, the sum of `WAVES` plane waves of
    random direction, wavelength and phase (random Fourier features of a Gaussian covariance
    of correlation length `length`), scaled so that its slope along each axis has RMS `rms`."""

    def __init__(self, rms: float, length: float, rng: np.random.Generator):
        self.k = rng.normal(0.0, 1.0 / length, size=(WAVES, 2))  # wave vectors (rad/m)
        self.phase = rng.uniform(0.0, 2 * math.pi, size=WAVES)
        # height amplitude: var(dz/dx) = amp^2 (2 / N) sum E[kx^2] E[sin^2] = (amp / length)^2
        self.amp = rms * length * math.sqrt(2.0 / WAVES)

    def lean(self, x: np.ndarray, y: np.ndarray, height: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where a point `height` (per robot) above the base at (x, y) (steps, robots) stands off
        it, horizontally: a body set square on the floor stands along the floor's normal
        (-gx, -gy, 1) / |.|, (gx, gy) its slope there, so its top leans downhill by height x
        sin(tilt) (compiled: `lean`)."""
        return lean(x, y, self.k, self.phase, self.amp, height)


@compiled()
def lean(
    x: np.ndarray, y: np.ndarray, k: np.ndarray, phase: np.ndarray, amp: float, height: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """`Tilt.lean`: how far a point `height` (per robot) above each base at (x, y)
    (steps, robots) stands off it, on a floor of height amp sum cos(k . p + phase). A kernel of
    its own, not the twin of a NumPy expression: its sines are the C library's."""
    steps, robots = x.shape
    dx, dy = np.empty((steps, robots)), np.empty((steps, robots))
    for i in range(steps):
        for j in range(robots):
            gx, gy = 0.0, 0.0
            for w in range(k.shape[0]):
                s = -amp * math.sin(k[w, 0] * x[i, j] + k[w, 1] * y[i, j] + phase[w])
                gx += s * k[w, 0]
                gy += s * k[w, 1]
            scale = height[j] / math.sqrt(1.0 + gx * gx + gy * gy)
            dx[i, j], dy[i, j] = -gx * scale, -gy * scale
    return dx, dy


def tilt(floor: Floor, tree: RandomTree, ideal: bool) -> Tilt | None:
    """The match's floor tilt (stream "floor", "tilt"); none if the level has none or if `ideal`."""
    if ideal or floor.tilt <= 0:
        return None
    return Tilt(floor.tilt, floor.tilt_length, tree.stream("floor", "tilt"))


class Grid:
    """The real tile grid of one match: the displacement one tile pitch along the map's x
    (and along y) really makes, `ex` and `ey`."""

    def __init__(self, tiles: Tiles, ex: tuple[float, float], ey: tuple[float, float]):
        self.origin = tiles.origin
        self.ex, self.ey = ex, ey

    def place(self, anchor: Pose, nominal: Pose) -> Pose:
        """Where a robot carried from `anchor` (its true pose at the origin tile) to the tile value
        `nominal` really stands: the nominal offset from the origin, laid out along the real
        grid's lines, from the anchor; the heading is the nominal one."""
        qx, qy = nominal.x - self.origin[0], nominal.y - self.origin[1]
        x = anchor.x + qx * self.ex[0] + qy * self.ey[0]
        y = anchor.y + qx * self.ex[1] + qy * self.ey[1]
        return Pose(x, y, nominal.heading)


def grid(floor: Floor, tree: RandomTree, ideal: bool) -> Grid | None:
    """The match's real tile grid (stream "floor", "tiles"), if the level has tiles: each axis's
    pitch off by a fraction uniform within +-`spacing_error`, each set of lines turned by an
    angle uniform within +-`angle_error` (four draws, always); a perfect grid if `ideal`."""
    tiles = floor.tiles
    if tiles is None:
        return None
    u = 2 * tree.stream("floor", "tiles").random(4) - 1
    if ideal:
        u[:] = 0.0
    sx, sy = 1 + tiles.spacing_error * u[0], 1 + tiles.spacing_error * u[1]
    ax, ay = tiles.angle_error * u[2], tiles.angle_error * u[3]
    return Grid(tiles, (sx * math.cos(ax), sx * math.sin(ax)), (-sy * math.sin(ay), sy * math.cos(ay)))
