"""Task progress helpers checked against geometry."""

import math
import random

import pytest
from helpers import variant

from arena.yaml_reader import ReadError
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
    for key in ("settle", "accuracy"):
        with pytest.raises(ReadError, match=f"task.{key}.*not used by a waypoints task"):
            variant("asabe", **{f"task__{key}": 1})
