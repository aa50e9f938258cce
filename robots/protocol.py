"""The message protocol between the referee and a controller process (version 1).

Frames are a 4-byte big-endian length and a UTF-8 JSON object of at most `MAX_FRAME` bytes.
Every message carries `"v": 1` and a `type`:

referee -> controller: `setup` {brief}, `step` {obs}, `stop`
controller -> referee: `loaded` {api}, `ready`, `command` {tick, command}, `fault` {kind, message}

Decoding is typed (msgspec): every message has a fixed schema, every number must be finite
and within `LIMIT`, every list and text has a length bound, and unknown fields are refused.
So the decoded shape is bounded whatever bytes arrive, and a team's bytes can raise nothing
but `ProtocolError`, whose message names the field. `parse` checks the envelope and leaves
the payload (brief, obs, command) raw; `brief_from`, `observation_from` and `command_from`
decode it into the API's dataclasses. docs/protocol.md describes each message.
"""

from __future__ import annotations

import math
import numbers
import struct
from typing import IO, Annotated, Any, Literal

import msgspec

from robots.api import (
    API_VERSION,
    BeaconInfo,
    Brief,
    Command,
    Drawing,
    LaserInfo,
    Observation,
    RobotInfo,
    SensorEvent,
    StartInfo,
    TaskInfo,
)

PROTOCOL_VERSION = 1
MAX_FRAME = 1 << 22  # 4 MiB: the largest honest message (a brief) is far below
LIMIT = 1e6  # no number in a message may exceed this in size (m, s, rad, m/s)
MAX_DRAWINGS, MAX_POINTS, MAX_TEXT = 256, 64, 80  # debug drawings beyond these are dropped

# ---- the schema -----------------------------------------------------------------------------

Real = Annotated[float, msgspec.Meta(ge=-LIMIT, le=LIMIT)]
Count = Annotated[int, msgspec.Meta(ge=0, le=1 << 40)]
Byte = Annotated[int, msgspec.Meta(ge=0, le=255)]
Name = Annotated[str, msgspec.Meta(max_length=256)]
Point = tuple[Real, Real]


class _Data(msgspec.Struct, forbid_unknown_fields=True, frozen=True):
    """A payload record: a fixed set of fields, nothing else."""


class _Beacon(_Data, frozen=True):
    id: Name
    x: Real
    y: Real


class _Laser(_Data, frozen=True):
    angular_velocity: Real
    index: bool


class _Robot(_Data, frozen=True):
    model: Name
    length: Real
    width: Real
    track: Real
    max_wheel_speed: Real
    max_wheel_accel: Real


class _Task(_Data, frozen=True):
    kind: Name
    radius: Real
    path: Annotated[list[Point], msgspec.Meta(max_length=1 << 16)] = []
    goal: Point | None = None
    trials: Annotated[int, msgspec.Meta(ge=1, le=1 << 40)] = 1


class _Start(_Data, frozen=True):
    x: Real
    y: Real
    heading: Real
    position_spread: Annotated[float, msgspec.Meta(ge=0, le=LIMIT)] = 0.0
    heading_spread: Annotated[float, msgspec.Meta(ge=0, le=LIMIT)] = 0.0
    region: tuple[Real, Real, Real, Real] | None = None


class _Brief(_Data, frozen=True):
    slot: Count
    field: tuple[Real, Real, Real, Real]
    beacon_kind: Name
    beacons: Annotated[list[_Beacon], msgspec.Meta(max_length=4096)]
    laser: _Laser
    robot: _Robot
    task: _Task
    control_period: Real
    time_limit: Real
    start: _Start | None = None


class _Event(_Data, frozen=True):
    time: Real
    kind: Name
    beacon: Name | None = None
    angle: Real | None = None
    samples: Annotated[list[Byte], msgspec.Meta(max_length=1 << 16)] = []


class _Observation(_Data, frozen=True):
    tick: Count
    time: Real
    events: Annotated[list[_Event], msgspec.Meta(max_length=1 << 16)] = []
    trial: Count = 0


class _Drawing(_Data, frozen=True):
    kind: Name
    points: Annotated[list[Point], msgspec.Meta(max_length=4096)] = []
    radius: Annotated[float, msgspec.Meta(ge=0, le=LIMIT)] = 0.0
    text: Annotated[str, msgspec.Meta(max_length=4096)] = ""
    color: tuple[Byte, Byte, Byte] = (255, 0, 255)


class _Command(_Data, frozen=True):
    left: Real
    right: Real
    estimate: tuple[Real, Real, Real] | None = None
    debug: Annotated[list[_Drawing], msgspec.Meta(max_length=4096)] = []


