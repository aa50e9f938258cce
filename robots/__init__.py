"""The team side: the controller API, the localization toolkit and reference controllers.

Imports nothing from `levels`, `arena` or `referee`: this package is what runs inside a team's process.
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
