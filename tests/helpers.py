"""Helpers the tests share (fixtures stay in conftest.py): a small level, level variants built
from parsed data, and running the command line as a user would."""

from __future__ import annotations

import atexit
import hashlib
import os
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml

import levels
from arena.rng import RandomTree
from arena.sensing.crossings import Trajectory
from arena.sensing.pipeline import Sensing
from arena.world import World
from levels.loader import parse_level
from levels.model import Level
from robots.api import BeaconInfo, Brief, LaserInfo, RobotInfo, StartInfo, TaskInfo

# A small valid level; tests derive variants of it with `variant`.
MINI_LEVEL = """\
name: mini
description: a small test table
units: m
seed: 3
time_limit: 4
physics_rate: 240
control_period: 0.05
field:
  size: [2.0, 1.0]
beacons:
  kind: sensor_array
  items:
    - {id: O, at: [0, 0]}
    - {id: A, at: [2, 0]}
    - {id: B, at: [2, 1]}
laser:
  angular_velocity: 20.0
  index: false
robots:
  - model: boe-bot
    start: [0.5, 0.5, 0]
    start_known: true
task:
  kind: waypoints
  radius: 0.05
  path: [[1.0, 0.5], [1.5, 0.5]]
default_controller: ref:dead-reckoning
"""


def edited(source: str, changes: dict[str, Any]) -> str:
    """Level YAML text with `changes` applied to its parsed data. `source` is level text or a
    built-in level's name; a key is a dotted path (`robots.0.start`, `beacons.crosstalk`), a
    value of None deletes the key. The text is dumped back, so the loader validates it as a file."""
    text = levels.path(source).read_text() if "\n" not in source else source
    data = yaml.safe_load(text)
    for path, value in changes.items():
        *parents, last = path.split(".")
        node = data
        for part in parents:
            node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
        key: Any = int(last) if isinstance(node, list) else last
        if value is None:
            del node[key]
        else:
            node[key] = value
    return yaml.safe_dump(data, sort_keys=False)


def exact_starts(source: str) -> dict[str, Any]:
    """`variant` changes that set every robot of a built-in level down exactly at its nominal
    start (no placement spread): for tests of something else than finding the start."""
    robots = yaml.safe_load(levels.path(source).read_text())["robots"]
    return {f"robots__{i}__placement": None for i, r in enumerate(robots) if "placement" in r}


def variant(source: str, name: str = "variant.yaml", **changes: Any) -> Level:
    """A parsed level: `source` (text or built-in name) with `changes` (dotted keys written with
    `__` for the dots: `robots__0__start=[1, 2, 0]`)."""
    text = edited(source, {k.replace("__", "."): v for k, v in changes.items()})
    return parse_level(text.encode(), name)


_SECRETS = Path(tempfile.mkdtemp(prefix="laserarena-test-secrets-"))
atexit.register(shutil.rmtree, _SECRETS, True)


def strong_secret(name: str) -> str:
    """A noise secret of 256 bits named by `name`: the same name gives the same secret, so runs
    compared across journals draw the same noise (a weak secret would be refused)."""
    return hashlib.sha256(f"laserarena-test-secret:{name}".encode()).hexdigest()


