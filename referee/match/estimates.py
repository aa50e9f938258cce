"""Localization accuracy: the controller's reported estimates against the true pose.

Each control tick earns a quality q in 0..1 (docs/rules.md): an estimate that is off by d in
position and h in heading earns q = 1 / (1 + sqrt((d / position_scale)^2 + (h / heading_scale)^2)),
a tick without an estimate earns 0. The match's localization quality is the mean of q over its
ticks, so withholding an estimate can never raise it; a robot stopped by a fault says nothing
until the time limit (`silent_until`), so stopping, which may end a match early, cannot either.
"""

from __future__ import annotations

import math

from arena.angles import wrap
from levels.model import Pose
from referee.records.results import Localization


def tick_quality(position_error: float, heading_error: float, position_scale: float, heading_scale: float) -> float:
    """One tick's localization quality q of an estimate this far off (m, rad)."""
    return 1.0 / (1.0 + math.hypot(position_error / position_scale, heading_error / heading_scale))


class EstimateStats:
    """Accumulates position and heading errors, and the tick qualities, over the control ticks
    of one robot, on the level's scales (m, rad)."""

    def __init__(self, position_scale: float = 0.01, heading_scale: float = 0.05) -> None:
        self.position_scale, self.heading_scale = position_scale, heading_scale
        self.ticks = 0
        self.estimated = 0
        self.quality_sum = 0.0
        self.pos_sq = self.pos_max = 0.0
        self.hdg_sq = self.hdg_max = 0.0

    def add(self, truth: Pose, estimate: tuple[float, float, float] | None) -> None:
        """Count one control tick, and its estimate's errors and quality if there is an estimate."""
        self.ticks += 1
        if estimate is None:
            return
        self.estimated += 1
        d = math.hypot(estimate[0] - truth.x, estimate[1] - truth.y)
        h = abs(wrap(estimate[2] - truth.heading))
        self.quality_sum += tick_quality(d, h, self.position_scale, self.heading_scale)
        self.pos_sq += d * d
        self.hdg_sq += h * h
        self.pos_max = max(self.pos_max, d)
        self.hdg_max = max(self.hdg_max, h)

    def silent_until(self, ticks: int) -> None:
        """Count the ticks after the last one added, up to `ticks` in all, as ticks without an
        estimate (a stopped robot's, to the time limit, whenever the match ended)."""
        self.ticks = max(self.ticks, ticks)

    @property
    def fraction(self) -> float:
        """Fraction of control ticks that carried an estimate."""
        return self.estimated / self.ticks if self.ticks else 0.0

    @property
    def quality(self) -> float:
        """The localization quality Q, 0..1: the mean tick quality, 0 for a tick without an estimate."""
        return self.quality_sum / self.ticks if self.ticks else 0.0

    def summary(self) -> Localization:
        """The accumulated errors as the robot's localization record."""
        n = self.estimated
        return Localization(
            ticks=self.ticks,
            estimates=n,
            fraction=self.fraction,
            quality=self.quality,
            position_rms=math.sqrt(self.pos_sq / n) if n else None,
            position_max=self.pos_max if n else None,
            heading_rms=math.sqrt(self.hdg_sq / n) if n else None,
            heading_max=self.hdg_max if n else None,
        )
