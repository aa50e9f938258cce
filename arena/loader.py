"""Load and validate a level YAML file into an immutable `Level`.

Every problem becomes a `LevelError` whose text is one line naming the file, the line
and the key (`levels/x.yaml:12: robots[0].start: outside the field`), so the command
line can print it and exit 2 without a traceback.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import yaml

import levels
from arena import level_checks
from arena.errors import LaserArenaError
from arena.level import (
    Beacon,
    Beacons,
    ControllerLimits,
    DriveErrors,
    Field,
    Floor,
    Laser,
    Level,
    Obstacle,
    Placement,
    Pose,
    RobotSlot,
    Rules,
    Task,
    Tiles,
    Trials,
)
from arena.robot_models import ROBOT_MODELS
from arena.units import LENGTH_UNITS

TASK_KINDS = ("waypoints", "goto", "localize", "race")

# Per-kind hardware parameters: name -> (quantity, default in SI units).
# Quantities: "length" and "speed" are converted from the file's units, "angle" from degrees.
COMMON_PARAMS: dict[str, tuple[str, float]] = {
    "quantization": ("count", 0),  # binary angle steps per turn; 0 = none
    "timing_noise": ("number", 0.0),  # s, std of the event clock
    "wobble": ("number", 0.0),  # relative std of the laser spin rate
    "wobble_time": ("number", 1.0),  # s, correlation time of the wobble
    "placement_error": ("length", 0.0),  # how far a beacon may really stand from its map position
    "spin_coupling": ("number", 0.0),  # steady loss of relative spin rate per unit body yaw rate
    "spin_time": ("number", 0.0),  # s, time the laser motor takes to recover from a turn; 0 = it never lags
}
# A finite beam sweeping a finite detector (docs/sensors.md, "Optics").
OPTICS_PARAMS: dict[str, tuple[str, float]] = {
    "beam_diameter": ("length", 0.0),
    "beam_divergence": ("angle", 0.0),  # full angle
    "aperture": ("length", 0.0),  # detector width across the beam
    "trigger_fraction": ("number", 0.0),  # fraction of the beam's power that fires the comparator
    "rise_time": ("number", 0.0),  # s the light must stay above the threshold
    "acceptance": ("angle", math.inf),  # incidence at which the detector's response halves
    "light_noise": ("number", 0.0),  # std of ln(light reaching the detector), sweep to sweep
}
OPTICS_KINDS = ("sensor_array", "flash_detector")  # the kinds whose detectors see a finite beam
BEACON_PARAMS: dict[str, dict[str, tuple[str, float]]] = {
    "reflector": {
        "range": ("length", math.inf),
        "max_incidence": ("angle", math.radians(90.0)),
        "false_rate": ("number", 0.0),  # false returns per second
    },
    "sensor_array": {
        **OPTICS_PARAMS,
        "merge_rate": ("number", 0.0),  # merged measurements per revolution
        "false_rate": ("number", 0.0),  # false pulses per second
        "clock_hz": ("number", 20e6),
    },
    "flash_detector": {
        **OPTICS_PARAMS,
        "counts_per_turn": ("count", 12500),
        "near_range": ("length", 0.3048),
        "near_incidence": ("angle", math.radians(44.0)),
        "far_range": ("length", 7 * 0.3048),
        "far_incidence": ("angle", math.radians(27.0)),
    },
    "light": {
        "samples_per_turn": ("count", 120),
        "beam_width": ("angle", math.radians(6.0)),
        "brightness_noise": ("number", 0.0),
        "servo_jitter": ("angle", 0.0),
        "saturation_range": ("length", 1.0),  # closer than this, a light saturates the sensor
    },
}
DEFAULT_BEACON_RADIUS = 0.02  # m


class LevelError(LaserArenaError):
    """A level file problem, printed as one line: `file:line: key: message`."""

    def __init__(self, source: str, line: int | None, key: str, message: str):
        self.source, self.line, self.key, self.message = source, line, key, message
        super().__init__(str(self))

    def __str__(self) -> str:
        where = f"{self.source}:{self.line}" if self.line else self.source
        return f"{where}: {self.key}: {self.message}" if self.key else f"{where}: {self.message}"


@dataclass
class _Node:
    """A YAML value with the 1-based line it starts on."""

    value: Any
    line: int


def _locate(node: yaml.Node, source: str) -> _Node:
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, _Node] = {}
        keylines: dict[str, int] = {}
        for knode, vnode in node.value:
            key = _locate(knode, source).value
            if not isinstance(key, str):
                raise LevelError(source, knode.start_mark.line + 1, str(key), "keys must be text")
            if key in out:
                raise LevelError(source, knode.start_mark.line + 1, key, "duplicate key")
            out[key] = _locate(vnode, source)
            keylines[key] = knode.start_mark.line + 1
        return _Node(_MapValue(out, keylines), line)
    if isinstance(node, yaml.SequenceNode):
        return _Node([_locate(n, source) for n in node.value], line)
    return _Node(yaml.constructor.SafeConstructor().construct_object(node), line)


@dataclass
class _MapValue:
    items: dict[str, _Node]
    keylines: dict[str, int]


class _Ctx:
    """Conversion context: the source name and the file's length unit."""

    def __init__(self, source: str):
        self.source = source
        self.scale = 1.0

    def fail(self, line: int | None, key: str, message: str) -> LevelError:
        return LevelError(self.source, line, key, message)


