"""`laserarena map LEVEL`: where on the field a beacon layout lets a robot localize well.

At every point of a grid: which beacons a standing robot's laser would detect (the level's own
detector model: range, incidence, tangential speed; and obstacles in the way), and, from those,
the Cramer-Rao bound on the position error for bearings with the hardware's angle noise and an
unknown heading: sigma^2 (J^T J)^-1, J's rows (dy/d^2, -dx/d^2, -1). Drawn as a heat map in mm
with contours, the beacons, the circles through three beacons (where the fix degenerates), the
places with fewer than three beacons in sight, and a colour bar. `--compare` draws a second
layout beside it on the same colour scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pygame

from arena.draw import BACKGROUND, BEACON
from arena.sensing import hardware as det
from arena.sensing.crossings import Crossings
from arena.world import CAT_OBSTACLE, World
from levels.model import Level

NO_FIX = (90, 90, 96)
STOPS = [
    (0.0, (48, 18, 59)),
    (0.25, (50, 136, 189)),
    (0.5, (102, 194, 165)),
    (0.75, (254, 224, 139)),
    (1.0, (213, 62, 79)),
]  # a perceptual-ish ramp from dark blue (good) to red (poor)


@dataclass(frozen=True)
class AccuracyMap:
    """The grid (cell centres), the bound in metres (NaN: no fix), the beacons seen, the noise."""

    level: Level
    xs: np.ndarray
    ys: np.ndarray
    error: np.ndarray  # (ny, nx), m
    seen: np.ndarray  # (ny, nx) beacons detected
    sigma: float
    ambiguous: np.ndarray | None = None  # (ny, nx) unlabelled returns the sector rule cannot assign


def visible_beacons(level: Level, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(points, beacons): would a standing robot's laser at (x, y) detect each beacon?"""
    items = level.beacons.items
    bx, by = np.array([b.x for b in items]), np.array([b.y for b in items])
    facing = np.array([b.facing for b in items])
    n, m = len(x), len(items)
    px, py = np.repeat(x, m), np.repeat(y, m)
    beacon = np.tile(np.arange(m), n)
    dx, dy = bx[beacon] - px, by[beacon] - py
    omega = level.robots[0].laser.angular_velocity
    zeros = np.zeros(n * m)
    c = Crossings(
        robot=zeros.astype(int),
        beacon=beacon,
        step=zeros.astype(int),
        s=zeros,
        t=zeros,
        x=px,
        y=py,
        phi=zeros,
        beam_rate=np.full(n * m, omega),
        distance=np.hypot(dx, dy),
        bearing=np.arctan2(dy, dx),
    )
    kind = level.beacons.kind
    ok = det.visible(kind, c, facing, level.beacons.params) if kind != "light" else np.ones(n * m, bool)
    ok &= c.distance > level.beacons.radius
    if level.obstacles:
        space = World(level).space
        flt = __import__("pymunk").ShapeFilter(mask=CAT_OBSTACLE)
        for i in np.nonzero(ok)[0]:
            shrink = 1 - level.beacons.radius / c.distance[i]
            end = (px[i] + dx[i] * shrink, py[i] + dy[i] * shrink)
            ok[i] = space.segment_query_first((px[i], py[i]), end, 0.0, flt) is None
    return ok.reshape(n, m)


def crlb(beacons: np.ndarray, x: np.ndarray, y: np.ndarray, mask: np.ndarray, sigma: float) -> np.ndarray:
    """Position error bound sqrt(trace of the position block of sigma^2 (J^T J)^-1), per point;
    NaN with fewer than three beacons or a singular geometry."""
    dx = beacons[None, :, 0] - x[:, None]
    dy = beacons[None, :, 1] - y[:, None]
    d2 = np.maximum(dx * dx + dy * dy, 1e-12)
    w = mask.astype(float)
    a, b = dy / d2 * w, -dx / d2 * w
    cc = -w
    # J^T J for rows (a, b, c), summed over visible beacons
    m = np.empty((len(x), 3, 3))
    for i, u in enumerate((a, b, cc)):
        for j, v in enumerate((a, b, cc)):
            m[:, i, j] = (u * v).sum(axis=1)
    out = np.full(len(x), np.nan)
    good = mask.sum(axis=1) >= 3
    det_ = np.linalg.det(m[good])
    ok_idx = np.nonzero(good)[0][np.abs(det_) > 1e-12 * np.abs(m[good]).max(axis=(1, 2)) ** 3]
    if len(ok_idx):
        inv = np.linalg.inv(m[ok_idx])
        out[ok_idx] = sigma * np.sqrt(np.maximum(inv[:, 0, 0] + inv[:, 1, 1], 0.0))
    return out


