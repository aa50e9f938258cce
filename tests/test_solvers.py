"""Every solver against the truth, against the others, and at its degenerate points."""

import math
import random

import numpy as np
import pytest

from robots.toolkit import solvers as S
from robots.toolkit.associate import by_prediction, by_sectors

TRI = [(0.0, 0.0), (1.83, 0.0), (1.83, 1.22)]
FT = 0.3048


def bearings(x, y, h, beacons):
    return [math.atan2(by - y, bx - x) - h for bx, by in beacons]


def away_from_degenerate(x, y, beacons, margin=0.05):
    """Not within `margin` of a beacon or of the circle through the first three."""
    if min(math.dist((x, y), b) for b in beacons) < margin:
        return False
    (ax, ay), (bx, by), (cx, cy) = beacons[:3]
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    ux = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)) / d
    uy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)) / d
    return abs(math.dist((x, y), (ux, uy)) - math.dist((ax, ay), (ux, uy))) > margin


def random_poses(n, seed=3, beacons=TRI):
    rng = random.Random(seed)
    out = []
    while len(out) < n:
        x, y, h = rng.uniform(-0.5, 2.5), rng.uniform(-0.5, 2.0), rng.uniform(-math.pi, math.pi)
        if away_from_degenerate(x, y, beacons):
            out.append((x, y, h))
    return out


@pytest.mark.parametrize("solver", ["total", "circles", "newton", "least_squares"])
def test_round_trip_to_1e_9(solver):
    for x, y, h in random_poses(300):
        z = bearings(x, y, h, TRI)
        if solver == "newton":
            fix = S.newton(TRI, z, (x + 0.03, y - 0.03, h + 0.03))  # a local method: a close guess
        elif solver == "least_squares":
            fix = S.least_squares(TRI, z, 1e-3)
        else:
            fix = getattr(S, solver)(TRI, z)
        assert fix.ok, (x, y, fix.reason)
        assert math.dist((fix.x, fix.y), (x, y)) < 1e-9
        assert abs(math.remainder(fix.heading - h, 2 * math.pi)) < 1e-9


def _seen(x, y, p):
    """The absolute direction of point `p` seen from (x, y)."""
    return math.atan2(p[1] - y, p[0] - x)


def test_bac_closed_form_round_trip_on_the_table():
    L, W = 1.83, 1.22
    rng = random.Random(5)
    for _ in range(300):
        x, y = rng.uniform(0.02, L - 0.02), rng.uniform(0.02, W - 0.02)
        alpha = abs(math.remainder(_seen(x, y, (L, 0)) - _seen(x, y, (0, 0)), 2 * math.pi))
        beta = abs(math.remainder(_seen(x, y, (0, W)) - _seen(x, y, (0, 0)), 2 * math.pi))
        fix = S.bac(alpha, beta, L, W)
        assert math.dist((fix.x, fix.y), (x, y)) < 1e-9
        # and it agrees with ToTal on the same three arrays
        t = S.total([(0, 0), (L, 0), (0, W)], bearings(x, y, 0.3, [(0, 0), (L, 0), (0, W)]))
        assert math.dist((fix.x, fix.y), (t.x, t.y)) < 1e-9


def test_wall_and_law_of_sines_round_trip():
    rng = random.Random(7)
    s = 48 * 0.0254
    for _ in range(300):
        x, y = rng.uniform(0.1, 3.2), rng.uniform(-3.2, 3.2)
        if min(math.dist((x, y), (0, t)) for t in (-s, 0, s)) < 0.05:
            continue  # the targets are collinear: only their own neighbourhoods are degenerate
        a = [math.atan2(ty - y, -x) for ty in (-s, 0, s)]
        fix = S.wall(s, math.remainder(a[0] - a[1], 2 * math.pi), math.remainder(a[1] - a[2], 2 * math.pi))
        assert math.dist((fix.x, fix.y), (x, y)) < 1e-9
        # the same robot by the general circle method (targets as three beacons)
        c = S.circles([(0, -s), (0, 0), (0, s)], bearings(x, y, 0.0, [(0, -s), (0, 0), (0, s)]))
        assert math.dist((c.x, c.y), (x, y)) < 1e-9
    for _ in range(300):
        x, y = rng.uniform(-1.4, 1.4), -rng.uniform(0.05, 2.0)
        a = [math.atan2(-y, lx - x) for lx in (-1.5, 0, 1.5)]
        fix = S.law_of_sines(
            1.5, abs(math.remainder(a[0] - a[1], 2 * math.pi)), abs(math.remainder(a[1] - a[2], 2 * math.pi))
        )
        assert math.dist((fix.x, fix.y), (x, y)) < 1e-9