@dataclass
class Shape:
    """What the loader read at one mapping of a level file (`arena/level_schema.py` makes the
    published JSON Schema from these): its allowed keys, each key's converters, how many times
    the mapping was read and each key required, and the keys that held lists."""

    keys: set[str] = dataclasses.field(default_factory=set)
    converters: dict[str, list[Callable[..., Any]]] = dataclasses.field(default_factory=dict)  # in first use order
    reads: int = 0
    required: dict[str, int] = dataclasses.field(default_factory=dict)
    lists: set[str] = dataclasses.field(default_factory=set)

    def note(self, key: str, conv: Callable[..., Any]) -> None:
        """`key` was read through `conv` (a key may take several forms: a number or a point)."""
        known = self.converters.setdefault(key, [])
        if conv not in known:
            known.append(conv)

    def always_required(self) -> list[str]:
        """The keys every reading of this mapping required (none that some reading let go)."""
        return sorted(k for k, n in self.required.items() if n == self.reads)


# while set (by the schema's maker), each mapping read records its Shape under its path, list
# positions written `[]`: the schema comes from the very calls that read levels
SHAPES: ContextVar[dict[str, Shape] | None] = ContextVar("SHAPES", default=None)


class _Map:
    """A YAML mapping being read: typed getters, and unknown keys rejected up front."""

    def __init__(self, ctx: _Ctx, node: _Node, path: str, allowed: tuple[str, ...]):
        if not isinstance(node.value, _MapValue):
            raise ctx.fail(node.line, path or "(top)", f"expected a mapping, got {_kind(node.value)}")
        self.ctx, self.node, self.path = ctx, node, path
        shapes = SHAPES.get()
        self.shape = None if shapes is None else shapes.setdefault(re.sub(r"\[\d+\]", "[]", path), Shape())
        if self.shape is not None:
            self.shape.keys.update(allowed)
            self.shape.reads += 1
        for key in node.value.items:
            if key not in allowed:
                raise ctx.fail(
                    node.value.keylines[key], self.key(key), f"unknown key (expected one of: {', '.join(allowed)})"
                )

    def key(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.node.value.items

    def raw(self, key: str) -> _Node:
        if not self.has(key):
            raise self.ctx.fail(self.node.line, self.key(key), "missing required key")
        return self.node.value.items[key]

    def req(self, key: str, conv: Callable[[_Ctx, _Node, str], Any]) -> Any:
        if self.shape is not None:
            self.shape.note(key, conv)
            self.shape.required[key] = self.shape.required.get(key, 0) + 1
        return conv(self.ctx, self.raw(key), self.key(key))

    def opt(self, key: str, conv: Callable[[_Ctx, _Node, str], Any], default: Any) -> Any:
        if self.shape is not None:
            self.shape.note(key, conv)
        return conv(self.ctx, self.raw(key), self.key(key)) if self.has(key) else default

    def sub(self, key: str, allowed: tuple[str, ...]) -> _Map:
        return _Map(self.ctx, self.raw(key), self.key(key), allowed)

    def seq(self, key: str) -> list[tuple[_Node, str]]:
        if self.shape is not None:
            self.shape.lists.add(key)
        node = self.raw(key)
        if not isinstance(node.value, list):
            raise self.ctx.fail(node.line, self.key(key), f"expected a list, got {_kind(node.value)}")
        return [(n, f"{self.key(key)}[{i}]") for i, n in enumerate(node.value)]


def _kind(value: Any) -> str:
    if isinstance(value, _MapValue):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if value is None:
        return "nothing"
    return f"{type(value).__name__} {value!r}"


# ---- scalar converters: (ctx, node, key) -> value -------------------------------------------


def _number(ctx: _Ctx, node: _Node, key: str) -> float:
    v = node.value
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ctx.fail(node.line, key, f"expected a number, got {_kind(v)}")
    if not math.isfinite(v):
        raise ctx.fail(node.line, key, "must be finite")
    return float(v)


def _positive(ctx: _Ctx, node: _Node, key: str) -> float:
    v = _number(ctx, node, key)
    if v <= 0:
        raise ctx.fail(node.line, key, f"must be positive, got {v:g}")
    return v


def _nonnegative(ctx: _Ctx, node: _Node, key: str) -> float:
    v = _number(ctx, node, key)
    if v < 0:
        raise ctx.fail(node.line, key, f"must not be negative, got {v:g}")
    return v


def _integer(ctx: _Ctx, node: _Node, key: str) -> int:
    v = node.value
    if isinstance(v, bool) or not isinstance(v, int):
        raise ctx.fail(node.line, key, f"expected a whole number, got {_kind(v)}")
    return v


def _count(ctx: _Ctx, node: _Node, key: str) -> int:
    v = _integer(ctx, node, key)
    if v < 0:
        raise ctx.fail(node.line, key, f"must not be negative, got {v}")
    return v


def _text(ctx: _Ctx, node: _Node, key: str) -> str:
    if not isinstance(node.value, str) or not node.value.strip():
        raise ctx.fail(node.line, key, f"expected text, got {_kind(node.value)}")
    return node.value


def _flag(ctx: _Ctx, node: _Node, key: str) -> bool:
    if not isinstance(node.value, bool):
        raise ctx.fail(node.line, key, f"expected true or false, got {_kind(node.value)}")
    return node.value


def _choice(*options: str) -> Callable[[_Ctx, _Node, str], str]:
    def conv(ctx: _Ctx, node: _Node, key: str) -> str:
        v = _text(ctx, node, key)
        if v not in options:
            raise ctx.fail(node.line, key, f"must be one of {', '.join(options)}, got {v!r}")
        return v

    return conv


def _numbers(ctx: _Ctx, node: _Node, key: str, n: int, what: str) -> list[float]:
    if not isinstance(node.value, list) or len(node.value) != n:
        raise ctx.fail(node.line, key, f"expected {what}, got {_kind(node.value)}")
    return [_number(ctx, item, key) for item in node.value]


def _length(ctx: _Ctx, node: _Node, key: str) -> float:
    return _positive(ctx, node, key) * ctx.scale


def _length_signed(ctx: _Ctx, node: _Node, key: str) -> float:
    return _number(ctx, node, key) * ctx.scale


def _point(ctx: _Ctx, node: _Node, key: str) -> tuple[float, float]:
    x, y = _numbers(ctx, node, key, 2, "a point [x, y]")
    return (x * ctx.scale, y * ctx.scale)


def _size(ctx: _Ctx, node: _Node, key: str) -> tuple[float, float]:
    w, h = _numbers(ctx, node, key, 2, "a size [width, height]")
    if w <= 0 or h <= 0:
        raise ctx.fail(node.line, key, f"sizes must be positive, got [{w:g}, {h:g}]")
    return (w * ctx.scale, h * ctx.scale)


def _pose(ctx: _Ctx, node: _Node, key: str) -> Pose:
    x, y, h = _numbers(ctx, node, key, 3, "a pose [x, y, heading_deg]")
    return Pose(x * ctx.scale, y * ctx.scale, math.radians(h))


def _rectangle(ctx: _Ctx, node: _Node, key: str) -> tuple[float, float, float, float]:
    """A rectangle [[xmin, ymin], [xmax, ymax]] as (xmin, ymin, xmax, ymax)."""
    if not isinstance(node.value, list) or len(node.value) != 2:
        raise ctx.fail(node.line, key, f"expected a rectangle [[xmin, ymin], [xmax, ymax]], got {_kind(node.value)}")
    (x0, y0), (x1, y1) = (_point(ctx, corner, key) for corner in node.value)
    if not (x0 < x1 and y0 < y1):
        raise ctx.fail(node.line, key, "the first corner must lie below and left of the second")
    return (x0, y0, x1, y1)


def _half_turn(ctx: _Ctx, node: _Node, key: str) -> float:
    """An angular spread in degrees, 0..180 (180: any heading), in radians."""
    v = _nonnegative(ctx, node, key)
    if v > 180:
        raise ctx.fail(node.line, key, f"must be at most 180 degrees (any heading), got {v:g}")
    return math.pi if v == 180 else math.radians(v)


def _points(ctx: _Ctx, node: _Node, key: str) -> tuple[tuple[float, float], ...]:
    if not isinstance(node.value, list) or not node.value:
        raise ctx.fail(node.line, key, f"expected a list of points, got {_kind(node.value)}")
    return tuple(_point(ctx, item, f"{key}[{i}]") for i, item in enumerate(node.value))


# ---- the level ------------------------------------------------------------------------------


# whether a level's default controller exists: (spec, level folder) -> (spec with a file made
# absolute, problem or None). The referee knows what a controller is (referee.sandbox.teams);
# the physical world does not, so a caller who wants the check passes it in.
ControllerCheck = Callable[[str, Path], tuple[str, str | None]]


def find_level(name: str, controllers: ControllerCheck | None = None) -> Level:
    """Load a level by path, or by built-in name (`asabe`); `LevelError` if there is neither."""
    p = Path(name)
    if p.is_file():
        return load_level(p, controllers=controllers)
    if name in levels.names():
        return load_level(levels.path(name), display=f"levels/{name}.yaml", controllers=controllers)
    if p.suffix in (".yaml", ".yml") or p.parent != Path("."):
        return load_level(p, controllers=controllers)  # reports the unreadable file
    raise LevelError(name, None, "", "no such level file or built-in level (see `laserarena levels`)")


def load_level(path: str | Path, display: str | None = None, controllers: ControllerCheck | None = None) -> Level:
    """Read, parse and validate a level file; raise `LevelError` on any problem."""
    source = display or str(path)
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_LEVEL_BYTES + 1)  # no more: parse_level refuses a longer file
    except OSError as e:
        raise LevelError(source, None, "(file)", f"cannot read: {e.strerror or e}") from None
    return parse_level(data, source, base=Path(path).resolve().parent, controllers=controllers)


