"""Immutable, typed description of a level: everything in SI units (metres, radians, seconds)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from levels._frozen import reduce_proxies
from levels.match import ControllerLimits, Rules


@dataclass(frozen=True)
class Pose:
    """A planar pose: x east, y north (m), heading counter-clockwise from +x (rad)."""

    x: float
    y: float
    heading: float = 0.0


@dataclass(frozen=True)
class Field:
    """The rectangular playing field: lower-left corner `origin` and `size`."""

    origin: tuple[float, float]
    size: tuple[float, float]
    walls: bool = True

    @property
    def xmin(self) -> float:
        return self.origin[0]

    @property
    def ymin(self) -> float:
        return self.origin[1]

    @property
    def xmax(self) -> float:
        return self.origin[0] + self.size[0]

    @property
    def ymax(self) -> float:
        return self.origin[1] + self.size[1]

    @property
    def center(self) -> tuple[float, float]:
        return (self.xmin + self.size[0] / 2, self.ymin + self.size[1] / 2)

    def contains(self, x: float, y: float, eps: float = 1e-9) -> bool:
        """True if (x, y) is inside the field or on its border."""
        return self.xmin - eps <= x <= self.xmax + eps and self.ymin - eps <= y <= self.ymax + eps


@dataclass(frozen=True)
class Obstacle:
    """A static obstacle: a convex polygon (`points`) or a circle (`points[0]`, `radius`)."""

    kind: str  # "polygon" | "circle"
    points: tuple[tuple[float, float], ...]
    radius: float = 0.0


@dataclass(frozen=True)
class Beacon:
    """One fixed beacon; `facing` is the direction its detector or reflector faces (rad), `gain`
    its detector's response relative to the kind's nominal one (a hand-trimmed array)."""

    id: str
    x: float
    y: float
    facing: float
    gain: float = 1.0


@dataclass(frozen=True)
class Beacons:
    """All beacons of a level: one hardware `kind` with its parameters."""

    kind: str
    items: tuple[Beacon, ...]
    radius: float
    params: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    crosstalk: str = "coded"  # sensor_array: "shared" = every robot sees every laser's pulses

    __reduce__ = reduce_proxies

    def by_id(self, beacon_id: str) -> Beacon:
        for b in self.items:
            if b.id == beacon_id:
                return b
        raise KeyError(beacon_id)


@dataclass(frozen=True)
class Laser:
    """A robot's spinning laser: angular velocity relative to the body (rad/s, + = CCW)."""

    angular_velocity: float
    index: bool
    # how far the beam passes beside the spin axis (m, + = to the beam's left): a laser module
    # clamped beside a motor shaft is never exactly on it; a team is not told (0 when ideal)
    beam_offset: float = 0.0
    # how high above the robot's base the beam leaves (m): where a tilted floor leans the robot,
    # the beam's origin stands that height x the tilt off the base (arena.floor)
    height: float = 0.0

    @property
    def period(self) -> float:
        return 2 * math.pi / abs(self.angular_velocity)


@dataclass(frozen=True)
class DriveErrors:
    """How a real drive departs from its nominal model (docs/drive.md): the spread of each
    robot's constants drawn once per match, and the per-turn and per-command randomness.
    All zero is a perfect drive."""

    gain_sd: float = 0.0  # sd of each wheel's speed gain around 1 (servo and wheel mismatch)
    radius_sd: float = 0.0  # sd of the common wheel-radius scale around 1
    track_sd: float = 0.0  # sd of the true track around the nominal one, as a fraction
    dead_band: float = 0.0  # commands below this fraction of top speed do nothing
    saturation: float = 0.0  # curvature of the servo response (0: linear)
    turn_slip: float = 0.0  # mean fraction of a spin or pivot turn lost to slip
    turn_slip_sd: float = 0.0  # sd of that fraction, drawn per turn command
    accel_slip: float = 0.0  # fraction of the nominal acceleration lost to slip
    latency: float = 0.0  # s from a command to the wheels taking it (one-way link)
    latency_jitter: float = 0.0  # s, uniform extra delay per command


PERFECT_DRIVE = DriveErrors()


@dataclass(frozen=True)
class RobotModel:
    """A differential-drive robot: footprint, mass, wheel track and wheel limits."""

    name: str
    length: float  # along the heading (m)
    width: float  # across (m)
    mass: float  # kg
    track: float  # distance between the wheels (m)
    max_wheel_speed: float  # m/s
    max_wheel_accel: float  # m/s^2
    friction: float  # ground friction coefficient (top-down friction joints)
    drive: DriveErrors = PERFECT_DRIVE  # how the real drive departs from the nominal figures above
    # radius of the circle, at the robot's centre, that another robot's laser plane meets
    # (mast, laser housing): only this blocks beams, not the whole footprint
    silhouette_radius: float = 0.03