def compute(level: Level, cells: int = 120, sigma: float | None = None) -> AccuracyMap:
    """The map on a grid of about `cells` cells along the longer side."""
    f = level.field
    step = max(f.size) / cells
    xs = f.xmin + step * (np.arange(int(round(f.size[0] / step))) + 0.5)
    ys = f.ymin + step * (np.arange(int(round(f.size[1] / step))) + 0.5)
    gx, gy = np.meshgrid(xs, ys)
    x, y = gx.ravel(), gy.ravel()
    mask = visible_beacons(level, x, y)
    omega = level.robots[0].laser.angular_velocity
    if sigma is None:
        sigma = det.angle_noise(level.beacons.kind, level.beacons.params, omega) or 1e-4
    beacons = np.array([(b.x, b.y) for b in level.beacons.items])
    err = crlb(beacons, x, y, mask, sigma)
    ambiguous = None
    if level.beacons.kind == "reflector":  # unlabelled: Vannoy's sector rule must tell them apart
        from robots.toolkit.associate import by_sectors

        named = {b.id: (b.x, b.y) for b in level.beacons.items}
        ref = level.field.center
        ambiguous = np.array(
            [
                by_sectors(
                    sorted(math.atan2(by - py, bx - px) % (2 * math.pi) for bx, by in named.values()), named, ref
                ).ambiguous
                for px, py in zip(x, y)
            ]
        ).reshape(gy.shape)
    return AccuracyMap(level, xs, ys, err.reshape(gy.shape), mask.sum(axis=1).reshape(gy.shape), sigma, ambiguous)


def _colour(v: float) -> tuple[int, int, int]:
    for (t0, c0), (t1, c1) in zip(STOPS, STOPS[1:]):
        if v <= t1:
            k = (v - t0) / (t1 - t0)
            red, green, blue = (round(a + (b - a) * k) for a, b in zip(c0, c1))
            return red, green, blue
    return STOPS[-1][1]


def scale_for(maps: list[AccuracyMap]) -> tuple[float, float]:
    """A common log colour scale (mm): from the best cell to the 95th percentile."""
    vals = np.concatenate([m.error[np.isfinite(m.error)].ravel() * 1000 for m in maps])
    if not len(vals):
        return 0.1, 1.0
    return float(max(vals.min(), 1e-3)), float(max(np.percentile(vals, 95), vals.min() * 1.01))


def draw(maps: list[AccuracyMap], out: Path, panel: int = 560) -> None:
    """Draw the maps side by side with one colour bar; write a PNG."""
    lo, hi = scale_for(maps)
    pygame.font.init()
    font, small = pygame.font.Font(None, 24), pygame.font.Font(None, 18)
    width = panel * len(maps) + 110
    surface = pygame.Surface((width, panel + 90))
    surface.fill(BACKGROUND)
    for k, m in enumerate(maps):
        _panel(surface, m, (k * panel + 10, 50), panel - 20, lo, hi, small)
        surface.blit(
            font.render(f"{m.level.name}: CRLB, sigma {1000 * m.sigma:.2f} mrad", True, (235, 235, 235)),
            (k * panel + 10, 14),
        )
    _colour_bar(surface, (len(maps) * panel + 10, 50), panel - 40, lo, hi, small)
    pygame.image.save(surface, str(out))


def _panel(surface, m: AccuracyMap, origin, size, lo, hi, font) -> None:
    f = m.level.field
    s = size / max(f.size)
    ox, oy = origin
    to = lambda x, y: (ox + (x - f.xmin) * s, oy + (f.ymax - y) * s)  # noqa: E731
    cell = max(1, math.ceil((m.xs[1] - m.xs[0]) * s)) if len(m.xs) > 1 else 2
    log_lo, log_hi = math.log(lo), math.log(hi)
    for j, y in enumerate(m.ys):
        for i, x in enumerate(m.xs):
            e = m.error[j, i]
            if np.isfinite(e):
                v = (math.log(max(e * 1000, 1e-9)) - log_lo) / (log_hi - log_lo)
                c = _colour(min(max(v, 0.0), 1.0))
            else:
                c = NO_FIX
            px, py = to(x, y)
            surface.fill(c, (px - cell / 2, py - cell / 2, cell + 1, cell + 1))
    _contours(surface, m, to, lo, hi)
    if m.ambiguous is not None:  # hatched: the sector rule cannot decide here
        for j, y in enumerate(m.ys):
            for i, x in enumerate(m.xs):
                if m.ambiguous[j, i] and (i + j) % 3 == 0:
                    surface.fill((255, 255, 255), (*to(x, y), 2, 2))
    x0, y0 = to(f.xmin, f.ymax)
    surface.set_clip((x0, y0, f.size[0] * s + 1, f.size[1] * s + 1))
    items = [(b.x, b.y) for b in m.level.beacons.items]
    for triple in _triples(items):  # circles through three beacons: the fix degenerates on them
        centre, radius = _circumcircle(*triple)
        if centre is not None and radius < 10 * max(f.size):
            pygame.draw.circle(surface, (255, 255, 255), to(*centre), radius * s, 1)
    surface.set_clip(None)
    pygame.draw.rect(surface, (30, 30, 30), (x0, y0, f.size[0] * s, f.size[1] * s), 2)
    for b in m.level.beacons.items:
        pygame.draw.circle(surface, BEACON[m.level.beacons.kind], to(b.x, b.y), 6)
        pygame.draw.circle(surface, (255, 255, 255), to(b.x, b.y), 6, 1)
        surface.blit(font.render(b.id, True, (255, 255, 255)), (to(b.x, b.y)[0] + 7, to(b.x, b.y)[1] - 14))


