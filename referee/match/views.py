"""The match as the controller API and the replay see it: a team's `Brief` (what its rules
announce, never its true pose), a detection as a `SensorEvent`, the robots' poses and the
replay's frames of them, and the replay's header."""

from __future__ import annotations

import functools

import numpy as np

from arena.angles import wrap
from arena.sensing.events import Detection
from levels.model import Level
from referee.records.replay_format import Header, TeamEntry
from referee.sandbox.teams import Team
from referee.version import __version__
from robots.api import BeaconInfo, Brief, LaserInfo, RobotInfo, SensorEvent, StartInfo, TaskInfo


def announced_start(level: Level, slot: int) -> StartInfo | None:
    """What the rules announce of robot `slot`'s start: its nominal pose and how far the true
    start may lie from it (never the true start itself), or nothing."""
    r = level.robots[slot]
    if not r.start_known:
        return None
    p = r.placement
    return StartInfo(r.start.x, r.start.y, r.start.heading, p.position, p.heading, p.region)


def brief_for(level: Level, slot: int) -> Brief:
    """What robot `slot`'s team may know: the map, its hardware, its task, and what the rules
    announce of its start; never its true pose."""
    r = level.robots[slot]
    m = r.model
    f = level.field
    task = level.task
    goal = (task.goal.x, task.goal.y) if task.goal else None
    return Brief(
        slot=slot,
        field=(f.xmin, f.ymin, f.xmax, f.ymax),
        beacon_kind=level.beacons.kind,
        beacons=tuple(BeaconInfo(b.id, b.x, b.y) for b in level.beacons.items),
        laser=LaserInfo(r.laser.angular_velocity, r.laser.index),
        robot=RobotInfo(m.name, m.length, m.width, m.track, m.max_wheel_speed, m.max_wheel_accel),
        task=TaskInfo(task.kind, task.radius, r.path, goal, task.trials.count, task.settle, task.accuracy),
        control_period=level.control_period,
        time_limit=level.time_limit,
        start=announced_start(level, slot),
    )


_new_event = functools.partial(object.__new__, SensorEvent)


def to_event(d: Detection) -> SensorEvent:
    """An arena detection as the team sees it (nothing about which laser caused it). Built as
    pickle builds one, its fields set at once: the frozen class's `__init__` sets each through
    `object.__setattr__`, at twice the cost, for hundreds of events a simulated second."""
    event = _new_event()
    event.__dict__.update(time=d.time, kind=d.kind, beacon=d.beacon, angle=d.angle, samples=d.samples)
    return event


def poses(state: tuple[float, ...]) -> list[tuple[float, float, float]]:
    """Every robot's (x, y, heading wrapped to (-pi, pi]) from a world `state`."""
    return [(state[i], state[i + 1], wrap(state[i + 2])) for i in range(0, len(state), 3)]


def frames(states: np.ndarray, tick: int, every: int, rate: int) -> list[list[float]]:
    """The replay's frames of world `states` (rows), one every `every` steps from `tick`:
    each row's `poses`, flat, then its time (tick / `rate`), as the writer takes them."""
    rows = states.tolist()
    for i, row in enumerate(rows):
        row[2::3] = map(wrap, row[2::3])
        row.append((tick + every * i) / rate)
    return rows


def replay_header(level: Level, teams: list[Team], seed: int, ideal: bool, noise_key: str | None) -> Header:
    """The header of the replay of a match of `level` between `teams`."""
    entries = tuple(TeamEntry(t.label, t.spec, t.code_hash) for t in teams)
    return Header(
        level.name,
        level.hash,
        level.text,
        seed,
        ideal,
        level.record_rate,
        level.control_period,
        entries,
        __version__,
        noise_key,
    )
