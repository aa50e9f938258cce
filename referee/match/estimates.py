"""Localization accuracy: the controller's reported estimates against the true pose."""

from __future__ import annotations

import math

from arena.angles import wrap
from arena.level import Pose
from referee.records.results import Localization


class EstimateStats:
    """Accumulates position and heading errors over the control ticks of one robot."""

    def __init__(self) -> None:
        self.ticks = 0
        self.estimated = 0
        self.pos_sq = self.pos_max = 0.0
        self.hdg_sq = self.hdg_max = 0.0

    def add(self, truth: Pose, estimate: tuple[float, float, float] | None) -> None:
        """Count one control tick, and its estimate error if there is an estimate."""
        self.ticks += 1
        if estimate is None:
            return
        self.estimated += 1
        d = math.hypot(estimate[0] - truth.x, estimate[1] - truth.y)
        h = abs(wrap(estimate[2] - truth.heading))
        self.pos_sq += d * d
        self.hdg_sq += h * h
        self.pos_max = max(self.pos_max, d)
        self.hdg_max = max(self.hdg_max, h)

    @property
    def fraction(self) -> float:
        """Fraction of control ticks that carried an estimate."""
        return self.estimated / self.ticks if self.ticks else 0.0

    def summary(self) -> Localization:
        """The accumulated errors as the robot's localization record."""
        n = self.estimated
        return Localization(
            ticks=self.ticks,
            estimates=n,
            fraction=self.fraction,
            position_rms=math.sqrt(self.pos_sq / n) if n else None,
            position_max=self.pos_max if n else None,
            heading_rms=math.sqrt(self.hdg_sq / n) if n else None,
            heading_max=self.hdg_max if n else None,
        )