@dataclass(frozen=True)
class Placement:
    """How a robot is set down, at the start of a match and of each trial (docs/levels.md):
    within `position` m of the nominal point (uniformly over that disc), or anywhere in
    `region` (xmin, ymin, xmax, ymax); turned up to `heading` rad either way from the nominal
    heading (pi: any heading). All zero: exactly at the nominal pose."""

    position: float = 0.0
    heading: float = 0.0
    region: tuple[float, float, float, float] | None = None

    @property
    def exact(self) -> bool:
        return self.position == 0.0 and self.heading == 0.0 and self.region is None


EXACT = Placement()


@dataclass(frozen=True)
class RobotSlot:
    """One robot in the level: its slot number, model, nominal start pose, how it is really
    set down there (`placement`), whether the rules announce that start, and its laser."""

    slot: int
    model: RobotModel
    start: Pose
    laser: Laser
    start_known: bool
    path: tuple[tuple[float, float], ...] = ()
    placement: Placement = EXACT


@dataclass(frozen=True)
class Trials:
    """A localize task's trials: the match is cut into `count` equal spans, and at the start of
    each span after the first the referee moves the robot to a new secret pose, as the seeds'
    experimenters carried theirs (docs/rules.md). Each trial's nominal pose is a point of
    `positions` (in a shuffled order) or of `region` (uniformly), with one of `headings` (rad),
    or a heading within `heading_spread` (rad) either way of the robot's nominal start heading
    (uniformly), or any heading; the robot's placement then sets it down around it. The first
    trial is the robot's start."""

    count: int = 1
    positions: tuple[tuple[float, float], ...] = ()
    region: tuple[float, float, float, float] | None = None
    headings: tuple[float, ...] = ()
    heading_spread: float | None = None


@dataclass(frozen=True)
class Tiles:
    """The floor tiles an experimenter carried a robot by, trial to trial (Simi's "12 inch
    translations"): a trial's nominal position is a tile value, a point of a square grid whose
    tile `origin` is where the robot started; the real grid's pitch along each axis is off by up
    to `spacing_error` (a fraction) and each set of its lines is turned up to `angle_error` (rad)
    from its axis, both drawn per match (arena.floor)."""

    origin: tuple[float, float]
    spacing_error: float = 0.0
    angle_error: float = 0.0


@dataclass(frozen=True)
class Floor:
    """The floor under the robots: its tilt, a smooth random height field whose slope along each
    axis (dz/dx, dz/dy) has RMS `tilt`, with correlation length `tilt_length` (m), drawn per
    match; and the `tiles` trials are measured by, if any (arena.floor)."""

    tilt: float = 0.0
    tilt_length: float = 1.0
    tiles: Tiles | None = None


@dataclass(frozen=True)
class Task:
    """What the robots must do; `path` per robot lives on RobotSlot (shared path copied there)."""

    kind: str  # waypoints | goto | localize | race
    radius: float = 0.0
    goal: Pose | None = None
    trials: Trials = Trials()
    settle: float = 0.0  # goto: seconds a robot stands, wheels still, within `radius` to arrive
    accuracy: float = 0.0  # the seed's accuracy: points halve a goto stop this far off the goal, or a waypoint
    # whose leg ran this far off the path (RMS); 0 on a waypoint task: every waypoint counts whole


@dataclass(frozen=True)
class Level:
    """A whole level, loaded and validated; `hash` is the SHA-256 of the file's bytes."""

    name: str
    description: str
    source: str
    hash: str
    units: str
    seed: int
    time_limit: float
    physics_rate: int
    control_period: float
    record_rate: int
    field: Field
    obstacles: tuple[Obstacle, ...]
    beacons: Beacons
    robots: tuple[RobotSlot, ...]
    task: Task
    default_controller: str
    limits: ControllerLimits = ControllerLimits()
    rules: Rules = Rules()
    floor: Floor = Floor()
    text: str = ""  # the file's text, so a replay can carry its level whole

    def __deepcopy__(self, memo: dict) -> Level:
        """A Level is immutable all the way down: a deep copy is itself (Gymnasium's make copies its kwargs)."""
        return self

    @property
    def dt(self) -> float:
        return 1.0 / self.physics_rate

    @property
    def steps_per_control(self) -> int:
        return round(self.control_period * self.physics_rate)

    @property
    def control_ticks(self) -> int:
        """The control ticks of a match that runs to its time limit."""
        return math.ceil(self.time_limit / self.control_period - 1e-9)

    @property
    def steps_per_record(self) -> int:
        return self.physics_rate // self.record_rate
