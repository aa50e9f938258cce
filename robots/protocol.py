"""The message protocol between the referee and a controller process (version 1).

Frames are a 4-byte big-endian length and a UTF-8 JSON object. Every message carries
`"v": 1` and a `type`:

referee -> controller: `setup` {brief}, `step` {obs}, `stop`
controller -> referee: `ready`, `command` {tick, command}, `fault` {kind, message}

Both sides decode into the API's dataclasses and reject anything malformed with
`ProtocolError`, so neither side ever acts on an unchecked message. docs/protocol.md
describes each message.
"""

from __future__ import annotations

import dataclasses
import json
import math
import struct
from typing import Any, BinaryIO

from robots.api import (
    BeaconInfo, Brief, Command, Drawing, LaserInfo, Observation, RobotInfo, SensorEvent, TaskInfo,
)

PROTOCOL_VERSION = 1
MAX_FRAME = 1 << 24  # 16 MiB: no honest message comes near this


class ProtocolError(Exception):
    """A malformed frame or message."""


def write(stream: BinaryIO, msg: dict) -> None:
    """Send one message."""
    data = json.dumps({"v": PROTOCOL_VERSION, **msg}, separators=(",", ":")).encode()
    stream.write(struct.pack(">I", len(data)) + data)
    stream.flush()


def read(stream: BinaryIO) -> dict | None:
    """Receive one message, or None at end of stream."""
    head = stream.read(4)
    if not head:
        return None
    if len(head) < 4:
        raise ProtocolError("truncated frame header")
    (size,) = struct.unpack(">I", head)
    if size > MAX_FRAME:
        raise ProtocolError(f"frame of {size} bytes is over the {MAX_FRAME} limit")
    data = stream.read(size)
    if len(data) < size:
        raise ProtocolError("truncated frame")
    return parse(data)


def parse(data: bytes) -> dict:
    """Decode one frame's JSON and check its version and type field."""
    try:
        msg = json.loads(data)
    except ValueError as e:
        raise ProtocolError(f"not JSON: {e}") from None
    if not isinstance(msg, dict) or msg.get("v") != PROTOCOL_VERSION or not isinstance(msg.get("type"), str):
        raise ProtocolError(f"not a version {PROTOCOL_VERSION} message")
    return msg


def to_plain(obj: Any) -> Any:
    """A dataclass as plain JSON-able data (the per-step messages without `asdict`'s deep copy)."""
    if isinstance(obj, Observation):
        return {"tick": obj.tick, "time": obj.time, "events": [
            {"time": e.time, "kind": e.kind, "beacon": e.beacon, "angle": e.angle, "samples": e.samples}
            for e in obj.events]}
    if isinstance(obj, Command):
        return {"left": obj.left, "right": obj.right, "estimate": obj.estimate,
                "debug": [dataclasses.asdict(d) for d in obj.debug]}
    return dataclasses.asdict(obj)


# ---- decoding with validation ----------------------------------------------------------