def test_least_squares_with_four_beacons_and_covariance():
    four = TRI + [(0.0, 1.22)]
    x, y, h = 1.16, 0.53, 0.4
    fix = S.least_squares(four, bearings(x, y, h, four), sigma=1e-3)
    assert math.dist((fix.x, fix.y), (x, y)) < 1e-9
    cov = np.array(fix.covariance)
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)


def test_degenerate_inputs_are_flagged():
    # on the circle through the three beacons: the centre of TRI's circumcircle is (0.915, 0.61)
    r = math.dist((0.915, 0.61), (0, 0))
    on = (0.915 + r * math.cos(2.5), 0.61 + r * math.sin(2.5))
    z = bearings(*on, 0.0, TRI)
    for fix in (S.total(TRI, z), S.circles(TRI, z)):
        assert not fix.ok and "circle" in fix.reason and fix.reliability == 0
    line = [(0, 0), (1, 0), (2, 0)]
    fix = S.total(line, bearings(0.5, 1, 0, line))
    assert not fix.ok and fix.reason == "collinear beacons"
    # the circle method handles a line of beacons (the seeds' wall and lights), except on the line
    assert S.circles(line, bearings(0.5, 1, 0, line)).ok
    on_line = S.circles(line, bearings(3.0, 0.0, 0, line))
    assert not on_line.ok and "line" in on_line.reason
    assert not S.total(TRI[:2], [0.1, 0.2]).ok
    assert not S.least_squares(TRI[:2], [0.1, 0.2], 1e-3).ok
    assert S.newton(TRI, [0.1, 0.2, 0.3], (0.0, 0.0, 0.0)).reason == "robot at a beacon"
    # near the circle the reliability collapses: it is a usable warning, not garbage
    near = (0.915 + 1.001 * r * math.cos(2.5), 0.61 + 1.001 * r * math.sin(2.5))
    far = (0.9, 0.4)
    assert (
        0 < S.total(TRI, bearings(*near, 0, TRI)).reliability < 0.01 * S.total(TRI, bearings(*far, 0, TRI)).reliability
    )


def test_total_batch_matches_scalar():
    poses = random_poses(2000, seed=11)
    z = np.array([bearings(x, y, h, TRI) for x, y, h in poses])
    x, y, rel = S.total_batch(np.array(TRI), z)
    for i in range(len(poses)):
        one = S.total(TRI, list(z[i]))
        assert (x[i], y[i]) == pytest.approx((one.x, one.y), abs=1e-9)
        assert rel[i] == pytest.approx(one.reliability, rel=1e-6)
    assert np.max(np.hypot(x - [p[0] for p in poses], y - [p[1] for p in poses])) < 1e-9


def test_vannoy_sector_rule_and_its_ambiguity():
    beacons = {"A": (0, 21 * FT), "B": (13 * FT, 21 * FT), "C": (13 * FT, 0)}
    centre = (6.5 * FT, 10.5 * FT)
    x, y, h = 8 * FT, 5 * FT, math.radians(220)
    rel = {b: (math.atan2(by - y, bx - x) - h) % (2 * math.pi) for b, (bx, by) in beacons.items()}
    order = sorted(rel, key=rel.get)
    assert order == ["C", "B", "A"]  # the worked example: C after 1.0556 s, then B, then A
    got = by_sectors([rel[b] for b in order], beacons, centre)
    assert got.ids == ("C", "B", "A") and not got.ambiguous
    # where all three sectors are 120 deg the rule cannot decide: find that point by search
    best = min(
        ((i * 0.01 * 13 * FT, j * 0.01 * 21 * FT) for i in range(1, 100) for j in range(1, 100)),
        key=lambda p: sum(abs(g - 2 * math.pi / 3) for g in sectors(p, beacons)),
    )
    assert max(abs(g - 2 * math.pi / 3) for g in sectors(best, beacons)) < math.radians(2)
    rel = sorted((math.atan2(by - best[1], bx - best[0]) % (2 * math.pi) for bx, by in beacons.values()))
    assert by_sectors(rel, beacons, centre).ambiguous


def sectors(p, beacons):
    a = sorted(math.atan2(by - p[1], bx - p[0]) % (2 * math.pi) for bx, by in beacons.values())
    return [(a[(i + 1) % 3] - a[i]) % (2 * math.pi) for i in range(3)]


