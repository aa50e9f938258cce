"""Differential drive against analytic kinematics, and contacts against geometry."""

import dataclasses
import itertools
import math
import statistics

import pytest
from helpers import MINI_LEVEL, edited, exact_starts, variant

from arena.rng import RandomTree
from arena.world import World
from levels.loader import parse_level
from levels.model import DriveErrors, Pose
from referee.match.loop import play_match
from referee.match.simulation import Simulation
from referee.sandbox.teams import resolve

BIG = edited(MINI_LEVEL, {"field.size": [4.0, 4.0], "robots.0.start": [2.0, 2.0, 0]})


def world(text=BIG):
    return World(parse_level(text.encode(), "test.yaml"))


def run(w, seconds):
    for _ in range(round(seconds * w.level.physics_rate)):
        w.step()


def test_straight_line_matches_ramped_kinematics():
    w = world()
    m = w.level.robots[0].model
    v, T = 0.1, 5.0
    w.command(0, v, v)
    run(w, T)
    ramp = v / m.max_wheel_accel
    expected = v * T - v * ramp / 2  # distance lost while accelerating from rest
    p = w.pose(0)
    assert p.x - 2.0 == pytest.approx(expected, abs=v * w.dt)  # within one physics step of travel
    assert abs(p.y - 2.0) < 1e-9 and abs(p.heading) < 1e-9


def test_spin_in_place_turns_at_2v_over_track():
    w = world()
    m = w.level.robots[0].model
    v, T = 0.05, 3.0
    w.command(0, -v, v)
    run(w, T)
    rate = 2 * v / m.track
    ramp = v / m.max_wheel_accel
    turned = rate * (T - ramp / 2)
    p = w.pose(0)
    assert math.remainder(p.heading - turned, 2 * math.pi) == pytest.approx(0, abs=rate * w.dt)
    assert math.dist((p.x, p.y), (2.0, 2.0)) < 1e-6


def test_arc_radius_matches_wheel_speed_ratio():
    w = world()
    m = w.level.robots[0].model
    vl, vr = 0.06, 0.12
    w.command(0, vl, vr)
    run(w, 1.0)  # past the ramp
    radius = m.track / 2 * (vr + vl) / (vr - vl)
    p = w.pose(0)
    center = (p.x - radius * math.sin(p.heading), p.y + radius * math.cos(p.heading))
    for _ in range(20):
        run(w, 0.25)
        q = w.pose(0)
        assert math.dist((q.x, q.y), center) == pytest.approx(radius, abs=1e-3)


def test_wheel_commands_clipped_to_model_limit():
    w = world()
    top = w.level.robots[0].model.max_wheel_speed
    w.command(0, 10.0, 10.0)
    run(w, 2.0)
    body = w.bodies[0]
    assert body.velocity.length == pytest.approx(top, rel=1e-6)


def test_robot_cannot_leave_through_a_wall():
    w = world(MINI_LEVEL)
    w.command(0, 0.17, 0.17)  # straight at the east wall, 1.5 m away
    run(w, 20.0)
    f, m = w.level.field, w.level.robots[0].model
    for v in w.shapes[0].get_vertices():
        x, y = w.bodies[0].local_to_world(v)
        assert f.xmin - 1e-3 <= x <= f.xmax + 1e-3 and f.ymin - 1e-3 <= y <= f.ymax + 1e-3
    assert w.pose(0).x > f.xmax - m.length / 2 - 0.01  # it got there and stopped


PUSH = edited(
    BIG, {"robots": [{"model": "generic", "start": [1.0, 2.0, 0]}, {"model": "boe-bot", "start": [1.6, 2.0, 0]}]}
)


def penetration(a, b):
    """Overlap depth of two convex polygons by the separating-axis theorem (<= 0: apart)."""
    depth = math.inf
    for poly in (a, b):
        for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]):
            nx, ny = y1 - y0, x0 - x1
            n = math.hypot(nx, ny)
            pa = [(x * nx + y * ny) / n for x, y in a]
            pb = [(x * nx + y * ny) / n for x, y in b]
            depth = min(depth, min(max(pa), max(pb)) - max(min(pa), min(pb)))
    return depth


def corners(w, slot):
    body = w.bodies[slot]
    return [tuple(body.local_to_world(v)) for v in w.shapes[slot].get_vertices()]


