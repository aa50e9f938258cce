"""Crossing times against analytic geometry and a fine-step reference; occlusion."""

import math

import numpy as np
import pytest
from helpers import ONE, TABLE, TWO, hits, make, sense

from arena.world import World
from levels.loader import parse_level


@pytest.mark.parametrize("omega", [20.0, -81.0, 1.5707963267948966])
def test_stationary_robot_matches_analytic_times(omega):
    w = make(omega=omega)
    (events,), _ = sense(w, 10.0)
    start = w.level.robots[0].start
    period = 2 * math.pi / abs(omega)
    for b in w.level.beacons.items:
        bearing = math.atan2(b.y - start.y, b.x - start.x)
        first = ((bearing - start.heading) * math.copysign(1, omega)) % (2 * math.pi) / abs(omega)
        expected = [first + k * period for k in range(int((10.0 - first) / period) + 1)]
        got = [e.time for e in hits(events, b.id)]
        if got and got[-1] > 10.0 - 1e-9:
            got = got[:-1] if len(got) > len(expected) else got
        assert len(got) == len(expected)
        assert np.max(np.abs(np.array(got) - expected)) < 1e-7  # 0.1 us
    index = [e.time for e in events if e.kind == "index"]
    assert np.allclose(index, [k * period for k in range(1, len(index) + 1)], atol=1e-9, rtol=0)


def fine_reference(poses, omega, dt, bx, by, sub=4000):
    """Crossing times by brute force: sample every step `sub` times along the linearly
    interpolated motion, find sign changes of the wrapped beam-bearing difference."""
    out = []
    frac = np.arange(sub + 1) / sub
    for k in range(len(poses) - 1):
        (x0, y0, h0), (x1, y1, h1) = poses[k], poses[k + 1]
        t = (k + frac) * dt
        x, y, h = x0 + frac * (x1 - x0), y0 + frac * (y1 - y0), h0 + frac * (h1 - h0)
        g = (h + omega * t - np.arctan2(by - y, bx - x) + np.pi) % (2 * np.pi) - np.pi
        i = np.nonzero((np.sign(g[:-1]) != np.sign(g[1:])) & (np.abs(g[:-1] - g[1:]) < 1.0))[0]
        out += list(t[i] + (t[i + 1] - t[i]) * g[i] / (g[i] - g[i + 1]))
    return np.array(out)


def test_moving_turning_robot_matches_fine_step_reference():
    w = make(omega=20.0)
    (events,), poses = sense(w, 6.0, commands=[(0.15, 0.45)])  # an arc: moving and turning
    assert poses[-1, 0, 2] - poses[0, 0, 2] > 3.0  # it really turned (rad)
    dt = w.dt
    for b in w.level.beacons.items:
        ref = fine_reference(poses[:, 0], 20.0, dt, b.x, b.y)
        got = np.array([e.time for e in hits(events, b.id)])
        assert len(got) == len(ref) > 10
        assert np.max(np.abs(got - ref)) < 1e-6  # 1 us


def test_turning_changes_the_beams_world_speed():
    # the seeds' "speed changes while turning": spinning in place at rate w, the same beacon
    # comes round every 2 pi / (omega + w), though the laser's own speed never changed
    w = make(omega=20.0)
    track = w.level.robots[0].model.track
    (events,), _ = sense(w, 4.0, commands=[(-0.4, 0.4)])
    spin = 0.8 / track
    times = np.array([e.time for e in hits(events, "P")])
    gaps = np.diff(times[times > 1.0])  # after the wheels have ramped up
    assert np.allclose(gaps, 2 * math.pi / (20.0 + spin), rtol=2e-3)
    index = np.diff([e.time for e in events if e.kind == "index"])
    assert np.allclose(index, 2 * math.pi / 20.0)  # the index is on the body: unchanged