MAX_LEVEL_BYTES = level_checks.MAX_BYTES


def parse_level(
    data: bytes, source: str, base: Path | None = None, controllers: ControllerCheck | None = None
) -> Level:
    """Parse and validate level YAML bytes; `source` names the file in errors. With `base`, the
    level file's folder, the checks that concern a contest rather than the physics run too:
    there must be enough beacons for a fix, and, given `controllers`, the default controller
    must exist (a file found relative to `base`). A replay's level text is parsed without `base` (its controller
    may live elsewhere), as are test fixtures that simulate, say, two lights."""
    ctx = _Ctx(source)
    problem = level_checks.text_problem(data)
    if problem:
        raise LevelError(source, problem.line, problem.key, problem.message)
    try:
        text = data.decode("utf-8")
        root = yaml.compose(text, Loader=yaml.SafeLoader)  # bounded: text_problem ran first
    except UnicodeDecodeError as e:
        raise LevelError(source, None, "(file)", f"not UTF-8 text ({e.reason})") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        reason = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise LevelError(source, mark.line + 1 if mark else None, "(yaml)", f"malformed YAML: {reason}") from None
    if root is None:
        raise LevelError(source, 1, "(top)", "the file is empty")
    located = _locate(root, source)
    top = _Map(
        ctx,
        located,
        "",
        (
            "name",
            "description",
            "units",
            "seed",
            "time_limit",
            "physics_rate",
            "control_period",
            "record_rate",
            "field",
            "obstacles",
            "beacons",
            "laser",
            "robots",
            "task",
            "default_controller",
            "limits",
            "rules",
            "floor",
        ),
    )

    units = top.opt("units", _choice(*LENGTH_UNITS), "m")
    ctx.scale = LENGTH_UNITS[units]

    physics_rate = top.opt("physics_rate", _integer, 240)
    if physics_rate <= 0:
        raise ctx.fail(top.raw("physics_rate").line, "physics_rate", "must be positive")
    control_period = top.req("control_period", _positive)
    steps = control_period * physics_rate
    if abs(steps - round(steps)) > 1e-6 or round(steps) < 1:
        raise ctx.fail(
            top.raw("control_period").line,
            "control_period",
            f"{control_period:g} s is not a whole multiple of the physics step 1/{physics_rate} s",
        )
    record_rate = top.opt("record_rate", _integer, DEFAULT_RECORD_RATE)
    if record_rate <= 0 or physics_rate % record_rate:
        raise _rate_problem(ctx, top, physics_rate, record_rate)

    fmap = top.sub("field", ("size", "origin", "walls"))
    fld = Field(
        origin=fmap.opt("origin", _point, (0.0, 0.0)),
        size=fmap.req("size", _size),
        walls=fmap.opt("walls", _flag, True),
    )

    obstacles = tuple(_obstacle(ctx, n, k, fld) for n, k in top.seq("obstacles")) if top.has("obstacles") else ()
    beacons = _beacons(ctx, top.sub("beacons", ("kind", "radius", "params", "items", "crosstalk")), fld)
    default_laser = _laser(top.sub("laser", LASER_KEYS))
    task_map = top.sub("task", ("kind", "radius", "path", "goal", "trials"))
    task, shared_path = _task(ctx, task_map, fld)
    floor = Floor()
    if top.has("floor"):
        floor_map = top.sub("floor", ("tilt", "tilt_length", "tiles"))
        floor = _floor(floor_map, fld)
        if floor.tiles is not None and not task.trials.positions:
            line = floor_map.raw("tiles").line
            raise ctx.fail(line, "floor.tiles", "tiles lay out listed trial positions, and the task lists none")

    robot_nodes = top.seq("robots")
    if not robot_nodes:
        raise ctx.fail(top.raw("robots").line, "robots", "at least one robot is required")
    robots = [_robot(ctx, n, k, i, fld, default_laser, task, shared_path) for i, (n, k) in enumerate(robot_nodes)]
    for r, (node, _key) in zip(robots, robot_nodes):
        turn = (abs(r.laser.angular_velocity) + 2 * r.model.max_wheel_speed / r.model.track) / physics_rate
        if turn >= math.pi / 2:
            where = top.raw("laser") if r.laser is default_laser else node
            raise ctx.fail(
                where.line,
                "laser.angular_velocity",
                f"the beam would turn {math.degrees(turn):.0f} deg per physics step; keep it "
                f"under 90 by raising physics_rate",
            )
    slots = sorted(r.slot for r in robots)
    if slots != list(range(len(robots))):
        raise ctx.fail(top.raw("robots").line, "robots", f"slots must be 0..{len(robots) - 1} once each, got {slots}")
    if task.kind == "race" and len(robots) < 2:
        raise ctx.fail(task_map.node.line, "task.kind", "a race needs at least two robots")

    default_controller = top.req("default_controller", _text)
    if base is not None and controllers is not None:
        default_controller, why = controllers(default_controller, base)
        if why:
            raise ctx.fail(top.raw("default_controller").line, "default_controller", f"{default_controller}: {why}")
    level = Level(
        name=top.req("name", _text),
        description=top.req("description", _text),
        source=source,
        hash="sha256:" + hashlib.sha256(data).hexdigest(),
        units=units,
        seed=top.opt("seed", _count, 0),
        time_limit=top.req("time_limit", _positive),
        physics_rate=physics_rate,
        control_period=control_period,
        record_rate=record_rate,
        field=fld,
        obstacles=obstacles,
        beacons=beacons,
        robots=tuple(sorted(robots, key=lambda r: r.slot)),
        task=task,
        default_controller=default_controller,
        limits=_limits(top.sub("limits", LIMIT_KEYS)) if top.has("limits") else ControllerLimits(),
        rules=_rules(top.sub("rules", RULE_KEYS)) if top.has("rules") else Rules(),
        floor=floor,
        text=text,
    )
    problem = level_checks.level_problem(level, contest=base is not None)
    if problem:
        raise ctx.fail(problem.line or _line_of(located, problem.key), problem.key, problem.message)
    if task.trials.count > level.control_ticks:
        raise ctx.fail(
            _line_of(located, "task.trials.count"),
            "task.trials.count",
            f"{task.trials.count} trials in a match of {level.control_ticks} control periods",
        )
    return level


