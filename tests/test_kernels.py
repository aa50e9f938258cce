"""The compiled sensing kernels give NumPy's own bits (decision 0025).

Each kernel replaced a run of NumPy expressions; those expressions are kept here, as written
before, and both are run on random trajectories: crossings (beams on and beside their axis),
occlusion by other robots, and Bac's merged pulses. Equality is exact, bit for bit, so results
and replays stay what they were (tests/test_golden.py guards the whole match). The arc functions
of the crossings themselves are the C library's (decisions 0041, 0050): the NumPy expressions here take
them elementwise from Python's `math`, which calls the same library."""

import math
import subprocess
import sys

import numpy as np
import pytest
from helpers import BEACONS, random_trajectory

from arena.angles import wrap_angle
from arena.sensing import occlusion, optics, sensor_array, spin
from arena.sensing.crossings import find_crossings

# ---- the NumPy expressions, as they were ----------------------------------------------------

_atan2 = np.vectorize(math.atan2, otypes=[float])  # the C library's, elementwise
_asin = np.vectorize(math.asin, otypes=[float])


def numpy_crossings(traj, bx, by, off):
    dx = bx[None, None, :] - traj.x[:, :, None]
    dy = by[None, None, :] - traj.y[:, :, None]
    a = traj.h + traj.phi
    d = a[:, :, None] - _atan2(dy, dx)  # the grid: the C library's too (decision 0050)
    if off is not None:
        d += _asin(np.clip(off[None, :, None] / np.hypot(dx, dy), -1.0, 1.0))
    d = wrap_angle(d)
    sign = np.sign(d)
    passes = (sign[:-1] != 0) & (sign[1:] != sign[:-1]) & (np.abs(d[1:] - d[:-1]) < np.pi)
    size = dx[0].size
    flat = passes.ravel().nonzero()[0]
    step, robot, beacon = np.unravel_index(flat, passes.shape)
    d = d.ravel()
    f0, f1 = d[flat], d[flat + size]
    s = f0 / (f0 - f1)
    ex0, ey0 = dx.ravel()[flat], dy.ravel()[flat]
    state = np.array((traj.x, traj.y, a, traj.phi)).reshape(4, -1)
    at = step * dx.shape[1] + robot
    start = state[:, at]
    ddx, ddy, da, dphi = state[:, at + dx.shape[1]] - start
    a0, phi0 = start[2], start[3]
    o = None if off is None else off[robot]
    for _ in range(2):
        ex, ey = ex0 - s * ddx, ey0 - s * ddy
        r2 = ex * ex + ey * ey
        f = a0 + s * da - _atan2(ey, ex)
        slope = da - (ey * ddx - ex * ddy) / r2
        if o is not None:
            r = np.sqrt(r2)
            f += _asin(np.clip(o / r, -1.0, 1.0))
            slope += o * (ex * ddx + ey * ddy) / (r2 * r * np.sqrt(np.maximum(1.0 - o * o / r2, 1e-12)))
        f = wrap_angle(f)
        s = np.minimum(np.maximum(s - f / np.where(slope == 0, 1.0, slope), 0.0), 1.0)
    ex, ey = ex0 - s * ddx, ey0 - s * ddy
    d2 = ex * ex + ey * ey
    dt = traj.t[step + 1] - traj.t[step]
    return dict(
        robot=robot,
        beacon=beacon,
        step=step,
        s=s,
        t=traj.t[step] + s * dt,
        x=bx[beacon] - ex,
        y=by[beacon] - ey,
        phi=phi0 + s * dphi,
        beam_rate=(da - (ey * ddx - ex * ddy) / d2) / dt,
        distance=np.sqrt(d2),
        bearing=_atan2(ey, ex),
    )