def _contours(surface, m: AccuracyMap, to, lo, hi) -> None:
    """Iso-lines at 1-2-5 steps (mm): a segment across every cell edge pair the level crosses."""
    levels = [v * 10**k for k in range(-3, 5) for v in (1, 2, 5) if lo <= v * 10**k <= hi]
    e = m.error * 1000
    for level in levels:
        above = np.where(np.isfinite(e), e > level, False)
        for j in range(len(m.ys) - 1):
            for i in range(len(m.xs) - 1):
                corners = (above[j, i], above[j, i + 1], above[j + 1, i + 1], above[j + 1, i])
                if all(corners) or not any(corners):
                    continue
                pts = []
                coords = (
                    (m.xs[i], m.ys[j]),
                    (m.xs[i + 1], m.ys[j]),
                    (m.xs[i + 1], m.ys[j + 1]),
                    (m.xs[i], m.ys[j + 1]),
                )
                vals = (e[j, i], e[j, i + 1], e[j + 1, i + 1], e[j + 1, i])
                for a in range(4):
                    b = (a + 1) % 4
                    if corners[a] != corners[b] and np.isfinite(vals[a]) and np.isfinite(vals[b]):
                        t = (level - vals[a]) / (vals[b] - vals[a])
                        pts.append(
                            to(
                                coords[a][0] + t * (coords[b][0] - coords[a][0]),
                                coords[a][1] + t * (coords[b][1] - coords[a][1]),
                            )
                        )
                if len(pts) >= 2:
                    pygame.draw.line(surface, (20, 20, 20), pts[0], pts[1], 1)


def _colour_bar(surface, origin, height, lo, hi, font) -> None:
    ox, oy = origin
    for k in range(height):
        pygame.draw.line(surface, _colour(1 - k / height), (ox, oy + k), (ox + 18, oy + k))
    for v in [v * 10**k for k in range(-3, 5) for v in (1, 2, 5)]:
        if lo <= v <= hi:
            up = (math.log(v) - math.log(lo)) / (math.log(hi) - math.log(lo))
            y = oy + (1 - up) * height
            pygame.draw.line(surface, (235, 235, 235), (ox + 18, y), (ox + 24, y))
            surface.blit(font.render(f"{v:g} mm", True, (235, 235, 235)), (ox + 27, y - 6))
    surface.fill(NO_FIX, (ox, oy + height + 12, 18, 12))
    surface.blit(font.render("< 3 beacons", True, (235, 235, 235)), (ox + 24, oy + height + 12))
    surface.fill((255, 255, 255), (ox + 8, oy + height + 32, 2, 2))
    surface.blit(font.render("ambiguous", True, (235, 235, 235)), (ox + 24, oy + height + 28))


def _triples(points):
    n = len(points)
    return [(points[i], points[j], points[k]) for i in range(n) for j in range(i + 1, n) for k in range(j + 1, n)]


def _circumcircle(a, b, c):
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-12:
        return None, math.inf
    ux = (
        (a[0] ** 2 + a[1] ** 2) * (b[1] - c[1])
        + (b[0] ** 2 + b[1] ** 2) * (c[1] - a[1])
        + (c[0] ** 2 + c[1] ** 2) * (a[1] - b[1])
    ) / d
    uy = (
        (a[0] ** 2 + a[1] ** 2) * (c[0] - b[0])
        + (b[0] ** 2 + b[1] ** 2) * (a[0] - c[0])
        + (c[0] ** 2 + c[1] ** 2) * (b[0] - a[0])
    ) / d
    return (ux, uy), math.dist((ux, uy), a)