def test_heavy_robot_pushes_a_light_one_and_they_never_overlap():
    w = world(PUSH)
    w.command(0, 0.3, 0.3)
    w.command(1, 0.0, 0.0)
    deepest = -math.inf
    for _ in range(5 * 240):
        w.step()
        deepest = max(deepest, penetration(corners(w, 0), corners(w, 1)))
    assert -1e-3 < deepest < 0.005  # they touched, and never overlapped deeply
    assert w.pose(1).x > 1.6 + 0.5  # the light robot was pushed well along
    assert w.pose(0).x > 1.0 + 0.5


def test_equal_robots_stall_head_on():
    text = edited(PUSH, {"robots.0.model": "boe-bot"})
    w = world(text)
    w.command(0, 0.17, 0.17)
    w.command(1, -0.17, -0.17)
    run(w, 5.0)
    assert abs(w.pose(0).x - w.pose(1).x) == pytest.approx(0.105, abs=0.01)


def test_box_and_circle_obstacles_stop_a_robot():
    for obstacle, face in (
        ({"kind": "box", "center": [3.0, 2.0], "size": [0.2, 1.0], "angle": 0}, 2.9),
        ({"kind": "circle", "center": [3.0, 2.0], "radius": 0.1}, 2.9),
    ):
        w = world(edited(BIG, {"obstacles": [obstacle]}))
        w.command(0, 0.17, 0.17)
        run(w, 15.0)  # 2.5 m of travel if nothing were in the way
        front = w.pose(0).x + w.level.robots[0].model.length / 2
        assert front == pytest.approx(face, abs=0.005)


# ---- the drive error model (docs/drive.md) ------------------------------------------------

PERFECT = {f.name: 0.0 for f in dataclasses.fields(DriveErrors)}


def erring(seed=1, text=BIG, **errors):
    """A world whose robot 0 has exactly the given drive errors (the rest zero), seeded."""
    text = edited(text, {"robots.0.drive": {**PERFECT, **errors}})
    return World(parse_level(text.encode(), "test.yaml"), RandomTree(seed))


def test_gain_mismatch_drives_the_arc_kinematics_predicts():
    # equal commands, unequal wheels: R = (track/2)(vr+vl)/(vr-vl) with the wheels' true speeds
    w = erring(seed=2, gain_sd=0.03)
    m = w.level.robots[0].model
    gl, gr = w.drives[0].gains
    assert abs(gr - gl) > 0.03  # a real mismatch to measure (this seed draws one)
    v = 0.1
    vl, vr = gl * v, gr * v
    w.command(0, v, v)
    run(w, 1.0)  # past the ramp
    radius = m.track / 2 * (vr + vl) / (vr - vl)
    p = w.pose(0)
    center = (p.x - radius * math.sin(p.heading), p.y + radius * math.cos(p.heading))
    for _ in range(8):
        run(w, 0.25)
        q = w.pose(0)
        assert math.dist((q.x, q.y), center) == pytest.approx(abs(radius), rel=2e-3)


def test_wheel_gains_spread_as_configured():
    # each wheel's gain ~ N(1, gain_sd): the sample sd of 2 x 150 draws lies within a
    # 4-sigma band of the sample-sd distribution (sd of the sd ~ sigma / sqrt(2n))
    sigma, n = 0.03, 150
    gains = [g for s in range(n) for g in erring(seed=s, gain_sd=sigma).drives[0].gains]
    sd = statistics.stdev(gains)
    assert abs(statistics.mean(gains) - 1) < 4 * sigma / math.sqrt(2 * n)
    assert abs(sd - sigma) < 4 * sigma / math.sqrt(2 * 2 * n)


def test_true_track_sets_the_spin_rate():
    # a spin turns at (vr - vl) / true track, not at the nominal track the team is told
    w = erring(seed=10, track_sd=0.05)
    nominal, true = w.level.robots[0].model.track, w.drives[0].track
    assert abs(true / nominal - 1) > 0.03  # this seed draws a clear error
    v, T = 0.05, 2.0
    w.command(0, -v, v)
    run(w, T)
    w.command(0, 0.0, 0.0)
    run(w, 1.0)
    turned = 2 * v * T / true  # the ramp down gives back what the ramp up lost
    assert w.pose(0).heading == pytest.approx(math.remainder(turned, 2 * math.pi), abs=2 * v / true * w.dt)