def test_another_robot_blocks_the_beam():
    # robot 1 stands on the line from robot 0 to beacon P
    w = make(robots=TWO)
    p0 = w.level.robots[0].start
    b = w.level.beacons.by_id("P")
    r1 = w.level.robots[1].start
    cross = (b.x - p0.x) * (r1.y - p0.y) - (b.y - p0.y) * (r1.x - p0.x)
    assert abs(cross) / math.dist((p0.x, p0.y), (b.x, b.y)) < 0.04  # within its half-width
    events, _ = sense(w, 3.0)
    assert hits(events[0], "P") == [] and len(hits(events[0], "Q")) >= 9
    # move it aside: the beam gets through
    w = make(robots=ONE + "\n  - {model: boe-bot, start: [0.95, 1.75, 0]}")
    events, _ = sense(w, 3.0)
    assert len(hits(events[0], "P")) >= 9


def test_a_robot_crossing_the_beam_blocks_it_for_the_right_time():
    # robot 1 drives north across the line from robot 0 to beacon Q. At every expected
    # crossing, the truth comes from sampling the beam segment densely against robot 1's
    # silhouette in the laser plane (a circle of the model's silhouette radius at its centre).
    w = make(omega=60.0, robots=ONE + "\n  - {model: boe-bot, start: [2.7, 0.5, 90]}")
    events, poses = sense(w, 8.0, commands=[(0, 0), (0.15, 0.15)])
    p0 = w.level.robots[0].start
    q = w.level.beacons.by_id("Q")
    m = w.level.robots[1].model
    times = np.array([e.time for e in hits(events[0], "Q")])
    period = 2 * math.pi / 60.0
    u = np.linspace(0, 1, 4001)
    end = 1 - w.level.beacons.radius / math.dist((p0.x, p0.y), (q.x, q.y))
    sx, sy = p0.x + u * end * (q.x - p0.x), p0.y + u * end * (q.y - p0.y)
    blocked_seen = 0
    for k in range(int((8.0 - times[0]) / period)):
        t = times[0] + k * period
        i = int(t / w.dt)
        f = t / w.dt - i
        x, y, _ = poses[i, 1] + f * (poses[i + 1, 1] - poses[i, 1])
        margin = m.silhouette_radius - np.min(np.hypot(sx - x, sy - y))
        if abs(margin) < 1e-3:
            continue  # grazing: the beam skims the silhouette, either answer is right
        truly_blocked = margin > 0
        seen = np.any(np.abs(times - t) < 1e-4)
        assert seen != truly_blocked, f"t={t:.4f}: blocked={truly_blocked} but seen={seen}"
        blocked_seen += truly_blocked
    assert blocked_seen >= 3  # the crossing robot did block a few sweeps


def test_obstacle_blocks_the_beam():
    w = make(obstacles="obstacles:\n  - {kind: circle, center: [1.0, 0.8], radius: 0.1}")
    (events,), _ = sense(w, 3.0)
    assert hits(events, "P") == [] and len(hits(events, "R")) >= 9


def test_only_the_silhouette_at_beam_height_blocks():
    # robot 1's footprint (105 x 95 mm) straddles the line from robot 0 to P, 35 mm from its
    # centre; its silhouette in the laser plane (a 20 mm mast) does not reach the line
    p0, b = (1.7, 1.2), (0.2, 0.3)
    n = np.array([b[1] - p0[1], p0[0] - b[0]]) / math.dist(p0, b)  # unit normal to the line
    centre = np.array([0.95, 0.75]) + 0.035 * n
    start = f"[{centre[0]:.6f}, {centre[1]:.6f}, 0]"
    w = make(robots=ONE + f"\n  - {{model: boe-bot, start: {start}}}")
    m = w.level.robots[1].model
    rel = np.array([0.95, 0.75]) - centre
    assert abs(rel[0]) < m.length / 2 and abs(rel[1]) < m.width / 2  # the line crosses the footprint
    assert m.silhouette_radius < 0.035
    events, _ = sense(w, 3.0)
    assert len(hits(events[0], "P")) >= 9
    # a level may give a model a wider silhouette (a tall housing): then it blocks
    w = make(robots=ONE + f"\n  - {{model: boe-bot, start: {start}, silhouette: 0.04}}")
    events, _ = sense(w, 3.0)
    assert hits(events[0], "P") == [] and len(hits(events[0], "Q")) >= 9


