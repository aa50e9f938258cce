"""Differential drive against analytic kinematics, and contacts against geometry."""

import math

import pytest

from arena.loader import parse_level
from arena.world import World
from conftest import MINI_LEVEL

BIG = MINI_LEVEL.replace("size: [2.0, 1.0]", "size: [4.0, 4.0]").replace(
    "start: [0.5, 0.5, 0]", "start: [2.0, 2.0, 0]")


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


PUSH = BIG.replace("""robots:
  - model: boe-bot
    start: [2.0, 2.0, 0]
    start_known: true
""", """robots:
  - model: generic
    start: [1.0, 2.0, 0]
  - model: boe-bot
    start: [1.6, 2.0, 0]
""")


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
    text = PUSH.replace("model: generic", "model: boe-bot")
    w = world(text)
    w.command(0, 0.17, 0.17)
    w.command(1, -0.17, -0.17)
    run(w, 5.0)
    assert abs(w.pose(0).x - w.pose(1).x) == pytest.approx(0.105, abs=0.01)


def test_box_and_circle_obstacles_stop_a_robot():
    for obstacle, face in (("{kind: box, center: [3.0, 2.0], size: [0.2, 1.0], angle: 0}", 2.9),
                           ("{kind: circle, center: [3.0, 2.0], radius: 0.1}", 2.9)):
        w = world(BIG.replace("beacons:", f"obstacles:\n  - {obstacle}\nbeacons:"))
        w.command(0, 0.17, 0.17)
        run(w, 15.0)  # 2.5 m of travel if nothing were in the way
        front = w.pose(0).x + w.level.robots[0].model.length / 2
        assert front == pytest.approx(face, abs=0.005)
