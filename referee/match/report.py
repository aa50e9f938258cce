"""What a step-wise driver (the match loop, the gym, the PettingZoo env) reads of the
simulation: what a control tick did (`Tick`) and each robot's standing as the referee counts
it (`RobotReport`), in frozen records, so no driver reaches into the simulation's own state.
Named tuples: the gym makes one of each per agent at every step, where a frozen dataclass's
field-by-field set costs more than the step's checks."""

from __future__ import annotations

from typing import NamedTuple

from referee.match.rules import Foul
from robots.api import Observation


class RobotReport(NamedTuple):
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


class Tick(NamedTuple):
    """What one control tick of a `Simulation` did, robot by robot (tuples in slot order)."""

    time: float  # the match's time now (s)
    observations: tuple[Observation | None, ...]  # each robot's next observation (None: stopped, or ended)
    earned: tuple[float | None, ...]  # the tick quality each robot's estimate earned (None: no estimate)
    progress: tuple[float, ...]  # each robot's task progress, 0..1, as the score counts it
    fouls: tuple[tuple[Foul, ...], ...]  # the fouls called on each robot during this tick
    ended: bool  # the match has ended: call `end()` for the result
