"""Task progress: which waypoints each robot has reached, whether it reached its goal, when,
and how far it strayed from the ideal path. Checked against the true pose; scoring of the
progress is in referee/match/scoring.py and docs/rules.md.
"""

from __future__ import annotations

import math

from msgspec import UNSET, UnsetType

from arena.level import Level, Pose
from referee.match.rules import Polyline
from referee.records.results import CrossTrack, TaskProgress


class TaskTracker:
    """Tracks every robot's progress through the level's task."""

    def __init__(self, level: Level):
        self.level = level
        self.kind = level.task.kind
        self.next = [0] * len(level.robots)
        self.reached_at: list[list[float]] = [[] for _ in level.robots]
        self.finished: list[float | None] = [None] * len(level.robots)
        self.final_distance: list[float] = [math.nan] * len(level.robots)
        self.start_distance = [
            math.dist((r.start.x, r.start.y), self.targets(r.slot)[0]) if self.targets(r.slot) else math.nan
            for r in level.robots
        ]
        # the ideal polyline: from the start through every waypoint
        self.polyline = [
            Polyline([(r.start.x, r.start.y), *self.targets(r.slot)]) if self.targets(r.slot) else None
            for r in level.robots
        ]
        self.finished_count = 0
        self.deviation: list[list[float]] = [[] for _ in level.robots]

    def targets(self, slot: int) -> tuple[tuple[float, float], ...]:
        """The points robot `slot` must reach in order."""
        g = self.level.task.goal
        if self.kind == "goto" and g is not None:  # the loader requires the goal of a goto task
            return ((g.x, g.y),)
        return self.level.robots[slot].path if self.kind in ("waypoints", "race") else ()

    def update(self, slot: int, x: float, y: float, time: float) -> None:
        """Advance robot `slot`'s progress with its position (x, y) at `time`."""
        targets = self.targets(slot)
        if self.kind == "goto":
            self.final_distance[slot] = math.dist((x, y), targets[0])
        radius = self.level.task.radius
        while self.next[slot] < len(targets) and math.dist((x, y), targets[self.next[slot]]) <= radius:
            self.next[slot] += 1
            self.reached_at[slot].append(time)
            if self.next[slot] == len(targets):
                self.finished[slot] = time
                self.finished_count += 1

    def sample_path(self, slot: int, pose: Pose | tuple[float, float]) -> None:
        """Record the robot's distance from the ideal path (at the record rate, until it finishes)."""
        line = self.polyline[slot]  # present for every robot of a waypoints or race task
        if line is not None and self.kind in ("waypoints", "race") and not self.done(slot):
            x, y = (pose.x, pose.y) if isinstance(pose, Pose) else pose
            self.deviation[slot].append(line.distance(x, y))

    def done(self, slot: int) -> bool:
        return self.finished[slot] is not None

    def progress(self, slot: int) -> float:
        """Task completion, 0..1: waypoints reached; or how much of the way to the goal."""
        targets = self.targets(slot)
        if self.kind == "goto":
            if self.done(slot):
                return 1.0
            return (
                max(0.0, 1.0 - self.final_distance[slot] / self.start_distance[slot])
                if self.start_distance[slot]
                else 0.0
            )
        return self.next[slot] / len(targets) if targets else 0.0

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
                cross = CrossTrack(mean=1000 * mean, std=1000 * std, max=1000 * max(dev))
            return TaskProgress(
                kind=self.kind,
                finished=finished,
                reached=self.next[slot],
                total=len(targets),
                reached_at=list(self.reached_at[slot]),
                cross_track_mm=cross,
            )
        if self.kind == "goto":
            return TaskProgress(kind=self.kind, finished=finished, final_distance=self.final_distance[slot])
        return TaskProgress(kind=self.kind, finished=finished)
