"""Position from bearings: the seeds' solvers and the best published one, each cross-checked.

Convention: a *bearing* is the angle at which the robot sees a beacon, measured from an
unknown reference on the robot (its heading plus any laser offset), counter-clockwise.
Every solver returns a `Fix`: position, the reference direction (heading), a reliability
(larger is better; 0 when degenerate) and, when the geometry cannot decide, `ok=False`
with the reason: fewer than three beacons, collinear beacons, the robot at a beacon or on
the circle through three beacons.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from robots.toolkit import dense
from robots.toolkit.angles import wrap

COT_CLAMP = 1e8  # cot of an angle this close to 0 or pi stands for infinity (ToTal's advice)
DEGENERATE = 1e-12
MAX_STEP = 0.25  # m: Newton's largest position step


class Fix(NamedTuple):
    """A position fix: (x, y) m, heading rad, a reliability (0 when degenerate), and why not.
    (An immutable named tuple rather than a dataclass: solvers make millions of these.)"""

    x: float
    y: float
    heading: float
    reliability: float
    ok: bool = True
    reason: str = ""
    covariance: tuple[tuple[float, float], tuple[float, float]] | None = None


def failed(reason: str) -> Fix:
    return Fix(math.nan, math.nan, math.nan, 0.0, False, reason)


def _cot(a: float) -> float:
    t = math.tan(a)
    if abs(t) < 1.0 / COT_CLAMP:
        return math.copysign(COT_CLAMP, t) if t else COT_CLAMP
    return 1.0 / t


def heading_from(x: float, y: float, beacons: list[tuple[float, float]], bearings: list[float]) -> float:
    """The reference direction that best explains the bearings from (x, y): a circular mean."""
    s = c = 0.0
    for (bx, by), b in zip(beacons, bearings):
        h = math.atan2(by - y, bx - x) - b
        s += math.sin(h)
        c += math.cos(h)
    return math.atan2(s, c)


def _collinear(p1, p2, p3) -> bool:
    area = (p2[0] - p1[0]) * (p3[1] - p1[1]) - (p2[1] - p1[1]) * (p3[0] - p1[0])
    scale = max(math.dist(p1, p2), math.dist(p2, p3), math.dist(p1, p3)) ** 2
    return abs(area) <= 1e-9 * scale


# ---- ToTal ---------------------------------------------------------------------------------


def total(beacons: list[tuple[float, float]], bearings: list[float], heading: bool = True) -> Fix:
    """ToTal three-object triangulation (Pierlot & Van Droogenbroeck, IEEE T-RO 2014),
    from the paper's formulas: beacons shifted to the second one, three cotangents, the three
    circle centres, and the intersection point. |D| is the reliability: it falls to 0 on the
    circle through the beacons, where the position cannot be determined. The heading (the
    circular mean of what each beacon says) is a second step; `heading=False` skips it, as the
    paper's position-only timings do."""
    if len(beacons) != 3 or len(bearings) != 3:
        return failed("ToTal needs exactly three beacons")
    (x1, y1), (x2, y2), (x3, y3) = beacons
    a1, a2, a3 = bearings
    x1p, y1p, x3p, y3p = x1 - x2, y1 - y2, x3 - x2, y3 - y2
    cross = x1p * y3p - x3p * y1p
    if cross * cross <= 1e-18 * (x1p * x1p + y1p * y1p) * (x3p * x3p + y3p * y3p):
        return failed("collinear beacons")
    t12 = _cot(a2 - a1)
    t23 = _cot(a3 - a2)
    denom = t12 + t23
    t31 = (1.0 - t12 * t23) / denom if denom else COT_CLAMP
    x12, y12 = x1p + t12 * y1p, y1p - t12 * x1p
    x23, y23 = x3p - t23 * y3p, y3p + t23 * x3p
    x31, y31 = (x3p + x1p) + t31 * (y3p - y1p), (y3p + y1p) - t31 * (x3p - x1p)
    k31 = x1p * x3p + y1p * y3p + t31 * cross
    d = (x12 - x23) * (y23 - y31) - (y12 - y23) * (x23 - x31)
    if abs(d) < DEGENERATE:
        return failed("robot on the circle through the beacons")
    x = x2 + k31 * (y12 - y23) / d
    y = y2 + k31 * (x23 - x12) / d
    if not heading:
        return Fix(x, y, math.nan, abs(d))
    # heading: the circular mean of what each beacon says (unit vectors turned back by bearings)
    sx = sy = 0.0
    for (bx, by), b in ((beacons[0], a1), (beacons[1], a2), (beacons[2], a3)):
        dx, dy = bx - x, by - y
        n = math.hypot(dx, dy)
        if n < 1e-9:
            return failed("robot at a beacon")
        c, s_ = math.cos(b), math.sin(b)
        sx += (dx * c + dy * s_) / n
        sy += (dy * c - dx * s_) / n
    return Fix(x, y, math.atan2(sy, sx), abs(d))