def test_the_laser_lags_when_the_body_starts_turning():
    # Bac: "the laser angular velocity was not constant while the robot turned". The rotor
    # keeps its world rate when the body starts to spin, then the motor restores its relative
    # rate (time constant tau) to omega - c x body rate: the beam's world rate ends at
    # omega + (1 - c) x body rate.
    omega, c, tau = 20.0, 0.5, 0.05
    params = f"  params: {{spin_coupling: {c}, spin_time: {tau}}}"
    w = make(params=params)
    (events,), poses = sense(w, 4.0, commands=[(-0.2, 0.2)], ideal=False)
    spin = poses[-1, 0, 2] - poses[-241, 0, 2]  # rad/s over the last second (steady by then)
    times = np.array([e.time for e in hits(events, "P")])
    gaps = np.diff(times[times > 2.0])
    assert np.allclose(gaps, 2 * math.pi / (omega + (1 - c) * spin), rtol=2e-3)
    (ideal,), _ = sense(make(params=params), 4.0, commands=[(-0.2, 0.2)], ideal=True)
    times = np.array([e.time for e in hits(ideal, "P")])
    assert np.allclose(np.diff(times[times > 2.0]), 2 * math.pi / (omega + spin), rtol=2e-3)


def test_first_order_closed_form_matches_the_recursion():
    from arena.sensing.spin import first_order

    rng = np.random.default_rng(3)
    y0, drive = np.array([0.4, -1.0]), rng.normal(size=(50, 2))
    for a in (0.93, 0.5):
        want, y = [], y0.copy()
        for k in range(50):
            y = a * y + drive[k]
            want.append(y.copy())
        powers = np.ascontiguousarray(np.broadcast_to(a ** np.arange(1, 51)[:, None], drive.shape))
        assert np.allclose(first_order(a, powers, y0, drive), want, rtol=1e-9, atol=1e-12)
        # without powers (a time constant so short that a^k underflows), the recursion itself
        assert np.array_equal(first_order(a, np.zeros((0, 0)), y0, drive), np.array(want))


@pytest.mark.parametrize("omega", [20.0, -81.0])
def test_a_beam_beside_the_axis_meets_each_beacon_earlier_by_its_range(omega):
    """A beam passing d beside the spin axis (to its left) is tangent to a circle of radius d:
    it meets a beacon at range R when its direction is the bearing minus asin(d / R), so each
    crossing moves by asin(d / R) / |omega| (earlier when spinning counter-clockwise)."""
    from helpers import edited

    d = 0.01
    text = TABLE.format(kind="sensor_array", omega=omega, robots=ONE, params="  params: {clock_hz: 0}", obstacles="")
    w = World(parse_level(edited(text, {"laser.beam_offset": d}).encode(), "t.yaml"))
    (events,), _ = sense(w, 3.0, ideal=False)
    start = w.level.robots[0].start
    spin = math.copysign(1, omega)
    for b in w.level.beacons.items:
        r = math.hypot(b.x - start.x, b.y - start.y)
        direction = math.atan2(b.y - start.y, b.x - start.x) - math.asin(d / r)
        first = ((direction - start.heading) * spin) % (2 * math.pi) / abs(omega)
        got = hits(events, b.id)[0].time
        assert got == pytest.approx(first, abs=1e-7)
    (ideal,), _ = sense(World(parse_level(edited(text, {"laser.beam_offset": d}).encode(), "t.yaml")), 3.0)
    centred = [e.time for e in hits(ideal)]
    assert [e.time for e in hits(events)] != pytest.approx(centred, abs=1e-7)  # ideal hardware has no offset
