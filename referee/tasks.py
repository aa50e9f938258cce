"""Task progress: which waypoints each robot has reached, whether it reached its goal, when.

Checked after every physics step against the true pose. The provisional score is the task
completion in percent (docs/results.md); the referee issue replaces it with full scoring.
"""

from __future__ import annotations

import math

from arena.level import Level, Pose


class TaskTracker:
    """Tracks every robot's progress through the level's task."""

    def __init__(self, level: Level):
        self.level = level
        self.kind = level.task.kind
        self.next = [0] * len(level.robots)
        self.reached_at: list[list[float]] = [[] for _ in level.robots]
        self.finished: list[float | None] = [None] * len(level.robots)
        self.final_distance: list[float] = [math.nan] * len(level.robots)

    def targets(self, slot: int) -> tuple[tuple[float, float], ...]:
        """The points robot `slot` must reach in order."""
        if self.kind == "goto":
            g = self.level.task.goal
            return ((g.x, g.y),)
        return self.level.robots[slot].path if self.kind in ("waypoints", "race") else ()

    def update(self, slot: int, pose: Pose, time: float) -> None:
        """Advance robot `slot`'s progress with its pose at `time`."""
        targets = self.targets(slot)
        if self.kind == "goto":
            self.final_distance[slot] = math.dist((pose.x, pose.y), targets[0])
        radius = self.level.task.radius
        while self.next[slot] < len(targets) and math.dist((pose.x, pose.y), targets[self.next[slot]]) <= radius:
            self.next[slot] += 1
            self.reached_at[slot].append(time)
            if self.next[slot] == len(targets):
                self.finished[slot] = time

    def done(self, slot: int) -> bool:
        return self.finished[slot] is not None

    def score(self, slot: int, estimate_fraction: float) -> float:
        """Provisional score: task completion in percent (localize: ticks with an estimate)."""
        targets = self.targets(slot)
        if not targets:
            return 100.0 * estimate_fraction
        return 100.0 * self.next[slot] / len(targets)

    def summary(self, slot: int) -> dict:
        out: dict = {"kind": self.kind, "finished": self.finished[slot]}
        targets = self.targets(slot)
        if self.kind in ("waypoints", "race"):
            out.update(reached=self.next[slot], total=len(targets), reached_at=self.reached_at[slot])
        elif self.kind == "goto":
            out.update(final_distance=self.final_distance[slot])
        return out