CHUNK = 8192  # problems per pass: keeps the temporaries in cache


def total_batch(beacons: np.ndarray, bearings: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ToTal for N problems at once: beacons (N, 3, 2) or (3, 2), bearings (N, 3).
    Returns x, y and the reliability |D| (0 where degenerate, with x, y NaN)."""
    beacons = np.asarray(beacons, dtype=float)
    n = len(bearings)
    if n > CHUNK:
        parts = [
            _total_chunk(beacons if beacons.ndim == 2 else beacons[i : i + CHUNK], bearings[i : i + CHUNK])
            for i in range(0, n, CHUNK)
        ]
        x, y, reliability = (np.concatenate(p) for p in zip(*parts))
        return x, y, reliability
    return _total_chunk(beacons, bearings)


def _total_chunk(beacons: np.ndarray, bearings: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if beacons.ndim == 2:  # one layout for all: its offsets are plain numbers
        (x1, y1), (x2, y2), (x3, y3) = beacons.tolist()
    else:
        x1, y1, x2, y2, x3, y3 = (beacons[:, i, j] for i in range(3) for j in range(2))
    x1p, y1p, x3p, y3p = x1 - x2, y1 - y2, x3 - x2, y3 - y2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t12 = 1.0 / np.tan(bearings[:, 1] - bearings[:, 0])
        t23 = 1.0 / np.tan(bearings[:, 2] - bearings[:, 1])
        np.clip(t12, -COT_CLAMP, COT_CLAMP, out=t12)
        np.clip(t23, -COT_CLAMP, COT_CLAMP, out=t23)
        t31 = (1.0 - t12 * t23) / (t12 + t23)
        x12, y12 = x1p + t12 * y1p, y1p - t12 * x1p
        x23, y23 = x3p - t23 * y3p, y3p + t23 * x3p
        x31, y31 = (x3p + x1p) + t31 * (y3p - y1p), (y3p + y1p) - t31 * (x3p - x1p)
        k31 = (x1p * x3p + y1p * y3p) + t31 * (x1p * y3p - x3p * y1p)
        d = (x12 - x23) * (y23 - y31) - (y12 - y23) * (x23 - x31)
        k = k31 / d
        x = x2 + k * (y12 - y23)
        y = y2 + k * (x23 - x12)
        reliability = np.abs(d)
        bad = reliability < DEGENERATE
        if bad.any():
            x[bad] = y[bad] = np.nan
            reliability[bad] = 0.0
    return x, y, reliability


# ---- geometric circle intersection (Vannoy; Simi appendix A) ------------------------------


def circle_through(p: tuple[float, float], q: tuple[float, float], angle: float) -> tuple[float, float, float]:
    """Centre and radius of the circle of points that see the chord p -> q under `angle`
    (counter-clockwise from p to q): the inscribed angle rule."""
    mx, my = (p[0] + q[0]) / 2, (p[1] + q[1]) / 2
    dx, dy = q[0] - p[0], q[1] - p[1]
    half = math.hypot(dx, dy) / 2
    # the centre lies on the perpendicular bisector, at half * cot(angle) to the left of p -> q
    k = _cot(angle) / 2
    return mx - k * dy, my + k * dx, half / abs(math.sin(angle)) if math.sin(angle) else math.inf


def _seen_point(p: tuple[float, float], a1: float, a3: float) -> tuple[float, float]:
    """A point off the beacons' line unless the outer beacons are seen 0 or pi apart."""
    return (p[0] + math.cos(a3 - a1), p[1] + math.sin(a3 - a1))


def circles(beacons: list[tuple[float, float]], bearings: list[float]) -> Fix:
    """Intersect the circle through beacons 1, 2 and the robot with the one through 2, 3 and
    the robot (Vannoy's construction): the robot is beacon 2 mirrored in the line of centres.
    Collinear beacons are fine (Ubersetzig's and Osentoski's layouts) unless the robot is on
    their line."""
    if len(beacons) != 3:
        return failed("the circle method needs three beacons")
    (p1, p2, p3), (a1, a2, a3) = beacons, bearings
    if _collinear(*beacons) and _collinear(p1, p3, _seen_point(p2, a1, a3)):
        return failed("robot on the line of collinear beacons")
    c1x, c1y, _ = circle_through(p1, p2, a2 - a1)
    c2x, c2y, _ = circle_through(p2, p3, a3 - a2)
    ux, uy = c2x - c1x, c2y - c1y
    n2 = ux * ux + uy * uy
    if n2 < DEGENERATE:
        return failed("robot on the circle through the beacons")
    t = ((p2[0] - c1x) * ux + (p2[1] - c1y) * uy) / n2
    fx, fy = c1x + t * ux, c1y + t * uy  # foot of beacon 2 on the line of centres
    x, y = 2 * fx - p2[0], 2 * fy - p2[1]
    gap = math.hypot(x - p2[0], y - p2[1])
    if gap < 1e-9 * max(1.0, math.dist(p1, p3)):
        return failed("robot on the circle through the beacons")
    return Fix(x, y, heading_from(x, y, beacons, bearings), n2)


# ---- Bac et al. 2011, appendix A -----------------------------------------------------------


def bac(alpha: float, beta: float, length: float, width: float) -> Fix:
    """Bac's closed form for the corner table: arrays at O (0, 0), (L, 0) and (0, W); `alpha` is
    the angle the robot sees between (L, 0) and O, `beta` between (0, W) and O (both 0..pi).
    theta = atan((L - W / tan beta) / (W - L / tan alpha)), r = W cos(theta - beta) / sin beta."""
    if not (0 < alpha < math.pi and 0 < beta < math.pi):
        return failed("angles outside (0, pi): the robot is not inside the table")
    theta = math.atan2(length - width / math.tan(beta), width - length / math.tan(alpha))
    r = width * math.cos(theta - beta) / math.sin(beta)
    x, y = r * math.cos(theta), r * math.sin(theta)
    if r < 1e-9:
        return failed("robot at a beacon")
    return Fix(x, y, math.nan, r)


# ---- Simi 2000: Newton-Raphson for x, y and heading ----------------------------------------


def newton(
    beacons: list[tuple[float, float]],
    bearings: list[float],
    guess: tuple[float, float, float],
    tolerance: float = 1e-12,
    iterations: int = 50,
) -> Fix:
    """Simi's method: solve atan2(yi - y, xi - x) - heading - bearing_i = 0 for (x, y, heading)
    by Newton-Raphson from `guess` (his was (57, -57.5, 0.1) in)."""
    m = len(beacons)
    if len(bearings) != m:
        raise ValueError(f"{m} beacons but {len(bearings)} bearings: one bearing per beacon")
    if m < 3:
        return failed("fewer than three beacons")
    solve = dense.lstsq_solver(m, 3)
    jh = [-1.0] * m  # the Jacobian's heading column
    x, y, h = guess
    for _ in range(iterations):
        minus_f, jx, jy = [], [], []  # the residuals, negated; the Jacobian's x and y columns
        for (bx, by), b in zip(beacons, bearings):
            dx, dy = bx - x, by - y
            d2 = dx * dx + dy * dy
            if d2 < 1e-18:
                return failed("robot at a beacon")
            minus_f.append(-wrap(math.atan2(dy, dx) - h - b))
            jx.append(dy / d2)
            jy.append(-dx / d2)
        sx, sy, sh = solve(jx + jy + jh, minus_f)
        grow = max(abs(sx), abs(sy)) / MAX_STEP
        if grow > 1:  # a trust region: far from the answer, never jump across the field
            sx, sy, sh = sx / grow, sy / grow, sh / grow
        x, y, h = x + sx, y + sy, h + sh
        if abs(sx) + abs(sy) + abs(sh) < tolerance:
            cond = dense.condition(np.array([jx, jy, jh]).T)
            if not math.isfinite(cond) or cond > 1e10:
                return failed("robot on the circle through the beacons")
            return Fix(float(x), float(y), wrap(float(h)), float(1.0 / cond))
    return failed("Newton-Raphson did not converge")


# ---- Ubersetzig 1999: three targets on one wall ---------------------------------------------


def wall(spacing: float, a12: float, a23: float) -> Fix:
    """Ubersetzig's wall-target method: targets at (0, -s), (0, 0), (0, +s) on the wall x = 0,
    the robot at x > 0 seeing angle `a12` between targets 1 and 2 and `a23` between 2 and 3.
    The circle centres C12, C23 lie at x = (s / 2) / tan(a), y = -s/2 and +s/2; the line through
    them, x = m y + xint, is the perpendicular bisector of target 2 -> robot."""
    if not (0 < a12 < math.pi and 0 < a23 < math.pi):
        return failed("angles outside (0, pi): the robot is not in front of the wall")
    c12x, c12y = (spacing / 2) / math.tan(a12), -spacing / 2
    c23x, c23y = (spacing / 2) / math.tan(a23), spacing / 2
    m = (c23x - c12x) / (c23y - c12y)
    xint = (c23x + c12x) / 2
    # foot of (0, 0) on x = m y + xint, mirrored: the robot
    yf = -m * xint / (1 + m * m)
    xf = m * yf + xint
    x, y = 2 * xf, 2 * yf
    if x <= 1e-9:
        return failed("robot on the circle through the beacons")
    return Fix(x, y, math.nan, x)


# ---- Osentoski: three lights in a line, law of sines ---------------------------------------


def law_of_sines(spacing: float, a: float, b: float) -> Fix:
    """Osentoski's three lights L (-s, 0), M (0, 0), R (s, 0): the robot (y < 0) sees angle `a`
    between L and M and `b` between M and R. With phi the angle at L, the law of sines in both
    triangles gives tan(phi) = sin a sin(a + b) / (sin b - sin a cos(a + b)) and |RM|."""
    if not (0 < a < math.pi and 0 < b < math.pi and a + b < math.pi):
        return failed("angles impossible for a robot between the outer lights")
    phi = math.atan2(math.sin(a) * math.sin(a + b), math.sin(b) - math.sin(a) * math.cos(a + b))
    dist_l = spacing * math.sin(a + phi) / math.sin(a)  # robot to L
    x, y = -spacing + dist_l * math.cos(phi), -dist_l * math.sin(phi)
    if dist_l < 1e-9:
        return failed("robot at a beacon")
    return Fix(x, y, math.nan, abs(y))


# ---- least squares for three or more beacons ------------------------------------------------


def least_squares(
    beacons: list[tuple[float, float]], bearings: list[float], sigma: float, guess: tuple[float, float] | None = None
) -> Fix:
    """Gauss-Newton fit of (x, y, heading) to any number of bearings, with the position
    covariance sigma^2 (J^T J)^-1 (sigma: the bearing noise, rad). Started from ToTal on the
    first three beacons unless a guess is given."""
    if len(beacons) < 3:
        return failed("fewer than three beacons")
    if guess is None:
        seed = total(beacons[:3], bearings[:3])
        guess = (seed.x, seed.y) if seed.ok else tuple(np.mean(beacons, axis=0))
    fit = newton(beacons, bearings, (guess[0], guess[1], heading_from(*guess, beacons, bearings)))
    if not fit.ok:
        return fit
    jac = []
    for bx, by in beacons:
        dx, dy = bx - fit.x, by - fit.y
        d2 = dx * dx + dy * dy
        jac.append((dy / d2, -dx / d2, -1.0))
    j = np.array(jac)
    try:
        cov = sigma * sigma * dense.inverse(j.T @ j)
    except np.linalg.LinAlgError:
        return failed("robot on the circle through the beacons")
    pos = ((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1])))
    return Fix(fit.x, fit.y, fit.heading, float(1.0 / math.sqrt(max(cov[0, 0] + cov[1, 1], 1e-300))), covariance=pos)