def test_dead_band_swallows_small_commands():
    w = erring(dead_band=0.1)
    top = w.level.robots[0].model.max_wheel_speed
    w.command(0, 0.09 * top, -0.09 * top)
    run(w, 2.0)
    assert w.pose(0) == Pose(2.0, 2.0, 0.0)
    w.command(0, 0.2 * top, 0.2 * top)  # above the band: moves
    run(w, 2.0)
    assert w.pose(0).x > 2.0 + 0.01


def test_servo_response_curve_sets_the_cruise_speed():
    # a command c above the dead band d (fractions of top speed) gives
    # top * tanh(s u) / tanh(s) with u = (c - d) / (1 - d)
    d, s, c = 0.05, 0.8, 0.5
    w = erring(dead_band=d, saturation=s)
    top = w.level.robots[0].model.max_wheel_speed
    w.command(0, c * top, c * top)
    run(w, 1.0)
    u = (c - d) / (1 - d)
    expected = top * math.tanh(s * u) / math.tanh(s)
    assert w.bodies[0].velocity.length == pytest.approx(expected, rel=1e-6)
    assert expected > c * top  # the servo runs ahead of a linear model at mid range


def test_latency_delays_the_motion_by_its_ticks():
    # with a fixed latency the whole trajectory is the prompt one, shifted by exactly its ticks
    latency = 0.05
    late, prompt = erring(latency=latency), erring()
    delay = round(latency * late.level.physics_rate)  # 12 ticks at 240 Hz
    for w in (late, prompt):
        w.command(0, 0.06, 0.1)
    xs_late, xs_prompt = [], []
    for _ in range(120):
        late.step()
        prompt.step()
        xs_late.append(late.state)
        xs_prompt.append(prompt.state)
    assert all(s == (2.0, 2.0, 0.0) for s in xs_late[:delay])  # the command is still on its way
    assert xs_late[delay:] == xs_prompt[:-delay]


def test_jittered_commands_arrive_in_order_within_the_latency_window():
    latency, jitter = 0.02, 0.03
    w = erring(seed=4, latency=latency, latency_jitter=jitter)
    rate = w.level.physics_rate
    lo, hi = round(latency * rate), round((latency + jitter) * rate)
    taken = []
    for k in range(40):
        w.command(0, 0.001 * (k + 1), 0.001 * (k + 1))
        sent = w.tick
        while w.drives[0].commanded != (0.001 * (k + 1),) * 2:
            w.step()
            assert w.tick - sent <= hi + 1
        taken.append(w.tick - 1 - sent)  # the update at tick t-1 took it
        run(w, 0.1)
    assert all(lo <= t <= hi for t in taken), taken
    assert len(set(taken)) > 3  # the jitter really varies


def spin_ratios(seed, turns, **errors):
    """Achieved over commanded angle for `turns` separate spin commands."""
    w = erring(seed=seed, **errors)
    track = w.level.robots[0].model.track
    v, T = 0.05, 1.0
    ratios = []
    for _ in range(turns):
        before = w.state[2]
        w.command(0, -v, v)
        run(w, T)
        w.command(0, 0.0, 0.0)
        run(w, 0.5)
        ratios.append((w.state[2] - before) / (2 * v * T / track))
    return ratios


def test_spin_slip_loses_the_configured_fraction_in_expectation():
    slip, sd, n = 0.1, 0.05, 40
    ratios = spin_ratios(3, n, turn_slip=slip, turn_slip_sd=sd)
    # the mean of n draws of 1 - slip lies within 4 standard errors of 1 - slip
    assert statistics.mean(ratios) == pytest.approx(1 - slip, abs=4 * sd / math.sqrt(n))
    assert statistics.stdev(ratios) == pytest.approx(sd, rel=0.5)  # random per turn


def test_acceleration_slip_lengthens_the_ramp():
    slip = 0.2
    w = erring(accel_slip=slip)
    m = w.level.robots[0].model
    v, T = 0.1, 3.0
    w.command(0, v, v)
    run(w, T)
    ramp = v / (m.max_wheel_accel * (1 - slip))
    assert w.pose(0).x - 2.0 == pytest.approx(v * T - v * ramp / 2, abs=v * w.dt)


def straight_run(seed):
    w = World(parse_level(BIG.encode(), "test.yaml"), RandomTree(seed))  # the boe-bot's own errors
    w.command(0, 0.12, 0.12)
    run(w, 4.0)
    w.command(0, -0.08, 0.08)
    run(w, 2.0)
    return w.state