DEFAULT_RECORD_RATE = 30  # replay frames per second


def _rate_problem(ctx: _Ctx, top: _Map, physics_rate: int, record_rate: int) -> LevelError:
    """record_rate must divide physics_rate; when it was left at its default, the fault is the
    physics_rate the file does give, so say that rather than blame a key that is not there."""
    divisors = [d for d in range(1, physics_rate + 1) if physics_rate % d == 0 and 10 <= d <= 60]
    hint = f" (e.g. {' or '.join(map(str, divisors[:3]))})" if divisors else ""
    if not top.has("record_rate"):
        return ctx.fail(
            top.raw("physics_rate").line,
            "physics_rate",
            f"{physics_rate} Hz is not a multiple of the default record_rate {record_rate} Hz; "
            f"give a physics_rate that is, or set record_rate to a divisor of {physics_rate}{hint}",
        )
    return ctx.fail(
        top.raw("record_rate").line,
        "record_rate",
        f"{record_rate} Hz must be positive and divide physics_rate {physics_rate} Hz{hint}",
    )


def _line_of(root: _Node, key: str) -> int | None:
    """The file line of a dotted key such as `robots[0].start` (None if it is not in the file)."""
    node: _Node | None = root
    line = root.line
    for name, index in re.findall(r"([^.\[\]]+)|\[(\d+)\]", key):
        if node is None:
            break
        if name and isinstance(node.value, _MapValue) and name in node.value.items:
            line, node = node.value.keylines[name], node.value.items[name]
        elif index and isinstance(node.value, list) and int(index) < len(node.value):
            node = node.value[int(index)]
            line = node.line
        else:
            break
    return line


