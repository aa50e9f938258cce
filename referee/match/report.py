"""What a step-wise driver (the gym, the PettingZoo env) may read of a match after a control
tick: each robot's standing as the referee counts it, in one frozen record, so no driver
reaches into the match's own state."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RobotReport:
    """One robot's standing now (docs/rules.md for what each part scores)."""

    time: float  # the match's time (s)
    progress: float  # task progress, 0..1, as the score counts it
    reached: int  # targets reached (waypoints; 1 once a goto robot arrived)
    targets: tuple[tuple[float, float], ...]  # the points it must reach, in order
    start: tuple[float, float]  # where it truly started (x, y)
    finished: float | None  # when it finished its task (s), or None
    stopped: bool  # stopped by a fault
    position: tuple[float, float]  # where it truly stands (x, y): for a trainer's shaping and a picture
    heading: float  # which way it truly faces (rad)
    quality_sum: float  # the sum of its ticks' localization qualities so far
    quality: float  # its localization quality so far (the mean over its ticks)
    penalties: tuple[float, ...]  # the penalty of each of its fouls so far, in order

    @property
    def done(self) -> bool:
        """Finished its task or stopped."""
        return self.finished is not None or self.stopped