def test_seeds_drift_differently_and_each_reproduces_exactly():
    runs = {s: straight_run(s) for s in (1, 2, 3)}
    assert straight_run(2) == runs[2]  # same seed, bit for bit
    ends = [(x, y) for x, y, _ in runs.values()]
    assert min(math.dist(a, b) for a, b in itertools.combinations(ends, 2)) > 1e-3
    ideal = world()
    ideal.command(0, 0.12, 0.12)
    run(ideal, 4.0)
    for _x, y, _ in runs.values():
        assert abs(y - 2.0) > 1e-4  # no seed drives the perfect straight line


def test_ideal_match_drives_perfectly_and_a_real_one_does_not():
    # Match plumbing: ideal gives today's perfect drive (the analytic line of the first test)
    level = parse_level(BIG.encode(), "test.yaml")
    for ideal in (True, False):
        w = Simulation(level, ["idle"], seed=7, ideal=ideal).world
        m = level.robots[0].model
        v, T = 0.1, 5.0
        w.command(0, v, v)
        run(w, T)
        expected = v * T - v * (v / m.max_wheel_accel) / 2
        p = w.pose(0)
        on_line = abs(p.x - 2.0 - expected) < v * w.dt and abs(p.y - 2.0) < 1e-9 and abs(p.heading) < 1e-9
        assert on_line == ideal


def test_blind_dead_reckoning_drifts_on_the_asabe_letters():
    # ~15 m of path: a wheel-gain difference of about 1 % alone turns the heading by
    # 0.01 * 15 / 0.105 ~ 1.4 rad over the run, so the blind estimate must be off by tens of
    # centimetres, differently per seed; with a perfect drive it stays within a centimetre
    level = variant("asabe", **exact_starts("asabe"))  # the drive's errors alone: set down exactly at the start
    drifts = []
    for seed in (1, 2):
        loc = play_match(level, [resolve("ref:dead-reckoning")], seed=seed, isolate=False)["robots"][0]["localization"]
        drifts.append(loc["position_rms"])
    assert min(drifts) > 0.1 and drifts[0] != drifts[1]
    ideal = play_match(level, [resolve("ref:dead-reckoning")], seed=1, isolate=False, ideal=True)
    assert ideal["robots"][0]["localization"]["position_rms"] < 0.01


def test_dead_reckoning_integrates_the_ramped_wheels_exactly():
    """ref:dead-reckoning's model of a control period (wheels ramping at the top acceleration to
    their commands, then holding them) against the same model integrated in 100,000 small steps,
    from rest, reversing, mid-ramp and at speed: within 1e-8 m and 1e-9 rad (a fixed 20-step
    scheme with the ramp taken per step was off by up to 0.5 mm and 0.01 rad a period)."""
    import math
    from types import SimpleNamespace

    from robots.controllers.dead_reckoning import DeadReckoning

    robot = SimpleNamespace(track=0.105, max_wheel_accel=0.5, max_wheel_speed=0.3)
    dr = DeadReckoning()
    dr.brief = SimpleNamespace(control_period=0.2, robot=robot)
    cases = [
        ((0.0, 0.0), (0.2, 0.25)),
        ((0.2, -0.1), (-0.2, 0.2)),
        ((0.05, 0.05), (0.3, -0.3)),
        ((0.1, 0.2), (0.1, 0.2)),
    ]
    for wheels, (left, right) in cases:
        dr.wheels, start = wheels, (0.3, 0.7, 2.9)
        dr._integrate(start, left, right)
        n = 100_000
        dt = 0.2 / n
        x, y, h = start
        wl, wr = wheels
        for k in range(n):  # the midpoint of each small step, the speeds exactly ramped there
            t = (k + 0.5) * dt
            sl = left if abs(left - wl) <= 0.5 * t else wl + math.copysign(0.5 * t, left - wl)
            sr = right if abs(right - wr) <= 0.5 * t else wr + math.copysign(0.5 * t, right - wr)
            v, w = (sl + sr) / 2, (sr - sl) / 0.105
            x += v * math.cos(h + w * dt / 2) * dt
            y += v * math.sin(h + w * dt / 2) * dt
            h += w * dt
        assert math.dist(dr.pose[:2], (x, y)) < 1e-8
        assert abs(math.remainder(dr.pose[2] - h, 2 * math.pi)) < 1e-9
        reached = [g if abs(g - w) <= 0.1 else w + math.copysign(0.1, g - w) for w, g in ((wl, left), (wr, right))]
        assert dr.wheels == pytest.approx(reached, abs=1e-15)  # 0.5 m/s^2 for 0.2 s: 0.1 m/s at most