class _Message(msgspec.Struct, tag_field="type", forbid_unknown_fields=True):
    v: Literal[1]


class _Setup(_Message, tag="setup"):
    brief: msgspec.Raw


class _Step(_Message, tag="step"):
    obs: msgspec.Raw


class _Stop(_Message, tag="stop"):
    pass


class _Loaded(_Message, tag="loaded"):
    api: Annotated[int, msgspec.Meta(ge=0, le=1 << 30)]  # the controller API the team's class speaks


class _Ready(_Message, tag="ready"):
    pass


class _CommandMsg(_Message, tag="command"):
    tick: Count
    command: msgspec.Raw


class _Fault(_Message, tag="fault"):
    kind: Name
    message: Annotated[str, msgspec.Meta(max_length=4096)]


_MESSAGE = msgspec.json.Decoder(_Setup | _Step | _Stop | _Loaded | _Ready | _CommandMsg | _Fault)
_DECODERS: dict[type[_Data], msgspec.json.Decoder[Any]] = {
    t: msgspec.json.Decoder(t) for t in (_Brief, _Observation, _Command)
}
_ENCODER = msgspec.json.Encoder()


class ProtocolError(Exception):
    """A malformed frame or message; the text names the field at fault."""


# ---- frames ---------------------------------------------------------------------------------


def write(stream: IO[bytes], msg: dict) -> None:
    """Send one message (plain data: dicts, lists, tuples, text, numbers; see `to_plain`)."""
    try:
        data = _ENCODER.encode({"v": PROTOCOL_VERSION, **msg})
    except (TypeError, ValueError, OverflowError) as e:
        raise ProtocolError(f"cannot encode a {msg.get('type')!r} message: {e}") from None
    if len(data) > MAX_FRAME:
        raise ProtocolError(f"a {msg.get('type')!r} message of {len(data)} bytes is over the {MAX_FRAME} limit")
    stream.write(struct.pack(">I", len(data)) + data)
    stream.flush()


_STEP_HEAD = b'\0\0\0\0{"v":%d,"type":"step","obs":' % PROTOCOL_VERSION


def step_frame(obs: Observation, buffer: bytearray) -> bytearray:
    """The `step` message for `obs` as a whole frame, encoded into `buffer` (reused from tick to
    tick): the same bytes `write` sends for `{"type": "step", "obs": to_plain(obs)}`, without
    building the plain data first (msgspec encodes the dataclasses as they are)."""
    buffer[:] = _STEP_HEAD
    try:
        _ENCODER.encode_into(obs, buffer, -1)
    except (TypeError, ValueError, OverflowError) as e:
        raise ProtocolError(f"cannot encode a 'step' message: {e}") from None
    buffer += b"}"
    size = len(buffer) - 4
    if size > MAX_FRAME:
        raise ProtocolError(f"a 'step' message of {size} bytes is over the {MAX_FRAME} limit")
    struct.pack_into(">I", buffer, 0, size)
    return buffer


def read(stream: IO[bytes]) -> dict | None:
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


def _one_line(text: str, limit: int = 300) -> str:
    """An error text safe for a log line or a terminal: control characters escaped, cut short.
    (The referee's `referee.terminal.safe` does the same; this side may not import it.)"""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text[:limit])


def _invalid(e: msgspec.ValidationError, what: str) -> ProtocolError:
    return ProtocolError(_one_line(f"{what}: {e}".replace("`$", "`" + what)))


def _decode(decoder: msgspec.json.Decoder, data: Any, what: str) -> Any:
    """Typed decoding where any failure at all is a ProtocolError naming `what` and the field."""
    try:
        return decoder.decode(data)
    except msgspec.ValidationError as e:
        raise _invalid(e, what) from None
    except msgspec.DecodeError as e:
        raise ProtocolError(_one_line(f"{what}: not JSON ({e})")) from None
    except RecursionError:
        raise ProtocolError(f"{what}: nested too deeply") from None
    except Exception as e:
        raise ProtocolError(f"{what}: undecodable ({type(e).__name__})") from None


def api_problem(version: object) -> str | None:
    """Why a controller that speaks API `version` cannot play under this referee, or None."""
    if version == API_VERSION and type(version) is int:
        return None
    return f"the team's controller speaks API version {version}, this referee speaks {API_VERSION}"


def parse(data: bytes) -> dict:
    """Decode one frame's envelope: a dict with `v`, `type` and that type's fields, checked.
    A payload (`brief`, `obs`, `command`) stays raw for its own `*_from` function."""
    if len(data) > MAX_FRAME:
        raise ProtocolError(f"frame of {len(data)} bytes is over the {MAX_FRAME} limit")
    msg = _decode(_MESSAGE, data, "message")
    out = {"v": msg.v, "type": msg.__struct_config__.tag}
    out.update((f, getattr(msg, f)) for f in msg.__struct_fields__ if f != "v")
    return out


