"""The controller API: the one contract between the referee and a team's code.

A controller gets a `Brief` once (`setup`) and an `Observation` every control period
(`step`), and answers each step with a `Command`. It never sees its true pose: only the
clock and the times at which its laser met beacons. Everything here is plain data
(frozen dataclasses of numbers, text and tuples) so it can cross a process border: these
classes are the protocol's schema, and their annotations carry the bounds (`robots.bounds`)
a message must keep.

This module imports nothing from `arena` or `referee`: it runs inside a team's process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

from msgspec import Meta

from robots.bounds import MAX_DRAWINGS, MAX_POINTS, MAX_TEXT, Byte, Count, Kind, Name, Point, Real, Size

API_VERSION = 2  # 2: the start announced with its spread (`StartInfo`), localize trials


@dataclass(frozen=True)
class BeaconInfo:
    """A fixed beacon the team may know: its id and position (m)."""

    id: Name
    x: Real
    y: Real


@dataclass(frozen=True)
class LaserInfo:
    """The robot's spinning laser: angular velocity relative to the body (rad/s, + = CCW)
    and whether an index switch reports relative angle 0 (straight ahead)."""

    angular_velocity: Real
    index: bool


@dataclass(frozen=True)
class RobotInfo:
    """The robot's model: footprint (m), wheel track (m) and wheel limits."""

    model: Name
    length: Real
    width: Real
    track: Real
    max_wheel_speed: Real  # m/s; commands are clipped to +-this
    max_wheel_accel: Real  # m/s^2; wheels ramp towards commands at this rate


@dataclass(frozen=True)
class TaskInfo:
    """What this robot must do: `kind` is waypoints | goto | localize | race;
    `path` the waypoints in order, `goal` an (x, y) target, `radius` how close counts;
    `trials` how many trials a localize match holds (the referee moves the robot to a new
    secret pose at the start of each after the first: `Observation.trial` says which).
    A goto robot arrives by standing, its wheels still, for `settle` seconds within `radius`
    of the goal; the arrival is worth 1 / (1 + d / `accuracy`) of the task's points for a
    stop d from the goal. On a waypoint task with an `accuracy` (0: none), each waypoint is
    worth 1 / (1 + e / `accuracy`) of its share, e the RMS distance from the path on the
    leg that led to it (docs/rules.md)."""

    kind: Name
    radius: Real
    path: Annotated[tuple[Point, ...], Meta(max_length=1 << 16)] = ()
    goal: Point | None = None
    trials: Annotated[int, Meta(ge=1, le=1 << 40)] = 1
    settle: Real = 0.0
    accuracy: Real = 0.0


@dataclass(frozen=True)
class StartInfo:
    """What the rules announce of the robot's start (docs/levels.md). The robot stands within
    `position_spread` (m) of (x, y), uniformly over that disc, or, when `region` (xmin, ymin,
    xmax, ymax) is given, anywhere in that rectangle; its heading lies within
    `heading_spread` (rad) either way of `heading`, and `heading_spread` pi means any heading
    at all. Spreads of 0: exactly this pose."""

    x: Real
    y: Real
    heading: Real
    position_spread: Size = 0.0
    heading_spread: Size = 0.0
    region: tuple[Real, Real, Real, Real] | None = None

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

    slot: Count
    field: tuple[Real, Real, Real, Real]  # xmin, ymin, xmax, ymax (m)
    beacon_kind: Name  # reflector | sensor_array | flash_detector | light
    beacons: Annotated[tuple[BeaconInfo, ...], Meta(max_length=4096)]
    laser: LaserInfo
    robot: RobotInfo
    task: TaskInfo
    control_period: Real  # s
    time_limit: Real  # s
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

    time: Real
    kind: Name
    beacon: Name | None = None
    angle: Real | None = None
    samples: Annotated[tuple[Byte, ...], Meta(max_length=1 << 16)] = ()


@dataclass(frozen=True)
class Observation:
    """What the controller learns at a control tick: the clock, the events since the last
    tick, and the localize trial under way (0 first; when it grows, the robot was carried to
    a new pose at the start of this control period, and every event here was sensed there)."""

    tick: Count
    time: Real
    events: Annotated[tuple[SensorEvent, ...], Meta(max_length=1 << 16)] = ()
    trial: Count = 0


@dataclass(frozen=True)
class Drawing:
    """A debug overlay drawn in the replay: `kind` is point | line | circle | text;
    `points` in metres (a drawing without any is set aside with a warning); `radius` for
    circles; `text` for labels; `color` as RGB."""

    kind: Kind
    points: Annotated[tuple[Point, ...], Meta(max_length=MAX_POINTS)] = ()
    radius: Size = 0.0
    text: Annotated[str, Meta(max_length=MAX_TEXT)] = ""
    color: tuple[Byte, Byte, Byte] = (255, 0, 255)


@dataclass(frozen=True)
class Command:
    """Wheel speeds (m/s, clipped to the robot's limits), an optional pose `estimate`
    (x, y, heading) that the referee scores against the truth, and optional debug drawings."""

    left: Real
    right: Real
    estimate: tuple[Real, Real, Real] | None = None
    debug: Annotated[tuple[Drawing, ...], Meta(max_length=MAX_DRAWINGS)] = ()


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
