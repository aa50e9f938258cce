"""Fouls: typed events with tick, time, robot and place, each costing the level's penalty.

After every physics step the rules hook looks at the world: contacts that ended (a collision
with a robot, wall, obstacle or beacon, if its impulse reached `min_impulse`), robots whose
centre left the field, robots faster than `speed_limit` (one foul per spell). Skipped ticks and
controller faults become fouls too (the match reports them here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arena.level import Level
from arena.world import World
from referee.records.results import FoulRecord


@dataclass(frozen=True)
class Foul:
    """One foul: its kind, when (tick and time), which robot, where, and details."""

    kind: str  # robot_collision | wall_collision | obstacle_collision | beacon_collision |
    #            leave_field | speeding | skipped_tick | fault
    tick: int
    time: float
    robot: int
    place: tuple[float, float]
    penalty: float
    detail: dict

    def to_record(self) -> FoulRecord:
        """The foul as it appears in the result and the replay."""
        return FoulRecord(
            kind=self.kind, tick=self.tick, time=self.time, place=list(self.place), penalty=self.penalty, **self.detail
        )


class Rules:
    """The rules hook of a match: collects fouls per robot."""

    def __init__(self, level: Level):
        self.level = level
        self.rules = level.rules
        self.fouls: list[list[Foul]] = [[] for _ in level.robots]
        self.seen_contacts = 0
        self.outside = [False] * len(level.robots)
        self.speeding = [False] * len(level.robots)
        f = level.field
        eps = 1e-9
        self.bounds = (f.xmin - eps, f.ymin - eps, f.xmax + eps, f.ymax + eps)

    def _add(self, kind: str, tick: int, robot: int, place: tuple[float, float], **detail) -> None:
        penalty = self.rules.penalties.get(kind, 0.0)
        self.fouls[robot].append(
            Foul(kind, tick, tick / self.level.physics_rate, robot, (float(place[0]), float(place[1])), penalty, detail)
        )

    def after_step(self, world: World) -> None:
        for c in world.contacts[self.seen_contacts :]:
            if c.impulse >= self.rules.min_impulse:
                if c.other_robot is not None:  # a robot-robot contact
                    self._add("robot_collision", c.tick, c.robot, c.point, impulse=c.impulse, other=c.other_robot)
                    self._add("robot_collision", c.tick, c.other_robot, c.point, impulse=c.impulse, other=c.robot)
                else:
                    self._add(f"{c.other}_collision", c.tick, c.robot, c.point, impulse=c.impulse)
        self.seen_contacts = len(world.contacts)
        xmin, ymin, xmax, ymax = self.bounds
        limit = self.rules.speed_limit
        state = world.state
        for slot, body in enumerate(world.bodies):
            x, y = state[3 * slot], state[3 * slot + 1]
            out = not (xmin <= x <= xmax and ymin <= y <= ymax)
            if out and not self.outside[slot]:
                self._add("leave_field", world.tick, slot, (x, y))
            self.outside[slot] = out
            if limit:
                v = body.velocity.length
                fast = v > limit + 1e-9
                if fast and not self.speeding[slot]:
                    self._add("speeding", world.tick, slot, (x, y), speed=v)
                self.speeding[slot] = fast

    def controller(self, slot: int, tick: int, kind: str, place: tuple[float, float], message: str) -> None:
        """A skipped tick or a fault reported by the controller's process."""
        self._add("skipped_tick" if kind == "skipped_tick" else "fault", tick, slot, place, fault=kind, message=message)

    def finish(self, world: World) -> None:
        """End of match: contacts still going on count too."""
        world.end_contacts()
        self.after_step(world)


class Polyline:
    """A path as arrays of segments, for fast distances to it."""

    def __init__(self, points: list[tuple[float, float]]):
        p = np.asarray(points, dtype=float)
        self.a = p[:-1]
        self.d = p[1:] - p[:-1]
        self.n2 = np.maximum((self.d**2).sum(axis=1), 1e-300)

    def distance(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the polyline."""
        rx, ry = x - self.a[:, 0], y - self.a[:, 1]
        t = np.clip((rx * self.d[:, 0] + ry * self.d[:, 1]) / self.n2, 0.0, 1.0)
        return float(np.sqrt(((rx - t * self.d[:, 0]) ** 2 + (ry - t * self.d[:, 1]) ** 2).min()))