def secret_file(name: str) -> str:
    """A file holding `strong_secret(name)`, for `--secret-file` (a secret never goes on a
    command line)."""
    path = _SECRETS / hashlib.sha256(name.encode()).hexdigest()[:16]
    path.write_text(strong_secret(name) + "\n")
    return str(path)


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run `python -m referee ARGS` as a separate process, as a user would."""
    return subprocess.run(
        [sys.executable, "-m", "referee", *args], capture_output=True, text=True, cwd=cwd, timeout=300
    )


# ---- processes a test started, and what they started in turn -------------------------------


def descendants(root: int) -> dict[int, str]:
    """Every process below `root` now, as pid -> start time (to tell a reused pid apart)."""
    parent, start = {}, {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                fields = open(f"/proc/{d}/stat").read().rpartition(")")[2].split()
            except OSError:
                continue
            parent[int(d)], start[int(d)] = int(fields[1]), fields[19]
    found, frontier = {}, [root]
    while frontier:
        p = frontier.pop()
        for child, ppid in parent.items():
            if ppid == p and child not in found:
                found[child] = start[child]
                frontier.append(child)
    return found


def stop_point(proc: subprocess.Popen, db: Path, table: str = "matches") -> dict[int, str]:
    """Wait, at most 120 s, until the run `proc` has committed a row to `table` of its journal
    `db` (or has ended); return every process seen below it meanwhile."""
    import sqlite3
    import time
    from contextlib import closing

    below: dict[int, str] = {}
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        below.update(descendants(proc.pid))
        try:
            if db.exists():
                with closing(sqlite3.connect(db)) as c:  # closed at once: a reader holds off the run's commits
                    if c.execute(f"SELECT 1 FROM {table} LIMIT 1").fetchall():
                        break
        except sqlite3.OperationalError:  # not made yet, or held a moment by the run
            pass
        time.sleep(0.05)
    below.update(descendants(proc.pid))
    return below


def alive(pid: int, started: str) -> bool:
    try:
        fields = open(f"/proc/{pid}/stat").read().rpartition(")")[2].split()
    except OSError:
        return False
    return fields[19] == started and fields[0] != "Z"


# ---- a laser test table: four sensor arrays, one or two robots, stepped by hand ------------

TABLE = """\
name: t
description: laser test table
time_limit: 30
control_period: 0.05
field: {{size: [4.0, 3.0]}}
{obstacles}
beacons:
  kind: {kind}
  radius: 0.02
{params}
  items:
    - {{id: P, at: [0.2, 0.3]}}
    - {{id: Q, at: [3.7, 0.4]}}
    - {{id: R, at: [3.5, 2.8]}}
    - {{id: S, at: [0.3, 2.6]}}
laser: {{angular_velocity: {omega}, index: true}}
robots:
{robots}
task: {{kind: localize}}
default_controller: ref:idle
"""
ONE = "  - {model: generic, start: [1.7, 1.2, 37]}"


def make(kind="sensor_array", omega=20.0, robots=ONE, params="", obstacles=""):
    text = TABLE.format(kind=kind, omega=omega, robots=robots, params=params, obstacles=obstacles)
    return World(parse_level(text.encode(), "t.yaml"))


def sense(world, seconds, commands=(), ideal=True, seed=1, every=12):
    """Step the world, flushing the sensing every `every` steps; returns (events, poses)."""
    s = Sensing(world, RandomTree(seed), ideal)
    for slot, (left, right) in enumerate(commands):
        world.command(slot, left, right)
    events = [[] for _ in world.bodies]
    poses = [[(b.position.x, b.position.y, b.angle) for b in world.bodies]]
    for k in range(round(seconds * world.level.physics_rate)):
        world.step()
        s.record()
        poses.append([(b.position.x, b.position.y, b.angle) for b in world.bodies])
        if (k + 1) % every == 0:
            for r, evs in enumerate(s.flush()):
                events[r] += evs
    for r, evs in enumerate(s.flush()):
        events[r] += evs
    return events, np.array(poses)


def hits(events, beacon=None):
    return [e for e in events if e.kind == "hit" and (beacon is None or e.beacon == beacon)]


TWO = ONE + "\n  - {model: boe-bot, start: [0.95, 0.75, 0]}"


# Bac's table: the four corner arrays (m), for the toolkit's tests of a controller's side
ARRAYS = {"O": (0.0, 0.0), "A": (1.83, 0.0), "B": (1.83, 1.22), "C": (0.0, 1.22)}


def table_brief(start: StartInfo | None = None, omega: float = 81.0) -> Brief:
    """The brief of a boe-bot on Bac's table, its laser at `omega` rad/s, a localize task."""
    return Brief(
        slot=0,
        field=(0.0, 0.0, 1.83, 1.22),
        beacon_kind="sensor_array",
        beacons=tuple(BeaconInfo(k, *p) for k, p in ARRAYS.items()),
        laser=LaserInfo(omega, False),
        robot=RobotInfo("boe-bot", 0.105, 0.095, 0.105, 0.17, 0.5),
        task=TaskInfo("localize", 0.05),
        control_period=0.2,
        time_limit=10.0,
        start=start,
    )