RULE_KEYS = ("speed_limit", "min_impulse", "position_scale", "heading_scale", "penalties")


def _rules(m: _Map) -> Rules:
    d = Rules()
    penalties = dict(d.penalties)
    if m.has("penalties"):
        pm = m.sub("penalties", tuple(d.penalties))
        for name in d.penalties:
            penalties[name] = pm.opt(name, _nonnegative, penalties[name])
    return Rules(
        speed_limit=m.opt("speed_limit", _nonnegative, 0.0) * m.ctx.scale,
        min_impulse=m.opt("min_impulse", _nonnegative, d.min_impulse),
        position_scale=m.opt("position_scale", _length, d.position_scale),
        heading_scale=math.radians(m.opt("heading_scale", _positive, math.degrees(d.heading_scale))),
        penalties=MappingProxyType(penalties),
    )


LIMIT_KEYS = (
    "setup_time",
    "step_time",
    "step_deadline",
    "overage_bank",
    "max_skips",
    "think_budget",
    "memory_mb",
    "log_kb",
)


def _limits(m: _Map) -> ControllerLimits:
    d = ControllerLimits()
    skips = m.opt("max_skips", _count, d.max_skips)
    if skips < 1:
        raise m.ctx.fail(m.raw("max_skips").line, m.key("max_skips"), "must be at least 1")
    step_time = m.opt("step_time", _positive, d.step_time)
    deadline = m.opt("step_deadline", _positive, max(d.step_deadline, step_time))
    if deadline < step_time:
        raise m.ctx.fail(m.raw("step_deadline").line, m.key("step_deadline"), "must not be below step_time")
    return ControllerLimits(
        setup_time=m.opt("setup_time", _positive, d.setup_time),
        step_time=step_time,
        step_deadline=deadline,
        overage_bank=m.opt("overage_bank", _nonnegative, d.overage_bank),
        max_skips=skips,
        think_budget=m.opt("think_budget", _positive, d.think_budget),
        memory=int(m.opt("memory_mb", _positive, d.memory / 2**20) * 2**20),
        log_bytes=int(m.opt("log_kb", _positive, d.log_bytes / 1024) * 1024),
    )


