"""Task progress: which waypoints each robot has reached, whether it arrived at its goal, when,
and how far it strayed from the ideal path. Checked against the true pose; scoring of the
progress is in referee/match/scoring.py and docs/rules.md.

A waypoint is reached the moment the robot's centre comes within the task radius. Where the
task sets an `accuracy`, each waypoint is worth 1 / (1 + e / accuracy) of its share, e the
RMS distance from the ideal path on the leg that led to it (`worth`). A goto robot arrives
only by stopping: at a control tick after its wheels have stood still for the task's `settle`
seconds with its centre within the radius (`stand`); passing through earns nothing, and the
arrival is worth more the nearer the stop is to the goal's centre.
"""

from __future__ import annotations

import bisect
import math

import numpy as np
from msgspec import UNSET, UnsetType

from levels.model import Level, Pose
from referee.match.paths import Paths, Polyline, first_near
from referee.records.results import CrossTrack, TaskProgress


class TaskTracker:
    """Tracks every robot's progress through the level's task, from its true start (`starts`,
    as arena.placement drew them; the level's nominal starts if not given)."""

    def __init__(self, level: Level, starts: tuple[Pose, ...] | None = None):
        starts = starts or tuple(r.start for r in level.robots)
        self.level = level
        self.kind = level.task.kind
        self._targets = [self._targets_of(slot) for slot in range(len(level.robots))]  # asked at every period
        self.next = [0] * len(level.robots)
        self.reached_at: list[list[float]] = [[] for _ in level.robots]
        self.finished: list[float | None] = [None] * len(level.robots)
        self.final_distance: list[float] = [math.nan] * len(level.robots)
        # the ideal polyline: from the start through every waypoint
        self.polyline = [
            Polyline([(s.x, s.y), *self.targets(r.slot)]) if self.targets(r.slot) else None
            for r, s in zip(level.robots, starts)
        ]
        self.paths = Paths(self.polyline)
        self.finished_count = 0
        self.still_since: list[float | None] = [None] * len(level.robots)  # goto: wheels still since then
        # a target's radius, a hair wide: where a check may look (numpy's distances may differ
        # from math.dist by an ulp); what counts as reached is confirmed with math.dist
        self.near = level.task.radius * (1 + 1e-9) + 1e-12
        self.deviation: list[list[float]] = [[] for _ in level.robots]
        # per robot, per target k, where the task sets an accuracy: the squares of its leg's
        # distances from the path summed, and their number (the samples after the previous target
        # before this one was reached; a batch and single steps add them in the same time order),
        # and the distance at the point where the robot reached it
        self.weighed = self.kind in ("waypoints", "race") and level.task.accuracy > 0
        self.legs: list[list[list[float]]] = [
            [[0.0, 0] for _ in self.targets(r.slot)] if self.weighed else [] for r in level.robots
        ]
        self.reach_distance: list[list[float]] = [[] for _ in level.robots]
        # per robot, per target k: at least how far the legs from target k to the last take
        # (`still_to_travel`), summed once here rather than at every control period
        self._rest = [self._legs_after(slot) for slot in range(len(level.robots))]

    def _legs_after(self, slot: int) -> list[float]:
        """For each target k of robot `slot`, the sum over the legs from it to the last target
        of each leg's length less the radius at both ends (none below zero)."""
        targets = self.targets(slot)
        out = [0.0] * len(targets)
        for k in range(len(targets) - 2, -1, -1):
            out[k] = out[k + 1] + max(0.0, math.dist(targets[k], targets[k + 1]) - 2 * self.near)
        return out

    def targets(self, slot: int) -> tuple[tuple[float, float], ...]:
        """The points robot `slot` must reach in order."""
        return self._targets[slot]

    def _targets_of(self, slot: int) -> tuple[tuple[float, float], ...]:
        g = self.level.task.goal
        if self.kind == "goto" and g is not None:  # the loader requires the goal of a goto task
            return ((g.x, g.y),)
        return self.level.robots[slot].path if self.kind in ("waypoints", "race") else ()

    def update(self, slot: int, x: float, y: float, time: float) -> None:
        """Advance robot `slot`'s progress with its position (x, y) at `time`."""
        targets = self.targets(slot)
        if self.kind == "goto":
            if not self.done(slot):  # arrived: the stop's distance is kept
                self.final_distance[slot] = math.dist((x, y), targets[0])
            return  # arriving is a stop (`stand`), not a passage
        radius = self.level.task.radius
        while self.next[slot] < len(targets) and math.dist((x, y), targets[self.next[slot]]) <= radius:
            if self.weighed:
                self.reach_distance[slot].append(self._off_path(slot, x, y))
            self.next[slot] += 1
            self.reached_at[slot].append(time)
            if self.next[slot] == len(targets):
                self.finished[slot] = time
                self.finished_count += 1

    def advance(self, states: np.ndarray, first_tick: int, rate: int, every: int) -> None:
        """`update` every robot with each of a run of steps' states (`states[i]` at tick
        `first_tick + i`, time tick / `rate`), as calling it step by step would; and record
        its distance from the ideal path at the ticks that are multiples of `every` (the record
        rate), until it finishes."""
        radius, near = self.level.task.radius, self.near
        n, start = len(states), -first_tick % every  # states[start::every] are sampled
        runs = []  # (slot, end): the robots whose distances to their path are sampled, up to `end`
        for slot in range(len(self.next)):
            xs, ys = states[:, 3 * slot], states[:, 3 * slot + 1]
            targets = self.targets(slot)
            if self.kind == "goto":  # as every step's update leaves it: from the last step
                if not self.done(slot):
                    self.final_distance[slot] = math.dist((xs[-1], ys[-1]), targets[0])
                continue
            end = n  # the step after which the robot has finished (no more samples)
            base = self.next[slot]
            reached: list[int] = []  # the steps at which it reached a target
            i = 0
            while self.next[slot] < len(targets) and i < n:
                tx, ty = targets[self.next[slot]]
                k = first_near(xs, ys, i, float(tx), float(ty), near)
                while k >= 0 and math.dist((xs[k], ys[k]), (tx, ty)) > radius:
                    k = first_near(xs, ys, k + 1, float(tx), float(ty), near)
                if k < 0:
                    break
                i = k
                self.update(slot, float(xs[i]), float(ys[i]), (first_tick + i) / rate)
                reached.extend([i] * (self.next[slot] - base - len(reached)))
                if self.done(slot):
                    end = i
            line = self.polyline[slot]
            if line is None or self.kind not in ("waypoints", "race") or (self.done(slot) and end == n):
                continue  # no path to stray from, or finished before these steps
            if start < end:
                runs.append((slot, end, base, reached))
        if runs:
            spans = [(slot, end) for slot, end, _, _ in runs]
            for (slot, _, base, reached), distances in zip(runs, self.paths.distances(states, start, every, spans)):
                self.deviation[slot].extend(distances)
                if self.weighed:  # a sample at step s is on the leg to the first target not reached by s
                    for j, d in enumerate(distances):
                        self._on_leg(slot, base + bisect.bisect_right(reached, start + j * every), d)

    def sample(self, slot: int, distance: float) -> None:
        """One sample of robot `slot`'s distance from its path, taken after this step's
        `update`: as `advance` samples at the record rate (a step-by-step driver's way)."""
        self.deviation[slot].append(distance)
        if self.weighed:
            self._on_leg(slot, self.next[slot], distance)

    def _on_leg(self, slot: int, target: int, distance: float) -> None:
        leg = self.legs[slot][target]
        leg[0] += distance * distance
        leg[1] += 1

    def _off_path(self, slot: int, x: float, y: float) -> float:
        line = self.polyline[slot]
        return line.distances([x], [y])[0] if line is not None else 0.0

    def worth(self, slot: int) -> list[float]:
        """What each target robot `slot` reached is worth, 0..1: 1 / (1 + e / accuracy), e the
        RMS of its leg's distances from the path; 1 each where the task sets no accuracy."""
        if not self.weighed:
            return [1.0] * self.next[slot]
        accuracy, out = self.level.task.accuracy, []
        for (squares, count), last in zip(self.legs[slot], self.reach_distance[slot]):
            rms = math.sqrt((squares + last * last) / (count + 1))
            out.append(1.0 / (1.0 + rms / accuracy))
        return out

    def stand(self, slot: int, still: bool, x: float, y: float, time: float) -> None:
        """At a control tick: whether robot `slot`'s wheels are still, and where it is. A goto
        robot whose wheels have been still at every tick for the task's `settle` seconds, its
        centre within the radius, has arrived now."""
        if self.kind != "goto" or self.done(slot):
            return
        if not still:
            self.still_since[slot] = None
            return
        since = self.still_since[slot]
        if since is None:
            self.still_since[slot] = since = time
        goal = self.targets(slot)[0]
        distance = math.dist((x, y), goal)
        if distance <= self.level.task.radius and time - since >= self.level.task.settle - 1e-9:
            self.final_distance[slot] = distance
            self.next[slot] = 1
            self.reached_at[slot].append(time)
            self.finished[slot] = time
            self.finished_count += 1

    def done(self, slot: int) -> bool:
        return self.finished[slot] is not None

    def still_to_travel(self, slot: int, x: float, y: float) -> float:
        """A lower bound on how far robot `slot`, now at (x, y), must still travel to finish:
        it must come within the task radius of each target left, in order, so each leg is at
        least its length less the radius at both ends (`near`: never more than the truth)."""
        targets, k = self.targets(slot), self.next[slot]
        if k == len(targets):
            return 0.0
        return max(0.0, math.dist((x, y), targets[k]) - self.near) + self._rest[slot][k]

    def progress(self, slot: int) -> float:
        """Task completion, 0..1: the worth of the waypoints reached over their number; or for
        goto the arrival, worth 1 / (1 + d / accuracy) for a stop d from the goal's centre, 0
        without one."""
        targets = self.targets(slot)
        if self.kind == "goto":
            if not self.done(slot):
                return 0.0
            return 1.0 / (1.0 + self.final_distance[slot] / self.level.task.accuracy)
        return math.fsum(self.worth(slot)) / len(targets) if targets else 0.0

    def summary(self, slot: int) -> TaskProgress:
        """Robot `slot`'s progress as its result record."""
        finished = self.finished[slot]
        targets = self.targets(slot)
        if self.kind in ("waypoints", "race"):
            dev = self.deviation[slot]
            cross: CrossTrack | UnsetType = UNSET
            if dev:
                mean = sum(dev) / len(dev)
                std = math.sqrt(sum((d - mean) ** 2 for d in dev) / len(dev))
                cross = CrossTrack(mean=mean, std=std, max=max(dev))
            return TaskProgress(
                kind=self.kind,
                finished=finished,
                reached=self.next[slot],
                total=len(targets),
                reached_at=list(self.reached_at[slot]),
                cross_track=cross,
                worth=self.worth(slot) if self.weighed else UNSET,
            )
        if self.kind == "goto":
            return TaskProgress(kind=self.kind, finished=finished, final_distance=self.final_distance[slot])
        return TaskProgress(kind=self.kind, finished=finished)