def numpy_blocked(traj, robot, step, s, px, py, bx, by, radius, reach, silhouette):
    n = traj.x.shape[1]
    vx, vy = bx - px, by - py
    d = np.hypot(vx, vy)
    shrink = np.where(d > radius, (d - radius) / np.maximum(d, 1e-12), 0.0)
    qx, qy = px + vx * shrink, py + vy * shrink
    blocked = np.zeros(len(robot), dtype=bool)
    if n > 1:
        cx, cy = traj.x[0], traj.y[0]
        ux, uy = (qx - px)[:, None], (qy - py)[:, None]
        px2, py2 = px[:, None], py[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = ((cx - px2) * ux + (cy - py2) * uy) / (ux * ux + uy * uy)
        u = np.minimum(np.maximum(u, 0.0), 1.0)
        gap = np.hypot(px2 + u * ux - cx, py2 + u * uy - cy)
        near = (~np.eye(n, dtype=bool))[robot] & (gap <= reach)
        rows, o = near.nonzero()
        ox = traj.x[step[rows], o] + s[rows] * (traj.x[step[rows] + 1, o] - traj.x[step[rows], o])
        oy = traj.y[step[rows], o] + s[rows] * (traj.y[step[rows] + 1, o] - traj.y[step[rows], o])
        sx, sy, tx, ty = px[rows], py[rows], qx[rows], qy[rows]
        ux, uy = tx - sx, ty - sy
        length2 = ux * ux + uy * uy
        u = ((ox - sx) * ux + (oy - sy) * uy) / np.where(length2 > 0, length2, 1.0)
        u = np.minimum(np.maximum(u, 0.0), 1.0)
        hit = np.hypot(sx + u * ux - ox, sy + u * uy - oy) <= silhouette[o]
        blocked[rows[hit]] = True
    return blocked, qx, qy


def numpy_merge(times, robot, beacon, turn, n_beacons, rate, key):
    with np.errstate(over="ignore"):
        z = np.uint64(key) + robot.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        z = z + turn.astype(np.int64).view(np.uint64) * np.uint64(0xD1B54A32D192ED03)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    h = z ^ (z >> np.uint64(31))
    merged = (h >> np.uint64(11)).astype(np.float64) * 2.0**-53 < rate
    victim = (h & np.uint64(0x7FF)).astype(np.int64) % n_beacons == beacon
    has_pred = np.concatenate(([False], robot[1:] == robot[:-1]))
    hit = np.nonzero(merged & victim & has_pred)[0]
    out = times.copy()
    out[hit] = times[hit - 1]
    return out


@pytest.mark.parametrize("offset", [False, True])
def test_crossings_are_numpys_bit_for_bit(offset):
    g = np.random.default_rng(7 + offset)
    total = 0
    for _ in range(60):
        traj = random_trajectory(g)
        off = g.uniform(-0.05, 0.05, traj.x.shape[1]) if offset else None
        want = numpy_crossings(traj, *BEACONS, off)
        got = find_crossings(traj, *BEACONS, off)
        total += len(got)
        for name, value in want.items():
            assert np.array_equal(getattr(got, name), value), name
            assert getattr(got, name).tobytes() == np.asarray(value, dtype=getattr(got, name).dtype).tobytes(), name
    assert total > 60 * 4 * 5 * 1.5  # about 3 passes per robot and beacon in 0.2 s


def test_occlusion_is_numpys_bit_for_bit():
    g = np.random.default_rng(3)
    bx, by = BEACONS
    blocked_any = 0
    for _ in range(200):
        traj = random_trajectory(g, robots=int(g.integers(1, 6)))
        c = find_crossings(traj, bx, by)
        reach = g.uniform(0.05, 0.3, traj.x.shape[1])
        silhouette = g.uniform(0.02, 0.2, traj.x.shape[1])
        args = (c.robot, c.step, c.s, c.x, c.y, bx[c.beacon], by[c.beacon])
        want = numpy_blocked(traj, *args, 0.02, reach, silhouette)
        got = occlusion.blocked(
            c.x, c.y, bx, by, c.beacon, 0.02, c.robot, c.step, c.s, traj.x, traj.y, reach, silhouette
        )
        for w, v in zip(want, got):
            assert w.tobytes() == v.tobytes()
        blocked_any += int(want[0].sum())
    assert blocked_any > 50  # the geometry does block beams, often enough to test


def test_merged_pulses_are_numpys_bit_for_bit():
    g = np.random.default_rng(5)
    for rate in (0.034, 0.5, 1.0):
        for _ in range(200):
            m = int(g.integers(2, 60))
            robot = np.sort(g.integers(0, 4, m))
            times = np.sort(g.uniform(0, 100, m))
            turn = np.floor(g.uniform(-3000, 3000, m))  # laser turning either way
            beacon = g.integers(0, 4, m)
            key = int(g.integers(1 << 62))
            want = numpy_merge(times, robot, beacon, turn, 4, rate, key)
            got, _ = sensor_array.merge(times, robot, beacon, turn, 4, rate, np.uint64(key))
            assert got.tobytes() == want.tobytes()


def numpy_phases(omega, dt, phi0, heading, noise, wobble, spin):
    """Spin.phases as NumPy wrote it (closed-form first-order filters, accumulated sums)."""

    def first_order(a, y0, drive):
        powers = a ** np.arange(1, len(drive) + 1)[:, None]
        return powers * (y0 + np.add.accumulate(drive / powers, axis=0))

    steps = len(heading) - 1
    rate, outs = None, [wobble[1], spin[2], spin[3]]
    if noise is not None:
        w = first_order(wobble[0], wobble[1], np.sqrt(1 - wobble[0] ** 2) * 0.003 * noise)
        rate = omega * (1.0 + w)
        outs[0] = w[-1]
    a, coupling, lag0, body0 = spin
    body = (heading[1:] - heading[:-1]) / dt
    change = np.empty_like(body)
    change[0] = body[0] - body0
    np.subtract(body[1:], body[:-1], out=change[1:])
    drive = -a * change
    if coupling:
        drive = drive - (1 - a) * coupling * body
    lag = first_order(a, lag0, drive)
    rate = (omega if rate is None else rate) + lag
    outs[1:] = lag[-1], body[-1]
    phi = np.empty((steps + 1, len(omega)))
    phi[0] = 0.0
    np.add.accumulate(rate * dt, axis=0, out=phi[1:])
    phi += phi0
    return phi, *outs


@pytest.mark.parametrize("wobbles", [False, True])
@pytest.mark.parametrize("coupling", [0.0, 0.2])
def test_laser_phases_are_numpys_bit_for_bit(wobbles, coupling):
    g = np.random.default_rng(11)
    dt, steps, n = 1 / 240, 48, 3
    powers = lambda a: np.ascontiguousarray(np.broadcast_to(a ** np.arange(1, steps + 1)[:, None], (steps, n)))  # noqa: E731
    for _ in range(30):
        omega = g.choice([-1.0, 1.0], n) * g.uniform(20, 90, n)
        phi0, heading = g.uniform(-40, 40, n), np.cumsum(g.normal(0, 0.02, (steps + 1, n)), axis=0)
        wa, sa = np.exp(-dt / 0.5), np.exp(-dt / 0.03)
        w0, lag0, body0 = g.normal(0, 0.003, n), g.normal(0, 0.5, n), g.normal(0, 1, n)
        noise = g.normal(size=(steps, n)) if wobbles else None
        want = numpy_phases(omega, dt, phi0, heading, noise, (wa, w0), (sa, coupling, lag0, body0))
        state = [phi0.copy(), w0.copy(), lag0.copy(), body0.copy()]  # moved on in place
        start = g.integers(0, 5, n)
        block = np.zeros((n, steps + 5))
        if noise is not None:
            for r in range(n):
                block[r, start[r] : start[r] + steps] = noise[:, r]
        at = start.copy() if noise is not None else np.zeros(0, np.int64)
        phi = spin.laser_phases(
            omega,
            dt,
            state[0],
            heading,
            np.zeros((0, 0)) if noise is None else block,  # each robot's draws in a row, from `at` on
            at,
            np.sqrt(1 - wa * wa) * 0.003,
            wa,
            powers(wa),
            sa,
            (1 - sa) * coupling,
            powers(sa),
            *state[1:],
        )
        for w, v in zip(want, (phi, *state[1:])):
            assert np.asarray(w).tobytes() == v.tobytes()
        assert state[0].tobytes() == phi[-1].tobytes()  # the next batch starts where this one ends
        if noise is not None:
            assert at.tolist() == (start + steps).tolist()  # each robot's position moved past its draws


def test_optics_and_incidence_are_numpys_bit_for_bit():
    g = np.random.default_rng(13)
    n = 5000
    distance, rate = g.uniform(0.05, 3, n), g.normal(0, 80, n)
    rate[:50] = 0.0  # a beam that stands still
    bearing, facing, beacon = g.uniform(-7, 7, n), g.uniform(-4, 4, 4), g.integers(0, 4, n)
    sens = np.where(g.random(n) < 0.1, 0.0, g.uniform(0, 1, n))
    hardware = (0.0015, 1e-3, 0.003, 0.5, 1.11e-5)
    inc = np.abs(wrap_angle(bearing + np.pi - facing[beacon]))
    assert optics.incidences(bearing, facing, beacon).tobytes() == inc.tobytes()
    d, div, ap, eta, rise = hardware
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.abs(rate) * distance
        w = d + div * distance
        a = ap * np.cos(inc)
        lit, across = sens > 0, w + a
        peak = sens * np.where(w > a, a / w, 1.0)
        x = np.where(lit, eta * w / sens, np.inf)
        dwell = (across - 2.0 * x) / v
        offset = np.where(v > 0, (x - across / 2.0) / v, 0.0)
    ok = (peak >= eta * (1 - 1e-9)) & lit & (dwell >= rise)
    got_ok, got_offset = optics.sweep_optics(distance, rate, np.cos(inc), sens, hardware)
    assert got_ok.tobytes() == ok.tobytes() and 0 < ok.sum() < n
    assert got_offset.tobytes() == np.where(ok, offset, 0.0).tobytes()


def test_kernels_compile_where_no_cache_folder_can_be_written():
    """A user who can write neither the installation nor a cache folder still gets sensing."""
    code = (
        "import numba.core.caching as c\n"
        "c.CacheImpl._locator_classes = []\n"  # what numba finds for such a user: no place to cache
        "import numpy as np\n"
        "from arena.sensing import crossings\n"
        "ex, ey = crossings.toward(np.ones((8, 2)), np.array([0.5, 0.25]))\n"
        "print(ex.tolist(), ey.tolist())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split() == ["[0.5,", "0.75]", "[0.5,", "0.75]"]


def test_border_crossings_are_where_numpy_finds_them():
    from referee.match.rules import border_changes

    g = np.random.default_rng(23)
    for _ in range(300):
        robots, steps = int(g.integers(1, 5)), int(g.integers(1, 60))
        states = g.uniform(-0.2, 1.2, (steps, 3 * robots))
        states[g.random(states.shape) < 0.02] = np.nan
        outside = g.random(robots) < 0.3
        x, y = states[:, 0::3], states[:, 1::3]
        out = ~((0.0 <= x) & (x <= 1.0) & (0.0 <= y) & (y <= 1.0))
        want = np.flatnonzero((out != np.vstack([outside, out[:-1]])).any(axis=1))
        assert border_changes(states, 0.0, 0.0, 1.0, 1.0, outside).tolist() == want.tolist()


def test_every_robots_distances_at_once_are_each_paths_own():
    from referee.match.paths import Paths, Polyline

    g = np.random.default_rng(29)
    for _ in range(100):
        robots = int(g.integers(1, 5))
        lines = [
            None if g.random() < 0.2 else Polyline([tuple(p) for p in g.uniform(0, 2, (int(g.integers(2, 7)), 2))])
            for _ in range(robots)
        ]
        states = g.uniform(-0.5, 2.5, (int(g.integers(9, 60)), 3 * robots))
        start, every = int(g.integers(0, 8)), int(g.integers(1, 9))
        runs = [(s, int(g.integers(start + 1, len(states) + 1))) for s in range(robots) if lines[s] is not None]
        got = Paths(lines).distances(states, start, every, runs)
        for (slot, end), values in zip(runs, got):
            want = lines[slot].distances(states[start:end:every, 3 * slot], states[start:end:every, 3 * slot + 1])
            assert np.array(values).tobytes() == np.array(want).tobytes()


def test_distances_to_a_path_are_numpys_bit_for_bit():
    from referee.match.paths import Polyline, first_near

    g = np.random.default_rng(19)
    for _ in range(300):
        points = [tuple(p) for p in g.uniform(0, 2, (int(g.integers(2, 9)), 2))]
        if g.random() < 0.2:
            points.insert(1, points[0])  # a segment of length 0
        line = Polyline(points)
        x, y = g.uniform(-0.5, 2.5, 60), g.uniform(-0.5, 2.5, 60)
        p = np.asarray(points, dtype=float)
        a, d = p[:-1], p[1:] - p[:-1]
        n2 = np.maximum((d**2).sum(axis=1), 1e-300)
        rx, ry = x[:, None] - a[:, 0], y[:, None] - a[:, 1]
        t = np.clip((rx * d[:, 0] + ry * d[:, 1]) / n2, 0.0, 1.0)
        want = np.sqrt((rx - t * d[:, 0]) ** 2 + (ry - t * d[:, 1]) ** 2).min(axis=1)
        assert np.array(line.distances(x, y)).tobytes() == want.tobytes()
        near = np.hypot(x - points[-1][0], y - points[-1][1]) <= 0.3
        start = int(g.integers(0, 60))
        hits = np.flatnonzero(near[start:])
        assert first_near(x, y, start, *points[-1], 0.3) == (start + hits[0] if len(hits) else -1)