def _inside(ctx: _Ctx, fld: Field, p: tuple[float, float], line: int, key: str, what: str) -> None:
    if not fld.contains(*p):
        s = ctx.scale
        raise ctx.fail(
            line,
            key,
            f"{what} ({p[0] / s:g}, {p[1] / s:g}) is outside the field "
            f"[{fld.xmin / s:g}..{fld.xmax / s:g}] x [{fld.ymin / s:g}..{fld.ymax / s:g}]",
        )


def _obstacle(ctx: _Ctx, node: _Node, key: str, fld: Field) -> Obstacle:
    m = _Map(ctx, node, key, ("kind", "center", "size", "angle", "radius", "points"))
    kind = m.req("kind", _choice("box", "circle", "polygon"))
    if kind == "circle":
        c = m.req("center", _point)
        _inside(ctx, fld, c, m.raw("center").line, m.key("center"), "centre")
        return Obstacle("circle", (c,), m.req("radius", _length))
    if kind == "box":
        (cx, cy), (w, h) = m.req("center", _point), m.req("size", _size)
        _inside(ctx, fld, (cx, cy), m.raw("center").line, m.key("center"), "centre")
        a = math.radians(m.opt("angle", _number, 0.0))
        ca, sa = math.cos(a), math.sin(a)
        corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
        return Obstacle("polygon", tuple((cx + ca * x - sa * y, cy + sa * x + ca * y) for x, y in corners))
    pts = m.req("points", _points)
    if len(pts) < 3:
        raise ctx.fail(m.raw("points").line, m.key("points"), "a polygon needs at least 3 points")
    why = level_checks.convex_problem(pts)
    if why:
        raise ctx.fail(m.raw("points").line, m.key("points"), why)
    for i, p in enumerate(pts):
        _inside(ctx, fld, p, m.raw("points").line, f"{m.key('points')}[{i}]", "point")
    return Obstacle("polygon", pts)


def _beacons(ctx: _Ctx, m: _Map, fld: Field) -> Beacons:
    kind = m.req("kind", _choice(*BEACON_PARAMS))
    schema = {**COMMON_PARAMS, **BEACON_PARAMS[kind]}
    params = {name: default for name, (_, default) in schema.items()}
    if m.has("params"):
        pm = m.sub("params", tuple(schema))
        for name, (quantity, _) in schema.items():
            if not pm.has(name):
                continue
            if quantity == "count":
                params[name] = pm.req(name, _count)
            elif quantity == "angle":
                params[name] = math.radians(pm.req(name, _nonnegative))
            elif quantity in ("length", "speed"):
                params[name] = pm.req(name, _positive) * ctx.scale
            else:
                params[name] = pm.req(name, _nonnegative)
    items: list[Beacon] = []
    for node, key in m.seq("items"):
        b = _Map(ctx, node, key, ("id", "at", "facing", "gain"))
        bid = str(b.req("id", _scalar_id))
        if any(o.id == bid for o in items):
            raise ctx.fail(b.raw("id").line, b.key("id"), f"duplicate beacon id {bid!r}")
        at = b.req("at", _point)
        _inside(ctx, fld, at, b.raw("at").line, b.key("at"), "beacon")
        facing = _facing(ctx, b, at, fld.center)
        if b.has("gain") and kind not in OPTICS_KINDS:
            raise ctx.fail(
                b.raw("gain").line, b.key("gain"), "a gain applies to sensor_array and flash_detector beacons"
            )
        items.append(Beacon(bid, at[0], at[1], facing, b.opt("gain", _positive, 1.0)))
    if not items:
        raise ctx.fail(m.raw("items").line, m.key("items"), "at least one beacon is required")
    radius = m.opt("radius", _length, DEFAULT_BEACON_RADIUS)
    crosstalk = m.opt("crosstalk", _choice("coded", "shared"), "coded")
    if crosstalk == "shared" and kind != "sensor_array":
        raise ctx.fail(
            m.raw("crosstalk").line, m.key("crosstalk"), "shared crosstalk applies to sensor_array beacons only"
        )
    return Beacons(kind=kind, items=tuple(items), radius=radius, params=MappingProxyType(params), crosstalk=crosstalk)


def _scalar_id(ctx: _Ctx, node: _Node, key: str) -> str:
    if isinstance(node.value, bool) or not isinstance(node.value, (str, int)):
        raise ctx.fail(node.line, key, f"expected a name or number, got {_kind(node.value)}")
    return str(node.value)


