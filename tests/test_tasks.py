"""Task progress helpers checked against geometry."""

import math
import random

import numpy as np
import pytest
from helpers import variant
from msgspec import UNSET

from levels.yaml_reader import ReadError
from referee.match.tasks import TaskTracker


def tracker_along(level, path):
    """A tracker of `level` whose robots' targets are `path`, from the start."""

    class Along(TaskTracker):
        def targets(self, slot):
            return tuple(path)

    return Along(level)


def test_still_to_travel_never_exceeds_a_path_that_finishes():
    # any path that comes within the radius of each target in order is at least as long
    rng = random.Random(7)
    level = variant("asabe", task__radius=0.1)
    for _ in range(300):
        path = [(rng.uniform(0, 1.8), rng.uniform(0, 1.2)) for _ in range(rng.randint(1, 5))]
        tracker = tracker_along(level, path)
        x, y = rng.uniform(0, 1.8), rng.uniform(0, 1.2)
        bound = tracker.still_to_travel(0, x, y)
        for _ in range(20):
            points = [(x, y)]
            for tx, ty in path:
                a, r = rng.uniform(0, 2 * math.pi), 0.1 * math.sqrt(rng.random())
                points.append((tx + r * math.cos(a), ty + r * math.sin(a)))
            length = sum(math.dist(p, q) for p, q in zip(points, points[1:]))
            assert bound <= length + 1e-12


def test_still_to_travel_by_hand():
    level = variant("asabe", task__radius=0.1)
    tracker = tracker_along(level, ((1.0, 0.0), (1.0, 1.0), (1.0, 0.05)))
    assert math.isclose(tracker.still_to_travel(0, 0.0, 0.0), 0.9 + 0.8 + 0.75)
    tracker.next[0] = 1  # the first reached: to the second, then the last leg
    assert math.isclose(tracker.still_to_travel(0, 1.0, 0.0), 0.9 + 0.75)
    tracker.next[0] = 2  # the last target only, the robot within its radius: nothing left to travel
    assert tracker.still_to_travel(0, 1.0, 0.0) == 0.0
    tracker.next[0] = 3
    assert tracker.still_to_travel(0, 5.0, 5.0) == 0.0


# ---- a goto arrival is a stop ---------------------------------------------------------------

FT = 0.3048


def goto_tracker(**changes):
    """A tracker of vannoy (goal (1, 10.5) ft, radius 1 ft, accuracy 0.1 ft, settle 1 s)."""
    level = variant("vannoy", **changes)
    return level, TaskTracker(level)


def test_passing_through_the_goal_earns_nothing():
    level, tracker = goto_tracker()
    gx, gy = level.task.goal.x, level.task.goal.y
    for i in range(201):  # straight through the goal's centre, never standing
        x = gx - FT + i * 0.01 * FT
        tracker.update(0, x, gy, i * 0.05)
        tracker.stand(0, False, x, gy, i * 0.05)
    assert not tracker.done(0) and tracker.progress(0) == 0.0


def test_a_stop_inside_arrives_after_settle_and_earns_by_its_distance():
    level, tracker = goto_tracker()
    gx, gy = level.task.goal.x, level.task.goal.y
    d = 0.25 * FT  # a stop a quarter foot from the centre
    for tick in range(100):  # still from t = 2.0 s on, checked every 50 ms
        t = 2.0 + tick * 0.05
        tracker.stand(0, True, gx + d, gy, t)
        if tracker.done(0):
            break
    assert tracker.finished[0] == 3.0  # one second after the first still tick
    assert math.isclose(tracker.progress(0), 1 / (1 + 0.25 / 0.1))  # d / accuracy = 2.5
    assert math.isclose(tracker.final_distance[0], d)


