"""The controller API: the one contract between the referee and a team's code.

A controller gets a `Brief` once (`setup`) and an `Observation` every control period
(`step`), and answers each step with a `Command`. It never sees its true pose: only the
clock and the times at which its laser met beacons. Everything here is plain data
(frozen dataclasses of numbers, text and tuples) so it can cross a process border.

This module imports nothing from `arena` or `referee`: it runs inside a team's process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

API_VERSION = 2  # 2: the start announced with its spread (`StartInfo`), localize trials


@dataclass(frozen=True)
class BeaconInfo:
    """A fixed beacon the team may know: its id and position (m)."""

    id: str
    x: float
    y: float


@dataclass(frozen=True)
class LaserInfo:
    """The robot's spinning laser: angular velocity relative to the body (rad/s, + = CCW)
    and whether an index switch reports relative angle 0 (straight ahead)."""

    angular_velocity: float
    index: bool


@dataclass(frozen=True)
class RobotInfo:
    """The robot's model: footprint (m), wheel track (m) and wheel limits."""

    model: str
    length: float
    width: float
    track: float
    max_wheel_speed: float  # m/s; commands are clipped to +-this
    max_wheel_accel: float  # m/s^2; wheels ramp towards commands at this rate


@dataclass(frozen=True)
class TaskInfo:
    """What this robot must do: `kind` is waypoints | goto | localize | race;
    `path` the waypoints in order, `goal` an (x, y) target, `radius` how close counts;
    `trials` how many trials a localize match holds (the referee moves the robot to a new
    secret pose at the start of each after the first: `Observation.trial` says which)."""

    kind: str
    radius: float
    path: tuple[tuple[float, float], ...] = ()
    goal: tuple[float, float] | None = None
    trials: int = 1


@dataclass(frozen=True)
class StartInfo:
    """What the rules announce of the robot's start (docs/levels.md). The robot stands within
    `position_spread` (m) of (x, y), uniformly over that disc, or, when `region` (xmin, ymin,
    xmax, ymax) is given, anywhere in that rectangle; its heading lies within
    `heading_spread` (rad) either way of `heading`, and `heading_spread` pi means any heading
    at all. Spreads of 0: exactly this pose."""

    x: float
    y: float
    heading: float
    position_spread: float = 0.0
    heading_spread: float = 0.0
    region: tuple[float, float, float, float] | None = None

    @property
    def pose(self) -> tuple[float, float, float]:
        """The nominal pose (x, y, heading)."""
        return (self.x, self.y, self.heading)

    @property
    def heading_known(self) -> bool:
        """Whether the rules say anything of the heading (a spread short of any heading)."""
        return self.heading_spread < math.pi


@dataclass(frozen=True)
class Brief:
    """Everything a team may know before the match starts."""

    slot: int
    field: tuple[float, float, float, float]  # xmin, ymin, xmax, ymax (m)
    beacon_kind: str  # reflector | sensor_array | flash_detector | light
    beacons: tuple[BeaconInfo, ...]
    laser: LaserInfo
    robot: RobotInfo
    task: TaskInfo
    control_period: float  # s
    time_limit: float  # s
    start: StartInfo | None = None  # what the rules announce of the start; None: nothing


@dataclass(frozen=True)
class SensorEvent:
    """One sensor event, as the hardware reports it (docs/sensors.md).

    `time`: when it happened (s, match clock, as the detector's clock reads it);
    `kind`: `hit` (the beam met a beacon), `index` (the laser passed straight ahead) or
    `scan` (a light turret's full turn of brightness samples);
    `beacon`: which beacon, where the hardware can tell (`None` for unlabelled returns);
    `angle`: the laser's angle relative to the robot (rad, [0, 2 pi)), where the hardware
    latches it (an encoder, a stepped head), else `None`;
    `samples`: for a scan, brightness 0 (bright) .. 255 (dark) at relative angles 2 pi k / N."""

    time: float
    kind: str
    beacon: str | None = None
    angle: float | None = None
    samples: tuple[int, ...] = ()


@dataclass(frozen=True)
class Observation:
    """What the controller learns at a control tick: the clock, the events since the last
    tick, and the localize trial under way (0 first; when it grows, the robot was carried to
    a new pose at the start of this control period, and every event here was sensed there)."""

    tick: int
    time: float
    events: tuple[SensorEvent, ...] = ()
    trial: int = 0


@dataclass(frozen=True)
class Drawing:
    """A debug overlay drawn in the replay: `kind` is point | line | circle | text;
    `points` in metres; `radius` for circles; `text` for labels; `color` as RGB."""

    kind: str
    points: tuple[tuple[float, float], ...]
    radius: float = 0.0
    text: str = ""
    color: tuple[int, int, int] = (255, 0, 255)


@dataclass(frozen=True)
class Command:
    """Wheel speeds (m/s, clipped to the robot's limits), an optional pose `estimate`
    (x, y, heading) that the referee scores against the truth, and optional debug drawings."""

    left: float
    right: float
    estimate: tuple[float, float, float] | None = None
    debug: tuple[Drawing, ...] = ()


class Controller:
    """Base class of a team's controller. Override `setup` and `step`.

    `api_version` is the controller API the class was written for; the controller process
    reports it when it has loaded the class, and a referee that speaks another version refuses
    the team in one line instead of failing on some later message."""

    api_version: int = API_VERSION

    def setup(self, brief: Brief) -> None:
        """Called once before the match with what the team may know."""

    def step(self, observation: Observation) -> Command:
        """Called every control period; return the wheel command for the next period."""
        raise NotImplementedError
