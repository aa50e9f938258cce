"""Task progress helpers checked against geometry."""

import math
import random

from helpers import variant

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