def test_moving_again_restarts_the_stand_and_outside_the_radius_never_arrives():
    level, tracker = goto_tracker()
    gx, gy = level.task.goal.x, level.task.goal.y
    tracker.stand(0, True, gx, gy, 0.0)
    tracker.stand(0, True, gx, gy, 0.95)
    tracker.stand(0, False, gx, gy, 1.0)  # the wheels turn again (pushing a wall: the robot need not move)
    tracker.stand(0, True, gx, gy, 1.05)
    tracker.stand(0, True, gx, gy, 2.0)
    assert not tracker.done(0)
    tracker.stand(0, True, gx, gy, 2.05)
    assert tracker.finished[0] == 2.05 and tracker.progress(0) == 1.0
    level, tracker = goto_tracker()
    for tick in range(200):  # standing a hair outside the radius for 10 s
        tracker.stand(0, True, gx + 1.0001 * FT, gy, tick * 0.05)
    assert not tracker.done(0) and tracker.progress(0) == 0.0


def test_a_level_sets_settle_and_accuracy_and_other_tasks_refuse_them():
    level, tracker = goto_tracker(task__settle=2.5, task__accuracy=0.5)
    assert level.task.settle == 2.5 and math.isclose(level.task.accuracy, 0.5 * FT)
    gx, gy = level.task.goal.x, level.task.goal.y
    for tick in range(51):
        tracker.stand(0, True, gx + 0.5 * FT, gy, tick * 0.05)
    assert tracker.finished[0] == 2.5 and math.isclose(tracker.progress(0), 0.5)  # d = accuracy: half
    with pytest.raises(ReadError, match="task.settle.*not used by a waypoints task"):
        variant("asabe", task__settle=1)
    with pytest.raises(ReadError, match="task.accuracy.*not used by a localize task"):
        variant("bac-static", task__accuracy=1)


# ---- a waypoint is worth its leg's distance from the path ----------------------------------

LINE_Y = 0.61  # bac-line's path: x = 0.45, 0.55, ..., 1.35 on y = 0.61; its nominal start (0.40, 0.61)


def test_a_leg_run_at_the_seeds_deviation_earns_half():
    """bac-line sets accuracy 3.6 mm, the seed's deviation from the straight path. A robot run
    parallel to the line 3.6 mm off it, sampled every 5 mm, reaches each waypoint 3.6 mm off: every
    leg's RMS is 3.6 mm, so every waypoint earns 1 / (1 + 1) = half."""
    level = variant("bac-line")
    assert level.task.accuracy == pytest.approx(0.0036)
    tracker = TaskTracker(level)
    y = LINE_Y + 0.0036
    for i in range(1, 200):
        x = 0.40 + 0.005 * i
        tracker.update(0, x, y, i * 0.05)
        if not tracker.done(0):
            tracker.sample(0, tracker.polyline[0].distances([x], [y])[0])
    assert tracker.done(0)
    assert tracker.worth(0) == pytest.approx([0.5] * 10, abs=1e-9)
    assert tracker.progress(0) == pytest.approx(0.5, abs=1e-9)
    assert tracker.summary(0).worth == tracker.worth(0)


def test_a_legs_worth_by_hand():
    """Two samples on the first leg, 3 and 4 mm off, then the waypoint reached 0 mm off: e =
    sqrt((9 + 16 + 0) / 3) mm; the next leg's sample counts for it alone."""
    tracker = TaskTracker(variant("bac-line"))
    tracker.sample(0, 0.003)
    tracker.sample(0, 0.004)
    tracker.update(0, 0.45, LINE_Y, 1.0)  # on the first waypoint, on the line
    tracker.sample(0, 0.012)  # after it: the second leg's
    e = math.sqrt((0.003**2 + 0.004**2) / 3)
    assert tracker.worth(0) == [pytest.approx(1 / (1 + e / 0.0036), rel=1e-12)]
    tracker.update(0, 0.55, LINE_Y + 0.012, 2.0)  # the second, 12 mm off
    assert tracker.worth(0)[1] == pytest.approx(1 / (1 + 0.012 / 0.0036), rel=1e-12)
    assert tracker.progress(0) == pytest.approx(sum(tracker.worth(0)) / 10, rel=1e-12)


