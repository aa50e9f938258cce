"""Small steering helpers shared by the reference controllers."""

from __future__ import annotations

import math

HEADING_SURE = 0.05  # rad: a heading known this well (one sd) needs no driving to learn it
LEARN = 0.06  # m: at most this far driven straight to learn the heading


def next_waypoint(path: list[tuple[float, float]], index: int, x: float, y: float, within: float) -> int:
    """The index of the first waypoint from `index` on that (x, y) is not yet within `within` of."""
    while index < len(path) and math.dist((x, y), path[index]) < within:
        index += 1
    return index


class HeadingProbe:
    """Drive straight to learn the heading, once (per localize trial): a robot without a heading
    sensor whose heading the rules do not announce learns it from its motion, as Bac's did ("the
    orientation was determined by evaluating two consecutive positions"). It drives until the
    heading is known within `sure` (rad, one sd) or it has gone `limit` (m)."""

    def __init__(self, sure: float = HEADING_SURE, limit: float = LEARN) -> None:
        self.sure, self.limit = sure, limit
        self.reset()

    def reset(self) -> None:
        """Learn again (the robot was carried to a new pose)."""
        self.start: tuple[float, float] | None = None
        self.done = False

    def driving(self, x: float, y: float, heading_sd: float) -> bool:
        """Whether to drive straight on now, the robot at (x, y) and its heading this sure."""
        if self.done:
            return False
        if self.start is None:
            self.start = (x, y)
        self.done = heading_sd <= self.sure or math.dist((x, y), self.start) >= self.limit
        return not self.done
