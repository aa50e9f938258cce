"""Fouls: typed events with tick, time, robot and place, each costing the level's penalty.

After every physics step the rules hook looks at the world: contacts that ended (a collision
with a robot, wall, obstacle or beacon, if its impulse reached `min_impulse`), robots whose
centre left the field, robots faster than `speed_limit` (one foul per spell). Skipped ticks and
controller faults become fouls too (the match reports them here).
"""

from __future__ import annotations

from bisect import bisect_right
from dataclasses import dataclass

import numpy as np

from arena.compiled import compiled
from arena.world import World
from levels.model import Level
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
        """The checks after one physics step, on the world as it is now."""
        speeds = tuple(b.velocity.length for b in world.bodies) if self.rules.speed_limit else None
        self._check(world, world.tick, len(world.contacts), world.state, speeds)

    def after_steps(self, world: World, states: np.ndarray, speeds: list[tuple[float, ...]] | None = None) -> None:
        """The checks after each of the last `len(states)` steps (`states[i]` is the world's
        `state` then, `speeds[i]` its robots' speeds, needed with a speed limit), with the
        fouls exactly as step-by-step checks give them: only the steps where a contact ended or
        a robot crossed the field's border or the speed limit are looked at one by one."""
        last = world.tick
        first = last - len(states) + 1  # the tick of states[0]
        ends = world.contact_ends
        busy = set(ends[self.seen_contacts :])
        busy.update((first + border_changes(states, *self.bounds, np.array(self.outside))).tolist())
        limit = self.rules.speed_limit
        if limit:
            fast = np.asarray(speeds) > limit + 1e-9
            changed = fast != np.vstack([self.speeding, fast[:-1]])
            busy.update((first + np.flatnonzero(changed.any(axis=1))).tolist())
        for tick in sorted(busy):
            i = tick - first
            state = tuple(states[i].tolist())
            self._check(world, tick, bisect_right(ends, tick), state, speeds[i] if limit and speeds else None)

    def _check(
        self, world: World, tick: int, contacts: int, state: tuple[float, ...], speeds: tuple[float, ...] | None
    ) -> None:
        """One step's checks at `tick`: the contacts that ended by then (the first `contacts`),
        then each robot leaving the field or passing the speed limit."""
        for c in world.contacts[self.seen_contacts : contacts]:
            if c.impulse >= self.rules.min_impulse:
                if c.other_robot is not None:  # a robot-robot contact
                    self._add("robot_collision", c.tick, c.robot, c.point, impulse=c.impulse, other=c.other_robot)
                    self._add("robot_collision", c.tick, c.other_robot, c.point, impulse=c.impulse, other=c.robot)
                else:
                    self._add(f"{c.other}_collision", c.tick, c.robot, c.point, impulse=c.impulse)
        self.seen_contacts = max(self.seen_contacts, contacts)
        xmin, ymin, xmax, ymax = self.bounds
        limit = self.rules.speed_limit
        for slot in range(len(self.outside)):
            x, y = state[3 * slot], state[3 * slot + 1]
            out = not (xmin <= x <= xmax and ymin <= y <= ymax)
            if out and not self.outside[slot]:
                self._add("leave_field", tick, slot, (x, y))
            self.outside[slot] = out
            if limit and speeds is not None:
                v = speeds[slot]
                fast = v > limit + 1e-9
                if fast and not self.speeding[slot]:
                    self._add("speeding", tick, slot, (x, y), speed=v)
                self.speeding[slot] = fast

    def moved(self) -> None:
        """The robots were carried to new poses, at rest and inside the field (`World.place`):
        a spell outside the field or over the speed limit ended there."""
        self.outside = [False] * len(self.outside)
        self.speeding = [False] * len(self.speeding)

    def controller(self, slot: int, tick: int, kind: str, place: tuple[float, float], message: str) -> None:
        """A skipped tick or a fault reported by the controller's process."""
        self._add("skipped_tick" if kind == "skipped_tick" else "fault", tick, slot, place, fault=kind, message=message)

    def finish(self, world: World) -> None:
        """End of match: contacts still going on count too."""
        world.end_contacts()
        self.after_step(world)


@compiled()
def border_changes(
    states: np.ndarray, xmin: float, ymin: float, xmax: float, ymax: float, outside: np.ndarray
) -> np.ndarray:
    """The rows of `states` (world states, a step each) at which some robot's centre is
    outside the field (xmin, ymin, xmax, ymax) where it was inside the row before, or the
    other way round; the first row is compared with `outside`, each robot's before it."""
    found = np.empty(states.shape[0], np.int64)
    was = outside.copy()
    count = 0
    for i in range(states.shape[0]):
        changed = False
        for slot in range(was.shape[0]):
            x, y = states[i, 3 * slot], states[i, 3 * slot + 1]
            out = not (xmin <= x and x <= xmax and ymin <= y and y <= ymax)
            if out != was[slot]:
                changed = True
            was[slot] = out
        if changed:
            found[count] = i
            count += 1
    return found[:count]
