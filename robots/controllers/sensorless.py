"""A controller that never senses: it reports the announced nominal start and stands still.

It is the floor of every localization score: the best a team can do without its laser is to
report where the rules say it starts (or, where they say nothing, the pose it would copy from
the public level file: `start`). A localizing controller must beat it by far on every level.
"""

from __future__ import annotations

from robots.api import Brief, Command, Controller, Observation


class Sensorless(Controller):
    """`start` (x, y, heading) is reported instead of the brief's nominal start; without
    either, the centre of the field facing +x."""

    def __init__(self, start: tuple[float, float, float] | None = None) -> None:
        self.start = start

    def setup(self, brief: Brief) -> None:
        xmin, ymin, xmax, ymax = brief.field
        announced = brief.start.pose if brief.start else ((xmin + xmax) / 2, (ymin + ymax) / 2, 0.0)
        self.pose = self.start or announced

    def step(self, observation: Observation) -> Command:
        return Command(0.0, 0.0, estimate=self.pose)
