"""The team side: the controller API, the localization toolkit and reference controllers.

- `api`: what a controller receives and returns (exported here), with `bounds`;
- `toolkit`: solvers, trackers and filters a controller may import;
- `controllers`: the reference controllers (`ref:NAME`);
- `_host`: the host's half, which a team never needs to read.

Imports: the standard library, numpy and msgspec only: it runs inside a team's process.
"""

from robots.api import (
    API_VERSION,
    BeaconInfo,
    Brief,
    Command,
    Controller,
    Drawing,
    LaserInfo,
    Observation,
    RobotInfo,
    SensorEvent,
    StartInfo,
    TaskInfo,
)

__all__ = [
    "API_VERSION",
    "BeaconInfo",
    "Brief",
    "Command",
    "Controller",
    "Drawing",
    "LaserInfo",
    "Observation",
    "RobotInfo",
    "SensorEvent",
    "StartInfo",
    "TaskInfo",
]  # the public API: `from robots import ...`