def _payload(d: Any, cls: type[_Data], what: str) -> Any:
    """A payload from raw JSON (as `parse` leaves it) or from plain data, decoded as `cls`."""
    if type(d) is msgspec.Raw or isinstance(d, bytes):
        return _decode(_DECODERS[cls], d, what)
    try:
        return msgspec.convert(d, cls)
    except msgspec.ValidationError as e:
        raise _invalid(e, what) from None
    except RecursionError:
        raise ProtocolError(f"{what}: nested too deeply") from None
    except Exception as e:
        raise ProtocolError(f"{what}: undecodable ({type(e).__name__})") from None


# ---- plain data out -------------------------------------------------------------------------


def _real(v: Any) -> Any:
    """A number as a Python float (numpy scalars included); anything else unchanged, for the
    other side to reject by name."""
    return float(v) if isinstance(v, numbers.Real) and not isinstance(v, bool) else v


def to_plain(obj: Any) -> Any:
    """A Brief, Observation or Command as plain JSON-able data. Numbers of any real type
    (numpy scalars, what a numpy-based team computes) become floats here, on the sending side."""
    if isinstance(obj, Observation):
        return {
            "tick": obj.tick,
            "time": obj.time,
            "events": [
                {"time": e.time, "kind": e.kind, "beacon": e.beacon, "angle": e.angle, "samples": e.samples}
                for e in obj.events
            ],
            "trial": obj.trial,
        }
    if isinstance(obj, Command):
        est = obj.estimate
        return {
            "left": _real(obj.left),
            "right": _real(obj.right),
            "estimate": tuple(map(_real, est)) if isinstance(est, (tuple, list)) else est,
            "debug": [
                {
                    "kind": g.kind,
                    "points": [tuple(map(_real, p)) for p in g.points],
                    "radius": _real(g.radius),
                    "text": g.text,
                    "color": tuple(int(c) if isinstance(c, numbers.Integral) else c for c in g.color),
                }
                for g in obj.debug
            ],
        }
    if isinstance(obj, Brief):
        return msgspec.to_builtins(obj)
    raise TypeError(f"to_plain: not a protocol payload: {type(obj).__name__}")


# ---- checked payloads in --------------------------------------------------------------------


def brief_from(d: Any) -> Brief:
    """A Brief from raw JSON or plain data, checked."""
    b = _payload(d, _Brief, "brief")
    return Brief(
        slot=b.slot,
        field=b.field,
        beacon_kind=b.beacon_kind,
        beacons=tuple(BeaconInfo(x.id, x.x, x.y) for x in b.beacons),
        laser=LaserInfo(b.laser.angular_velocity, b.laser.index),
        robot=RobotInfo(
            b.robot.model,
            b.robot.length,
            b.robot.width,
            b.robot.track,
            b.robot.max_wheel_speed,
            b.robot.max_wheel_accel,
        ),
        task=TaskInfo(b.task.kind, b.task.radius, tuple(b.task.path), b.task.goal, b.task.trials),
        control_period=b.control_period,
        time_limit=b.time_limit,
        start=None
        if b.start is None
        else StartInfo(
            b.start.x, b.start.y, b.start.heading, b.start.position_spread, b.start.heading_spread, b.start.region
        ),
    )


def observation_from(d: Any) -> Observation:
    """An Observation from raw JSON or plain data, checked."""
    o = _payload(d, _Observation, "obs")
    return Observation(
        tick=o.tick,
        time=o.time,
        events=tuple(SensorEvent(e.time, e.kind, e.beacon, e.angle, tuple(e.samples)) for e in o.events),
        trial=o.trial,
    )


def command_from(d: Any) -> Command:
    """A Command from raw JSON or plain data: wheel speeds and estimate finite and within
    `LIMIT` (else ProtocolError naming the field); debug drawings beyond the caps dropped."""
    c = _payload(d, _Command, "command")
    if not c.debug:  # the common case, on the per-tick path
        return Command(c.left, c.right, c.estimate)
    return Command(
        c.left,
        c.right,
        c.estimate,
        tuple(
            Drawing(g.kind, tuple(g.points[:MAX_POINTS]), g.radius, g.text[:MAX_TEXT], g.color)
            for g in c.debug[:MAX_DRAWINGS]
        ),
    )