def closed_to_others(path: Path) -> bool:
    """Whether some folder on the way to `path` keeps other users out (no x bit for others):
    then `nobody`, whom a root referee's unsandboxed controllers run as, cannot start Python there."""
    return any(not p.stat().st_mode & stat.S_IXOTH for p in [path, *path.parents])


# ---- random worlds for the sensing kernels --------------------------------------------------------------------------


def random_trajectory(g, steps=48, robots=4, dt=1 / 240):
    """Robots wandering and turning on a 2 x 1.5 m table, lasers spinning either way."""
    t = 10.0 + np.arange(steps + 1) * dt
    x = g.uniform(0.1, 1.9, robots) + np.cumsum(g.normal(0, 2e-3, (steps + 1, robots)), axis=0)
    y = g.uniform(0.1, 1.4, robots) + np.cumsum(g.normal(0, 2e-3, (steps + 1, robots)), axis=0)
    h = g.uniform(-4, 4, robots) + np.cumsum(g.normal(0, 0.01, (steps + 1, robots)), axis=0)
    omega = g.choice([-1.0, 1.0], robots) * g.uniform(30, 90, robots)
    phi = g.uniform(-50, 50, robots) + np.arange(steps + 1)[:, None] * omega * dt * (1 + g.normal(0, 0.003, robots))
    return Trajectory(t=t, x=x, y=y, h=h, phi=phi)


BEACONS = (np.array([0.0, 2.0, 2.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.5, 1.5, 1.6]))


# The 40 tile positions (in) at which Simi's Appendix F reports an optical fix.
SIMI_POSITIONS = [
    (33.465, -46.116),
    (33.465, -34.116),
    (33.465, -22.116),
    (45.465, -70.116),
    (45.465, -58.116),
    (45.465, -46.116),
    (45.465, -34.116),
    (45.465, -22.116),
    (57.465, -82.116),
    (57.465, -70.116),
    (57.465, -46.116),
    (57.465, -34.116),
    (57.465, -22.116),
    (57.46535, -58.11582),
    (69.465, -94.116),
    (69.465, -82.116),
    (69.465, -70.116),
    (69.465, -58.116),
    (69.465, -46.116),
    (69.465, -34.116),
    (69.465, -22.116),
    (81.465, -94.116),
    (81.465, -82.116),
    (81.465, -70.116),
    (81.465, -58.116),
    (81.465, -46.116),
    (81.465, -34.116),
    (81.465, -22.116),
    (93.465, -82.116),
    (93.465, -70.116),
    (93.465, -58.116),
    (93.465, -46.116),
    (93.465, -34.116),
    (93.465, -22.116),
    (105.465, -58.116),
    (105.465, -46.116),
    (105.465, -34.116),
    (105.465, -22.116),
    (117.465, -34.116),
    (117.465, -22.116),
]
SIMI_START_TILE = (57.46535, -58.11582)  # the start's tile value: "the initial optical solution position"


def simi_on_tiles(**changes: Any) -> Level:
    """simi as its experimenter ran it: the floor's tiles (their errors as the fidelity
    experiment sets them), and trials at Appendix F's positions, each at the start's heading or
    turned 45 or 90 degrees either way (the contest level draws them from a region instead)."""
    tiles = {"origin": list(SIMI_START_TILE), "spacing_error": 0.0015, "angle_error": 0.2}
    trials = {
        "count": 10,
        "positions": [list(p) for p in SIMI_POSITIONS if p != SIMI_START_TILE],
        "headings": [0, 45, 90, -45, -90],
    }
    return variant("simi", floor__tiles=tiles, task__trials=trials, **changes)