def _num(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ProtocolError(f"{what} must be a number, got {type(v).__name__}")
    return float(v)


def _opt_num(v: Any, what: str) -> float | None:
    return None if v is None else _num(v, what)


def _str(v: Any, what: str) -> str:
    if not isinstance(v, str):
        raise ProtocolError(f"{what} must be text, got {type(v).__name__}")
    return v


def _opt_str(v: Any, what: str) -> str | None:
    return None if v is None else _str(v, what)


def _list(v: Any, what: str) -> list:
    if not isinstance(v, list):
        raise ProtocolError(f"{what} must be a list, got {type(v).__name__}")
    return v


def _dict(v: Any, what: str) -> dict:
    if not isinstance(v, dict):
        raise ProtocolError(f"{what} must be an object, got {type(v).__name__}")
    return v


def _nums(v: Any, what: str, n: int | None = None) -> tuple[float, ...]:
    items = _list(v, what)
    if n is not None and len(items) != n:
        raise ProtocolError(f"{what} must have {n} numbers, got {len(items)}")
    return tuple(_num(x, what) for x in items)


def _fields(d: Any, cls: type, what: str) -> dict:
    d = _dict(d, what)
    names = {f.name for f in dataclasses.fields(cls)}
    extra = set(d) - names
    if extra:
        raise ProtocolError(f"{what}: unknown field {sorted(extra)[0]!r}")
    return d


def brief_from(d: Any) -> Brief:
    """A Brief from plain data, checked."""
    d = _fields(d, Brief, "brief")
    try:
        laser = _fields(d["laser"], LaserInfo, "brief.laser")
        robot = _fields(d["robot"], RobotInfo, "brief.robot")
        task = _fields(d["task"], TaskInfo, "brief.task")
        return Brief(
            slot=int(_num(d["slot"], "brief.slot")),
            field=_nums(d["field"], "brief.field", 4),
            beacon_kind=_str(d["beacon_kind"], "brief.beacon_kind"),
            beacons=tuple(BeaconInfo(_str(b["id"], "beacon id"), _num(b["x"], "beacon x"), _num(b["y"], "beacon y"))
                          for b in (_fields(b, BeaconInfo, "brief.beacons[]")
                                    for b in _list(d["beacons"], "brief.beacons"))),
            laser=LaserInfo(_num(laser["angular_velocity"], "laser.angular_velocity"), bool(laser["index"])),
            robot=RobotInfo(_str(robot["model"], "robot.model"), *(
                _num(robot[k], f"robot.{k}") for k in
                ("length", "width", "track", "max_wheel_speed", "max_wheel_accel"))),
            task=TaskInfo(_str(task["kind"], "task.kind"), _num(task["radius"], "task.radius"),
                          tuple(_nums(p, "task.path[]", 2) for p in _list(task["path"], "task.path")),
                          None if task["goal"] is None else _nums(task["goal"], "task.goal", 2)),
            control_period=_num(d["control_period"], "brief.control_period"),
            time_limit=_num(d["time_limit"], "brief.time_limit"),
            start=None if d.get("start") is None else _nums(d["start"], "brief.start", 3),
        )
    except KeyError as e:
        raise ProtocolError(f"brief: missing field {e.args[0]!r}") from None


def observation_from(d: Any) -> Observation:
    """An Observation from plain data, checked."""
    d = _fields(d, Observation, "obs")
    events = []
    for e in _list(d.get("events", []), "obs.events"):
        e = _fields(e, SensorEvent, "obs.events[]")
        events.append(SensorEvent(
            time=_num(e.get("time"), "event.time"), kind=_str(e.get("kind"), "event.kind"),
            beacon=_opt_str(e.get("beacon"), "event.beacon"), angle=_opt_num(e.get("angle"), "event.angle"),
            samples=tuple(int(_num(s, "event.samples[]")) for s in _list(e.get("samples", []), "event.samples"))))
    return Observation(tick=int(_num(d.get("tick"), "obs.tick")), time=_num(d.get("time"), "obs.time"),
                       events=tuple(events))


def command_problem(cmd: object) -> str | None:
    """Why `cmd` is not a usable Command (wrong type, non-finite numbers), or None if it is.
    The referee applies this to every command, however it arrived."""
    if not isinstance(cmd, Command):
        return f"step() returned {type(cmd).__name__}, not Command"
    for name in ("left", "right"):
        v = getattr(cmd, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"Command.{name} must be a finite number, got {v!r}"
    est = cmd.estimate
    if est is not None:
        if not (isinstance(est, tuple) and len(est) == 3 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in est)):
            return f"Command.estimate must be None or three finite numbers, got {est!r}"
    return None


def command_from(d: Any) -> Command:
    """A Command from plain data. Its wheel speeds and estimate are passed through as sent,
    for `command_problem` to judge exactly as it judges an in-process command; debug
    drawings are checked and capped here."""
    d = _fields(d, Command, "command")
    est = d.get("estimate")
    debug = []
    for g in _list(d.get("debug", []), "command.debug")[:256]:
        g = _fields(g, Drawing, "command.debug[]")
        debug.append(Drawing(
            kind=_str(g.get("kind"), "drawing.kind"),
            points=tuple(_nums(p, "drawing.points[]", 2) for p in _list(g.get("points", []), "drawing.points")[:64]),
            radius=_num(g.get("radius", 0.0), "drawing.radius"), text=_str(g.get("text", ""), "drawing.text")[:80],
            color=tuple(int(_num(c, "drawing.color")) for c in _nums(g.get("color", [255, 0, 255]), "drawing.color", 3))))
    return Command(left=d.get("left"), right=d.get("right"),
                   estimate=tuple(est) if isinstance(est, list) else est, debug=tuple(debug))