def _facing(ctx: _Ctx, b: _Map, at: tuple[float, float], center: tuple[float, float]) -> float:
    """A beacon faces a direction in degrees, or towards a point [x, y]; default: the field centre."""
    if not b.has("facing"):
        target = center
    elif isinstance(b.raw("facing").value, list):
        target = b.req("facing", _point)
    else:
        return math.radians(b.req("facing", _number))
    if math.dist(target, at) < 1e-12:
        raise ctx.fail(b.node.line, b.key("facing"), "a beacon cannot face the point it stands on")
    return math.atan2(target[1] - at[1], target[0] - at[0])


LASER_KEYS = ("angular_velocity", "index", "beam_offset", "height")


def _laser(m: _Map) -> Laser:
    w = m.req("angular_velocity", _number)
    if w == 0:
        raise m.ctx.fail(m.raw("angular_velocity").line, m.key("angular_velocity"), "must not be zero")
    return Laser(
        angular_velocity=w,
        index=m.opt("index", _flag, False),
        beam_offset=m.opt("beam_offset", _length_signed, 0.0),
        height=m.opt("height", _nonnegative, 0.0) * m.ctx.scale,
    )


def _floor(m: _Map, fld: Field) -> Floor:
    """The floor's tilt (RMS slope per axis in degrees, below 45; its correlation length) and
    the tiles trials are measured by."""
    tilt = m.opt("tilt", _nonnegative, 0.0)
    if tilt >= 45:
        raise m.ctx.fail(m.raw("tilt").line, m.key("tilt"), f"must be below 45 degrees, got {tilt:g}")
    tiles = None
    if m.has("tiles"):
        t = m.sub("tiles", ("origin", "spacing_error", "angle_error"))
        origin = t.req("origin", _point)
        _inside(m.ctx, fld, origin, t.raw("origin").line, t.key("origin"), "origin")
        spacing = t.opt("spacing_error", _nonnegative, 0.0)
        if spacing >= 0.5:
            raise m.ctx.fail(t.raw("spacing_error").line, t.key("spacing_error"), f"must be below 0.5, got {spacing:g}")
        angle = t.opt("angle_error", _nonnegative, 0.0)
        if angle >= 45:
            raise m.ctx.fail(
                t.raw("angle_error").line, t.key("angle_error"), f"must be below 45 degrees, got {angle:g}"
            )
        tiles = Tiles(origin=origin, spacing_error=spacing, angle_error=math.radians(angle))
    return Floor(
        tilt=math.tan(math.radians(tilt)),
        tilt_length=m.opt("tilt_length", _length, 1.0),
        tiles=tiles,
    )


def _task(ctx: _Ctx, m: _Map, fld: Field) -> tuple[Task, tuple[tuple[float, float], ...]]:
    kind = m.req("kind", _choice(*TASK_KINDS))
    path: tuple[tuple[float, float], ...] = ()
    goal = None
    radius = 0.0
    if kind in ("waypoints", "goto", "race"):
        radius = m.req("radius", _length)
    if kind == "waypoints":
        path = m.opt("path", _points, ())  # else each robot names its own
    elif kind == "goto":
        g = m.raw("goal")
        vals = g.value if isinstance(g.value, list) else None
        goal = (
            _pose(ctx, g, m.key("goal"))
            if vals is not None and len(vals) == 3
            else Pose(*_point(ctx, g, m.key("goal")), math.nan)
        )
        _inside(ctx, fld, (goal.x, goal.y), g.line, m.key("goal"), "goal")
    for key, allowed in (("path", ("waypoints",)), ("goal", ("goto",))):
        if m.has(key) and kind not in allowed:
            raise ctx.fail(m.raw(key).line, m.key(key), f"not used by a {kind} task")
    if kind == "localize" and m.has("radius"):
        raise ctx.fail(m.raw("radius").line, m.key("radius"), "not used by a localize task")
    for i, p in enumerate(path):
        _inside(ctx, fld, p, m.raw("path").line, f"{m.key('path')}[{i}]", "waypoint")
    trials = Trials()
    if m.has("trials"):
        if kind != "localize":
            raise ctx.fail(m.raw("trials").line, m.key("trials"), f"not used by a {kind} task (only by localize)")
        trials = _trials(ctx, m.sub("trials", ("count", "positions", "region", "headings")), fld)
    return Task(kind=kind, radius=radius, goal=goal, trials=trials), path