def test_without_an_accuracy_every_waypoint_counts_whole():
    tracker = TaskTracker(variant("asabe"))
    for x, y in tracker.targets(0)[:3]:
        tracker.update(0, x + 0.04, y, 1.0)  # 4 cm off each
    assert tracker.worth(0) == [1.0, 1.0, 1.0] and tracker.summary(0).worth is UNSET


def test_a_batch_weighs_the_legs_as_single_steps_do():
    """`advance` over a run of states gives each leg the same samples (one every `every` steps,
    each on the leg to the first waypoint not reached by its step) as `update` and `sample` step
    by step: the same worth to the bit, over runs cut at random places."""
    rng = random.Random(3)
    level = variant("bac-line")
    n, every = 2000, 12
    xs = [0.40 + 1.0 * i / n for i in range(1, n + 1)]
    ys = [LINE_Y + 0.006 * math.sin(i / 37) + rng.uniform(-0.002, 0.002) for i in range(1, n + 1)]
    states = np.zeros((n, 3))
    states[:, 0], states[:, 1] = xs, ys
    single = TaskTracker(level)
    for i in range(n):
        tick = i + 1
        single.update(0, xs[i], ys[i], tick / 240)
        if tick % every == 0 and not single.done(0):
            single.sample(0, single.polyline[0].distances([xs[i]], [ys[i]])[0])
    batched = TaskTracker(level)
    at = 0
    while at < n:
        size = rng.randint(1, 150)
        batched.advance(states[at : at + size], at + 1, 240, every)
        at += size
    assert single.done(0) and batched.done(0)
    assert batched.reached_at[0] == single.reached_at[0]
    assert batched.deviation[0] == single.deviation[0]
    assert batched.worth(0) == single.worth(0)
    assert 0.2 < min(single.worth(0)) and max(single.worth(0)) < 0.9  # the wiggle costs, and differs by leg


def test_the_worked_example_of_docs_rules():
    """docs/rules.md, Following the path: a leg sampled 2, 4 and 5 mm off and reached 4 mm off is
    worth 0.48 of its 10 points; a robot set down on the line 2 deg off its heading, driving
    blind, reaches 9 waypoints worth 29 task points, where counting them whole gives 90."""
    tracker = TaskTracker(variant("bac-line"))
    tracker.update(0, 0.45, LINE_Y, 1.0)
    tracker.update(0, 0.55, LINE_Y, 2.0)
    for mm in (2, 4, 5):
        tracker.sample(0, mm / 1000)
    tracker.update(0, 0.65, LINE_Y + 0.004, 3.0)
    assert round(10 * tracker.worth(0)[2], 1) == 4.8
    blind = TaskTracker(variant("bac-line"))
    slope = math.tan(math.radians(2))
    for i in range(1, 20001):  # 1.0 m in 0.05 mm steps, sampled every 0.5 mm
        x = 0.40 + i * 0.00005
        y = LINE_Y + (x - 0.40) * slope
        blind.update(0, x, y, i / 1000)
        if i % 10 == 0:
            blind.sample(0, blind.polyline[0].distances([x], [y])[0])
    assert blind.next[0] == 9
    # analytically: the robot is (x - 0.40) tan 2 deg off the line; it reaches waypoint k where it
    # comes within 3 cm of it, and a leg's RMS is that of a ramp between two such reach points
    ends, worth = [0.40], []
    for wx, _ in blind.targets(0)[:9]:  # every waypoint on the line
        # (x - wx)^2 + ((x - 0.40) slope)^2 = 0.03^2, the smaller root
        a, b, c = 1 + slope**2, -2 * wx - 0.80 * slope**2, wx**2 + (0.40 * slope) ** 2 - 0.03**2
        ends.append((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a))
        u, v = ends[-2] - 0.40, ends[-1] - 0.40
        worth.append(1 / (1 + slope * math.sqrt((u * u + u * v + v * v) / 3) / 0.0036))
    assert blind.worth(0) == pytest.approx(worth, abs=0.005)
    assert [round(w, 2) for w in blind.worth(0)][:4] == [0.9, 0.57, 0.37, 0.27]  # as docs/rules.md says
    assert round(100 * blind.progress(0)) == round(10 * sum(worth)) == 29
