"""What sensing tells a controller: one event (`Detection`) and the order a controller gets them in."""

from __future__ import annotations

from functools import partial
from typing import NamedTuple


class Detection(NamedTuple):
    """One event for one robot's controller. `source` is the robot whose laser caused it
    (for replays only, never shown to a team). An immutable named tuple: a match makes
    hundreds per simulated second, and a tuple is several times cheaper to build than a
    frozen dataclass."""

    robot: int
    time: float
    kind: str  # hit | index | scan
    beacon: str | None = None
    angle: float | None = None
    samples: tuple[int, ...] = ()
    source: int = -1
    beam: tuple[float, float, float, float] | None = None  # laser (x, y) -> target (x, y), for replays


# a Detection from a tuple of all its fields in order, with no Python call per event
NEW_DETECTION = partial(tuple.__new__, Detection)


def event_order(d: Detection) -> tuple:
    """The order of one controller's events: by time, then kind, beacon and source."""
    return (d.time, d.kind, d.beacon or "", d.source)