def _bad_real(v: object) -> bool:
    """True unless `v` is a real number (numpy scalars too) that is finite and within LIMIT."""
    if type(v) is float:  # the common case first; NaN fails the comparison
        return not -LIMIT <= v <= LIMIT
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        return True
    try:
        f = float(v)
    except (OverflowError, ValueError, TypeError):
        return True
    return not (math.isfinite(f) and abs(f) <= LIMIT)


def command_problem(cmd: object) -> str | None:
    """Why `cmd` is not a usable Command (wrong type, numbers not finite or out of range,
    debug not a sequence), or None if it is; give it `sendable(cmd)`. The same judgement on either side of the
    protocol, and for a controller in the referee's own process; it never raises."""
    if not isinstance(cmd, Command):
        return f"step() returned {type(cmd).__name__}, not Command"
    for name in ("left", "right"):
        v = getattr(cmd, name)
        if _bad_real(v):
            return f"Command.{name} must be a finite number within +-{LIMIT:g}, got {_show(v)}"
    est = cmd.estimate
    if est is not None and not (
        isinstance(est, (tuple, list))
        and len(est) == 3
        and not (_bad_real(est[0]) or _bad_real(est[1]) or _bad_real(est[2]))
    ):
        return f"Command.estimate must be None or three finite numbers within +-{LIMIT:g}, got {_show(est)}"
    if not isinstance(cmd.debug, (tuple, list)):
        return f"Command.debug must be a tuple of Drawing, got {_show(cmd.debug)}"
    return None  # drawings are judged one by one (`drawing_problem`): a bad one is dropped, not fatal


DRAWING_KINDS = ("point", "line", "circle", "text")
DROPPED = "dropped"  # the kind of a drawing the team side could not send: its text says why


def drawing_problem(g: object) -> str | None:
    """Why a debug drawing cannot be drawn (kind, finite coordinates, sizes), or None; the
    referee drops such drawings with a warning in the result instead of ending the controller."""
    if not isinstance(g, Drawing):
        return f"not a Drawing: {_show(g)}"
    if g.kind == DROPPED and isinstance(g.text, str):
        return g.text or "dropped"
    if not isinstance(g.kind, str) or g.kind not in DRAWING_KINDS:
        return f"kind {_show(g.kind)} is not one of {', '.join(DRAWING_KINDS)}"
    if not (
        isinstance(g.points, (tuple, list))
        and all(isinstance(p, (tuple, list)) and len(p) == 2 and not any(map(_bad_real, p)) for p in g.points)
    ):
        return f"a {g.kind}'s points must be finite (x, y) pairs within +-{LIMIT:g}"
    need = 2 if g.kind == "line" else 1
    if not need <= len(g.points) <= MAX_POINTS:
        return f"a {g.kind} has {len(g.points)} points (from {need} to {MAX_POINTS})"
    if _bad_real(g.radius) or g.radius < 0:
        return f"a {g.kind}'s radius must be a finite number >= 0, got {_show(g.radius)}"
    if not isinstance(g.text, str) or len(g.text) > MAX_TEXT:
        return f"a {g.kind}'s text must be a str of at most {MAX_TEXT} characters"
    if not (
        isinstance(g.color, (tuple, list))
        and len(g.color) == 3
        and all(isinstance(c, numbers.Integral) and not isinstance(c, bool) and 0 <= c <= 255 for c in g.color)
    ):
        return f"a {g.kind}'s color must be three integers 0..255, got {_show(g.color)}"
    return None


def sendable(cmd: object) -> object:
    """`cmd` with each drawing that cannot be drawn replaced by a DROPPED one naming why, and
    drawings past MAX_DRAWINGS folded into one: what a team side sends, so the referee can warn."""
    if not isinstance(cmd, Command) or not isinstance(cmd.debug, (tuple, list)) or not cmd.debug:
        return cmd
    problems = [drawing_problem(g) for g in cmd.debug[:MAX_DRAWINGS]]
    extra = len(cmd.debug) - MAX_DRAWINGS
    if not any(problems) and extra <= 0:
        return cmd
    debug = [Drawing(DROPPED, (), 0.0, p[:MAX_TEXT]) if p else g for g, p in zip(cmd.debug, problems)]
    if extra > 0:
        debug[-1] = Drawing(DROPPED, (), 0.0, f"{extra + 1} drawings past the {MAX_DRAWINGS - 1} a tick may have")
    return Command(cmd.left, cmd.right, cmd.estimate, tuple(debug))


def _show(v: object) -> str:
    """A short, safe rendering of a team's value for a fault message."""
    try:
        text = repr(v)
    except Exception:
        text = f"<{type(v).__name__}>"
    return text[:60] + ("..." if len(text) > 60 else "")