def test_prediction_association_gates():
    beacons = {"A": (0, 0), "B": (2, 0), "C": (1, 2)}
    pose = (1.0, 0.7, 0.2)
    z = bearings(1.02, 0.69, 0.21, list(beacons.values()))
    assert by_prediction(z, beacons, pose, gate=0.2).ids == ("A", "B", "C")
    wild = by_prediction([z[0], z[1] + 1.0, z[2]], beacons, pose, gate=0.2)
    assert wild.ids == ("A", None, "C") and wild.ambiguous


def _newton_through_np_linalg(beacons, bearings, guess, tolerance=1e-12, iterations=50):
    """Simi's Newton-Raphson as first written, every step through np.linalg: the reference the
    toolkit's (its least-squares step solved by LAPACK directly) must equal bit for bit."""
    x, y, h = guess
    for _ in range(iterations):
        f, jac = [], []
        for (bx, by), b in zip(beacons, bearings):
            dx, dy = bx - x, by - y
            d2 = dx * dx + dy * dy
            if d2 < 1e-18:
                return None
            f.append(math.remainder(math.atan2(dy, dx) - h - b, 2 * math.pi))
            jac.append((dy / d2, -dx / d2, -1.0))
        j = np.array(jac)
        step = np.linalg.lstsq(j, -np.array(f), rcond=None)[0]
        grow = max(abs(step[0]), abs(step[1])) / S.MAX_STEP
        if grow > 1:
            step = step / grow
        x, y, h = x + step[0], y + step[1], h + step[2]
        if abs(step[0]) + abs(step[1]) + abs(step[2]) < tolerance:
            cond = np.linalg.cond(j)
            if not math.isfinite(cond) or cond > 1e10:
                return None
            return (float(x), float(y), math.remainder(float(h), 2 * math.pi), float(1.0 / cond))
    return None


def test_newton_gives_the_bits_of_its_np_linalg_form():
    g = np.random.default_rng(29)
    for _ in range(1500):
        m = int(g.integers(3, 8))
        beacons = [tuple(p) for p in g.uniform(-2, 5, size=(m, 2))]
        x, y, h = g.uniform(0, 3), g.uniform(0, 2), g.uniform(-4, 4)
        bearings = [math.atan2(by - y, bx - x) - h + g.normal(0, 1e-3) for bx, by in beacons]
        guess = (x + g.normal(0, 0.3), y + g.normal(0, 0.3), h + g.normal(0, 0.3))
        fix = S.newton(beacons, bearings, guess)
        expected = _newton_through_np_linalg(beacons, bearings, guess)
        bits = np.array(fix[:4]).tobytes() if fix.ok else None
        assert bits == (None if expected is None else np.array(expected).tobytes())


def test_newton_wants_one_bearing_per_beacon():
    beacons = [(0.0, 0.0), (3.0, 0.0), (3.0, 2.0), (0.0, 2.0)]
    with pytest.raises(ValueError, match="4 beacons but 3 bearings"):
        S.newton(beacons, [0.1, 0.2, 0.3], (1.0, 1.0, 0.0))


def test_a_turns_fit_finds_the_pose_least_squares_finds():
    """revolution.fit (the normal equations in plain floats) against the geometry it inverts and
    against solvers.least_squares (a general solver): the same pose, to 1e-9, with three and
    four arrays, noisy bearings included; and it refuses the circle through three arrays."""
    from robots.toolkit.revolution import fit

    g = np.random.default_rng(17)
    four = TRI + [(0.0, 1.22)]
    for _ in range(300):
        x, y, h = g.uniform(0.1, 1.7), g.uniform(0.1, 1.1), g.uniform(-math.pi, math.pi)
        for points in (TRI, four):
            z = bearings(x, y, h, points)
            got = fit(points, z)
            assert got is not None and math.dist(got[:2], (x, y)) < 1e-9
            assert abs(math.remainder(got[2] - h, 2 * math.pi)) < 1e-9
            noisy = [b + g.normal(0, 2e-3) for b in z]
            want, got = S.least_squares(points, noisy, 1e-3), fit(points, noisy)
            if want.ok:
                assert got is not None and math.dist(got[:2], (want.x, want.y)) < 1e-9
    r = math.dist((0.915, 0.61), (0, 0))
    on = (0.915 + r * math.cos(2.5), 0.61 + r * math.sin(2.5))
    assert fit(TRI, bearings(*on, 0.0, TRI)) is None