def _trials(ctx: _Ctx, m: _Map, fld: Field) -> Trials:
    """A localize task's trials: how many, and where their secret poses come from."""
    count = m.req("count", _count)
    if count < 1:
        raise ctx.fail(m.raw("count").line, m.key("count"), "at least one trial (the start)")
    if m.has("positions") and m.has("region"):
        raise ctx.fail(m.raw("region").line, m.key("region"), "give positions or a region, not both")
    if count > 1 and not (m.has("positions") or m.has("region")):
        raise ctx.fail(m.node.line, m.key("positions"), "trials after the first need positions or a region")
    positions = m.opt("positions", _points, ())
    for i, p in enumerate(positions):
        _inside(ctx, fld, p, m.raw("positions").line, f"{m.key('positions')}[{i}]", "trial position")
    region = m.opt("region", _rectangle, None)
    if region is not None:
        for corner in (region[:2], region[2:]):
            _inside(ctx, fld, corner, m.raw("region").line, m.key("region"), "corner")
    headings: tuple[float, ...] = ()
    if m.has("headings"):
        node = m.raw("headings")
        if not isinstance(node.value, list) or not node.value:
            raise ctx.fail(node.line, m.key("headings"), f"expected a list of headings (deg), got {_kind(node.value)}")
        headings = tuple(math.radians(_number(ctx, n, f"{m.key('headings')}[{i}]")) for i, n in enumerate(node.value))
    return Trials(count=count, positions=positions, region=region, headings=headings)


def _placement(ctx: _Ctx, m: _Map, fld: Field) -> Placement:
    """How a robot is set down around its nominal start (and each trial's pose)."""
    if m.has("position") and m.has("region"):
        raise ctx.fail(m.raw("region").line, m.key("region"), "give a position spread or a region, not both")
    region = m.opt("region", _rectangle, None)
    if region is not None:
        for corner in (region[:2], region[2:]):
            _inside(ctx, fld, corner, m.raw("region").line, m.key("region"), "corner")
    return Placement(
        position=m.opt("position", _nonnegative, 0.0) * ctx.scale,
        heading=m.opt("heading", _half_turn, 0.0),
        region=region,
    )


DRIVE_KEYS = tuple(f.name for f in dataclasses.fields(DriveErrors))
# Largest allowed value per drive key: spreads stay far from a negative gain or track, a
# dead band below top speed, slips below the whole motion.
DRIVE_MAX = {
    "gain_sd": 0.2,
    "radius_sd": 0.2,
    "track_sd": 0.2,
    "dead_band": 0.9,
    "turn_slip": 0.9,
    "turn_slip_sd": 0.5,
    "accel_slip": 0.9,
}


def _drive(m: _Map, base: DriveErrors) -> DriveErrors:
    """A robot's drive errors: the model's, with the keys the level gives replaced."""
    values = {}
    for key in DRIVE_KEYS:
        if m.has(key):
            v = m.req(key, _nonnegative)
            if v > DRIVE_MAX.get(key, math.inf):
                raise m.ctx.fail(m.raw(key).line, m.key(key), f"must be at most {DRIVE_MAX[key]:g}, got {v:g}")
            values[key] = v
    return dataclasses.replace(base, **values)


def _robot(
    ctx: _Ctx,
    node: _Node,
    key: str,
    index: int,
    fld: Field,
    default_laser: Laser,
    task: Task,
    shared_path: tuple[tuple[float, float], ...],
) -> RobotSlot:
    m = _Map(
        ctx, node, key, ("slot", "model", "start", "placement", "start_known", "laser", "path", "drive", "silhouette")
    )
    model_name = m.opt("model", _choice(*ROBOT_MODELS), "boe-bot")
    model = ROBOT_MODELS[model_name]
    if m.has("drive"):
        model = dataclasses.replace(model, drive=_drive(m.sub("drive", DRIVE_KEYS), model.drive))
    if m.has("silhouette"):  # the radius of what this robot puts in the laser plane
        model = dataclasses.replace(model, silhouette_radius=m.req("silhouette", _length))
    start = m.req("start", _pose)
    line = m.raw("start").line
    _inside(ctx, fld, (start.x, start.y), line, m.key("start"), "start")
    c, s = math.cos(start.heading), math.sin(start.heading)
    for dx in (-model.length / 2, model.length / 2):
        for dy in (-model.width / 2, model.width / 2):
            corner = (start.x + c * dx - s * dy, start.y + s * dx + c * dy)
            if not fld.contains(*corner):
                raise ctx.fail(
                    line, m.key("start"), f"the {model_name} footprint at this start pose reaches outside the field"
                )
    laser = _laser(m.sub("laser", LASER_KEYS)) if m.has("laser") else default_laser
    path = shared_path
    if m.has("path"):
        if task.kind not in ("waypoints", "race"):
            raise ctx.fail(m.raw("path").line, m.key("path"), f"not used by a {task.kind} task")
        path = m.req("path", _points)
        for i, p in enumerate(path):
            _inside(ctx, fld, p, m.raw("path").line, f"{m.key('path')}[{i}]", "waypoint")
    elif task.kind == "race" or (task.kind == "waypoints" and not path):
        raise ctx.fail(
            m.node.line,
            m.key("path"),
            f"missing required key (no task.path to share, and a {task.kind} robot needs a path)",
        )
    return RobotSlot(
        slot=m.opt("slot", _count, index),
        model=model,
        start=start,
        laser=laser,
        start_known=m.opt("start_known", _flag, False),
        path=path,
        placement=_placement(ctx, m.sub("placement", ("position", "heading", "region")), fld)
        if m.has("placement")
        else Placement(),
    )
