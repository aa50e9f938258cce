"""The strongest strategies we know that never use the laser, for `make baselines`.

Each drives by dead reckoning alone and reports the pose its odometry gives from the announced
start (the centre of the announced region, or of the field, facing the announced heading):

How it works, in detail: docs/internals.md, `benchmarks/no_laser.py`.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import replace

from robots.api import Brief, Command, Controller, Observation

FRACTION = 4  # the reference is fed one event in this many
STAND_MARGIN = 0.3  # s stood beyond the task's settle time, for the wheels' ramp down


class _Driver(Controller):
    """Plays a plan of (seconds, left, right) steps and dead-reckons from the announced start."""

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        if brief.start is not None:
            x, y, heading = brief.start.pose
            if brief.start.region is not None:
                x0, y0, x1, y1 = brief.start.region
                x, y = (x0 + x1) / 2, (y0 + y1) / 2
        else:
            x0, y0, x1, y1 = brief.field
            x, y, heading = (x0 + x1) / 2, (y0 + y1) / 2, 0.0
        self.pose = [x, y, heading]
        self.plan: list[tuple[float, float, float]] = []
        self.until, self.wheels, self.last = 0.0, (0.0, 0.0), 0.0
        self.speed = 0.8 * brief.robot.max_wheel_speed
        self.stand = (
            (brief.task.settle or 1.0) + STAND_MARGIN + brief.robot.max_wheel_speed / brief.robot.max_wheel_accel
        )

    def more(self) -> list[tuple[float, float, float]]:
        """The next steps of the plan."""
        raise NotImplementedError

    def drive(self, distance: float) -> tuple[float, float, float]:
        return (distance / self.speed, self.speed, self.speed)

    def turn(self, angle: float) -> tuple[float, float, float]:
        v = math.copysign(0.5 * self.speed, angle)
        return (abs(angle) * self.brief.robot.track / 2 / abs(v), -v, v)

    def halt(self) -> tuple[float, float, float]:
        return (self.stand, 0.0, 0.0)

    def step(self, observation: Observation) -> Command:
        now = observation.time
        dt, (left, right) = now - self.last, self.wheels
        v, w = (left + right) / 2, (right - left) / self.brief.robot.track
        self.pose[2] += w * dt
        self.pose[0] += v * dt * math.cos(self.pose[2])
        self.pose[1] += v * dt * math.sin(self.pose[2])
        self.last = now
        while now >= self.until:
            if not self.plan:
                self.plan = self.more()
            seconds, left, right = self.plan.pop(0)
            self.until, self.wheels = self.until + seconds, (left, right)
        return Command(*self.wheels, estimate=tuple(self.pose))


class Spiral(_Driver):
    """A square spiral of stops around the announced start."""

    def setup(self, brief: Brief) -> None:
        super().setup(brief)
        radius = brief.task.radius or 0.1
        self.pitch = 1.4 * radius  # stops and rings this far apart: every point within a radius of a stop
        self.legs = 0

    def more(self) -> list[tuple[float, float, float]]:
        self.legs += 1
        steps = [self.turn(math.pi / 2)]
        for _ in range((self.legs + 1) // 2):  # legs of 1, 1, 2, 2, 3, 3, ... pitches
            steps += [self.drive(self.pitch), self.halt()]
        return steps


class Bounce(_Driver):
    """Straight on for a random time, stand, spin by a random angle."""

    def setup(self, brief: Brief) -> None:
        super().setup(brief)
        self.rng = random.Random(0)  # its own, fixed: a team's controller has no other

    def more(self) -> list[tuple[float, float, float]]:
        return [
            self.drive(self.speed * self.rng.uniform(1.0, 4.0)),
            self.halt(),
            self.turn(self.rng.uniform(-math.pi, math.pi)),
        ]


class Walls(_Driver):
    """Straight on until it must have met a wall, then along the walls: each leg turned a
    little less than a right angle, so that it keeps pressing on the wall it slides along,
    standing still at every pitch of the way (a corner stops it until the next leg turns it)."""

    def setup(self, brief: Brief) -> None:
        super().setup(brief)
        x0, y0, x1, y1 = brief.field
        self.side = max(x1 - x0, y1 - y0)
        self.pitch = 1.4 * (brief.task.radius or 0.1)
        self.met = False

    def more(self) -> list[tuple[float, float, float]]:
        if not self.met:
            self.met = True
            return [self.drive(math.hypot(self.side, self.side))]
        steps = [self.turn(math.radians(80))]
        for _ in range(max(1, round(self.side / self.pitch))):
            steps += [self.drive(self.pitch), self.halt()]
        return steps


class Fraction(Controller):
    """`inner` (the level's reference) fed one event in FRACTION."""

    def __init__(self, inner: Controller):
        self.inner, self.seen = inner, 0

    def setup(self, brief: Brief) -> None:
        self.inner.setup(brief)

    def step(self, observation: Observation) -> Command:
        kept = []
        for e in observation.events:
            if self.seen % FRACTION == 0:
                kept.append(e)
            self.seen += 1
        return self.inner.step(replace(observation, events=tuple(kept)))


STRATEGIES: dict[str, Callable[[], Controller]] = {"spiral": Spiral, "walls": Walls, "bounce": Bounce}
