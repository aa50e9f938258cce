"""Load and validate a level YAML file into an immutable `Level`.

Every problem becomes a `LevelError` whose text is one line naming the file, the line
and the key (`levels/x.yaml:12: robots[0].start: outside the field`), so the command
line can print it and exit 2 without a traceback. The file is read with the kit of
levels/yaml_reader.py, each section by its own module: the clocks, limits and rules by
levels/match.py, the field, obstacles and floor by levels/_geometry.py, the
beacons by levels/_beacons.py, the task by levels/_task.py, the robots and lasers
by levels/_robots.py; the checks across sections are levels/checks.py's.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path

import levels
from levels import _beacons, _geometry, _robots, _task, checks, match
from levels import yaml_reader as yr
from levels.match import ControllerLimits, Rules
from levels.model import Field, Floor, Level, Task
from levels.units import LENGTH_UNITS

TOP_KEYS = (
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
)
MAX_LEVEL_BYTES = checks.MAX_BYTES


class LevelError(yr.ReadError):
    """A level file problem, printed as one line: `file:line: key: message`."""


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


def parse_level(
    data: bytes, source: str, base: Path | None = None, controllers: ControllerCheck | None = None
) -> Level:
    """Parse and validate level YAML bytes; `source` names the file in errors. With `base`, the
    level file's folder, the checks that concern a contest rather than the physics run too:
    there must be enough beacons for a fix, and, given `controllers`, the default controller
    must exist (a file found relative to `base`). A replay's level text is parsed without `base` (its controller
    may live elsewhere), as are test fixtures that simulate, say, two lights."""
    ctx = yr.Context(source, LevelError)
    problem = checks.text_problem(data)
    if problem:
        raise LevelError(source, problem.line, problem.key, problem.message)
    text, located = yr.compose(ctx, data)  # bounded: text_problem ran first
    top = yr.Map(ctx, located, "", TOP_KEYS)
    units = top.opt("units", yr.choice(*LENGTH_UNITS), "m")
    ctx.scale = LENGTH_UNITS[units]
    physics_rate, control_period, record_rate = match.clocks(top)
    fld = _geometry.field(top.sub("field", _geometry.FIELD_KEYS))
    obstacles = (
        tuple(_geometry.obstacle(ctx, n, k, fld) for n, k in top.seq("obstacles")) if top.has("obstacles") else ()
    )
    beacons = _beacons.beacons(top.sub("beacons", _beacons.BEACONS_KEYS), fld)
    default_laser = _robots.laser(top.sub("laser", _robots.LASER_KEYS))
    task_map = top.sub("task", _task.TASK_KEYS)
    task, shared_path = _task.task(task_map, fld)
    floor = _floor(top, fld, task)
    robots = _robots.robots(top, fld, default_laser, task, shared_path, physics_rate)
    if task.kind == "race" and len(robots) < 2:
        raise ctx.fail(task_map.node.line, "task.kind", "a race needs at least two robots")
    default_controller = _default_controller(top, base, controllers)
    level = Level(
        name=top.req("name", yr.text),
        description=top.req("description", yr.text),
        source=source,
        hash="sha256:" + hashlib.sha256(data).hexdigest(),
        units=units,
        seed=top.opt("seed", yr.count, 0),
        time_limit=top.req("time_limit", yr.positive),
        physics_rate=physics_rate,
        control_period=control_period,
        record_rate=record_rate,
        field=fld,
        obstacles=obstacles,
        beacons=beacons,
        robots=tuple(sorted(robots, key=lambda r: r.slot)),
        task=task,
        default_controller=default_controller,
        limits=match.limits(top.sub("limits", match.LIMIT_KEYS)) if top.has("limits") else ControllerLimits(),
        rules=match.rules(top.sub("rules", match.RULE_KEYS)) if top.has("rules") else Rules(),
        floor=floor,
        text=text,
    )
    _check(ctx, level, located, contest=base is not None)
    return level


def _floor(top: yr.Map, fld: Field, task: Task) -> Floor:
    """The floor, flat without a `floor` key; tiles lay out the task's listed trial positions."""
    if not top.has("floor"):
        return Floor()
    floor_map = top.sub("floor", _geometry.FLOOR_KEYS)
    floor = _geometry.floor(floor_map, fld)
    if floor.tiles is not None and not task.trials.positions:
        line = floor_map.raw("tiles").line
        raise top.ctx.fail(line, "floor.tiles", "tiles lay out listed trial positions, and the task lists none")
    return floor


def _default_controller(top: yr.Map, base: Path | None, controllers: ControllerCheck | None) -> str:
    """The level's default controller; given `base` and `controllers`, one that exists (a file
    made absolute)."""
    default_controller: str = top.req("default_controller", yr.text)
    if base is not None and controllers is not None:
        default_controller, why = controllers(default_controller, base)
        if why:
            line = top.raw("default_controller").line
            raise top.ctx.fail(line, "default_controller", f"{default_controller}: {why}")
    return default_controller


def _check(ctx: yr.Context, level: Level, located: yr.Node, contest: bool) -> None:
    """The checks of the whole level (level_checks'; with `contest`, those of a contest too),
    and trials that fit in the match."""
    problem = checks.level_problem(level, contest=contest)
    if problem:
        raise ctx.fail(problem.line or yr.line_of(located, problem.key), problem.key, problem.message)
    trials = level.task.trials.count
    if trials > level.control_ticks:
        raise ctx.fail(
            yr.line_of(located, "task.trials.count"),
            "task.trials.count",
            f"{trials} trials in a match of {level.control_ticks} control periods",
        )
