"""The message protocol between the referee and a controller process (version 1).

Frames are a 4-byte big-endian length and a UTF-8 JSON object of at most `MAX_FRAME` bytes.
Every message carries `"v": 1` and a `type`; each is a tagged Struct here:

referee -> controller: `Setup` {brief}, `Step` {obs}, `Stop`
controller -> referee: `Loaded` {api}, `Ready`, `CommandMsg` {tick, command}, `FaultMsg` {kind, message}

How it works, in detail: docs/internals.md, `robots/_host/protocol.py`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import operator
import struct
import types
import typing
from enum import StrEnum
from typing import IO, Annotated, Any, Final, Generic, Literal, TypeVar

import msgspec

from robots.api import API_VERSION, Brief, Command, Drawing, Observation
from robots.bounds import KIND_CHARS, LIMIT, MAX_DRAWINGS, MAX_POINTS, MAX_TEXT, NAME_CHARS, Name

PROTOCOL_VERSION: Final = 1
MAX_FRAME = 1 << 22  # 4 MiB: the largest honest message (a brief) is far below


class FaultKind(StrEnum):
    """What went wrong with a controller, as the result records it (str-valued: the same JSON)."""

    LOAD = "load"  # the first four a controller may report of itself (`REPORTED`)
    EXCEPTION = "exception"
    MEMORY = "memory"
    BAD_COMMAND = "bad_command"
    CRASH = "crash"  # the rest the referee finds
    TIMEOUT = "timeout"
    OUTPUT_FLOOD = "output_flood"
    PROTOCOL = "protocol"
    SKIPPED_TICK = "skipped_tick"


REPORTED = frozenset({FaultKind.LOAD, FaultKind.EXCEPTION, FaultKind.MEMORY, FaultKind.BAD_COMMAND})

# ---- the messages ---------------------------------------------------------------------------

P = TypeVar("P")  # a payload: the API's dataclass when sent, `msgspec.Raw` as `parse` leaves it


class Message(msgspec.Struct, tag_field="type", forbid_unknown_fields=True, frozen=True):
    """One message: its `type` is the tag, `v` the protocol version (required)."""

    v: Literal[1]


class Setup(Message, Generic[P], tag="setup", frozen=True):
    brief: P


class Step(Message, Generic[P], tag="step", frozen=True):
    obs: P


class Stop(Message, tag="stop", frozen=True):
    pass


class Loaded(Message, tag="loaded", frozen=True):
    api: Annotated[int, msgspec.Meta(ge=0, le=1 << 30)]  # the controller API the team's class speaks


class Ready(Message, tag="ready", frozen=True):
    pass


class CommandMsg(Message, Generic[P], tag="command", frozen=True):
    tick: Annotated[int, msgspec.Meta(ge=0, le=1 << 40)]
    command: P


FAULT_CHARS = 4096  # the most characters a fault's message may have


class FaultMsg(Message, tag="fault", frozen=True):
    kind: Name  # one of REPORTED, or the referee calls it a `protocol` fault
    message: Annotated[str, msgspec.Meta(max_length=FAULT_CHARS)]


Raw = msgspec.Raw
_MESSAGE = msgspec.json.Decoder(Setup[Raw] | Step[Raw] | Stop | Loaded | Ready | CommandMsg[Raw] | FaultMsg)
PAYLOADS = {Brief: "brief", Observation: "obs", Command: "command"}  # each payload and its field


def _number(v: Any) -> Any:
    """A number of any real type (numpy scalars, what a numpy-based team computes) as a Python
    int or float, on the sending side; anything else is refused by name."""
    if isinstance(v, numbers.Integral):
        return int(v)
    if isinstance(v, numbers.Real):
        return float(v)
    raise TypeError(f"Encoding objects of type {type(v).__name__} is unsupported")


_ENCODER = msgspec.json.Encoder(enc_hook=_number)


class ProtocolError(Exception):
    """A malformed frame or message; the text names the field at fault."""


class CommandError(ProtocolError):
    """A well-formed `command` message whose command fails its checks (a `bad_command` fault)."""


# ---- strict payloads ------------------------------------------------------------------------


def _strict(tp: Any) -> Any:
    """The type `tp` with each API dataclass in it replaced by its strict twin (`_twin`)."""
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        return _twin(tp)
    args, origin = typing.get_args(tp), typing.get_origin(tp)
    if origin is Annotated:
        return Annotated[(_strict(args[0]), *tp.__metadata__)]
    swapped = tuple(a if a is Ellipsis else _strict(a) for a in args)
    if swapped == args:
        return tp
    if origin in (types.UnionType, typing.Union):
        return functools.reduce(operator.or_, swapped)
    return origin[swapped]


@functools.cache
def _twin(cls: type) -> type:
    """A frozen Struct with the fields, bounds and defaults of dataclass `cls`, refusing unknown
    fields (msgspec refuses them for Structs only): a payload is checked against it first."""
    hints = typing.get_type_hints(cls, include_extras=True)
    return msgspec.defstruct(
        cls.__name__,
        [
            (f.name, _strict(hints[f.name]))
            if f.default is dataclasses.MISSING
            else (f.name, _strict(hints[f.name]), f.default)
            for f in dataclasses.fields(cls)
        ],
        forbid_unknown_fields=True,
        frozen=True,
    )


# each payload decoded into its twin (unknown fields refused, every bound checked)
_CHECKS: dict[type, msgspec.json.Decoder[Any]] = {cls: msgspec.json.Decoder(_twin(cls)) for cls in PAYLOADS}

T = TypeVar("T", Brief, Observation, Command)


def decoded(raw: bytes | msgspec.Raw, cls: type[T]) -> T:
    """A payload (a message's `brief`, `obs` or `command`, raw as `parse` leaves it) as the API's
    dataclass `cls`, checked: any failure is a ProtocolError naming the field. Its bytes are
    decoded once, into the payload's strict twin, which is then made the dataclass."""
    return _dataclass(_decode(_CHECKS[cls], raw, PAYLOADS[cls]), cls)


def _dataclass(twin: Any, cls: type[T]) -> T:
    """A payload decoded into its strict twin, as the API's dataclass `cls` (already checked)."""
    return msgspec.convert(twin, cls, from_attributes=True)


def wired(cmd: Command) -> Command:
    """`cmd` as the referee gets it over the wire (numbers of any real type made floats, the
    checks and caps applied): for a controller in the referee's own process. ProtocolError if
    it cannot cross."""
    try:
        data = _ENCODER.encode(cmd)
    except (TypeError, ValueError, OverflowError) as e:
        raise ProtocolError(f"cannot encode a 'command' message: {e}") from None
    return decoded(data, Command)


# ---- frames ---------------------------------------------------------------------------------


def write(stream: IO[bytes], msg: Message) -> None:
    """Send one message (its payload an API dataclass; numpy scalars are sent as numbers)."""
    kind = msg.__struct_config__.tag
    try:
        data = _ENCODER.encode(msg)
    except (TypeError, ValueError, OverflowError) as e:
        raise ProtocolError(f"cannot encode a {kind!r} message: {e}") from None
    if len(data) > MAX_FRAME:
        raise ProtocolError(f"a {kind!r} message of {len(data)} bytes is over the {MAX_FRAME} limit")
    stream.write(struct.pack(">I", len(data)) + data)
    stream.flush()


_STEP_HEAD = b'\0\0\0\0{"type":"step","v":%d,"obs":' % PROTOCOL_VERSION


def step_frame(obs: Observation, buffer: bytearray) -> bytearray:
    """The `Step` message for `obs` as a whole frame, encoded into `buffer` (reused from tick to
    tick): the same bytes `write` sends for it, without building the message first."""
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


def read(stream: IO[bytes]) -> Message | None:
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


def one_line(text: str) -> str:
    """`text` with every run of white space (newlines too) made one space: what a fault or a
    protocol error says is one line of a log. The referee escapes what a terminal must not see
    (control characters) when it records the fault (referee.terminal.safe)."""
    return " ".join(text.split())


def describe(e: BaseException) -> str:
    """An exception as `Type: message` on one line, as a fault message says it."""
    text = one_line(str(e))
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def _decode(decoder: msgspec.json.Decoder, data: Any, what: str) -> Any:
    """Typed decoding where any failure at all is a ProtocolError naming `what` and the field."""
    try:
        return decoder.decode(data)
    except msgspec.ValidationError as e:
        raise ProtocolError(one_line(f"{what}: {e}".replace("`$", "`" + what))) from None
    except msgspec.DecodeError as e:
        raise ProtocolError(one_line(f"{what}: not JSON ({e})")) from None
    except RecursionError:
        raise ProtocolError(f"{what}: nested too deeply") from None
    except Exception as e:
        raise ProtocolError(f"{what}: undecodable ({type(e).__name__})") from None


def api_problem(version: object) -> str | None:
    """Why a controller that speaks API `version` cannot play under this referee, or None."""
    if version == API_VERSION and type(version) is int:
        return None
    return f"the team's controller speaks API version {version}, this referee speaks {API_VERSION}"


def parse(data: bytes) -> Message:
    """Decode one frame's envelope into its message, checked. A payload (`brief`, `obs`,
    `command`) stays raw (`msgspec.Raw`) for `decoded`."""
    if len(data) > MAX_FRAME:
        raise ProtocolError(f"frame of {len(data)} bytes is over the {MAX_FRAME} limit")
    msg: Message = _decode(_MESSAGE, data, "message")
    return msg


# ---- answers: what the referee reads from a controller ----------------------------------------

NUMBER_BYTES = len("-1.2345678901234567e-300")  # the longest number within LIMIT our encoder writes
CHAR_BYTES = len("\\ud83d\\ude00")  # the most a character of text can take in JSON: an escaped surrogate pair
_COMMAND: Any = _twin(Command)  # a command as it is checked (its strict twin)
_ANSWER = msgspec.json.Decoder(Loaded | Ready | CommandMsg[_COMMAND] | FaultMsg)  # what a controller may send


@functools.cache
def answer_bound() -> int:
    """The most bytes a controller's message can take within the schema's bounds: a `command`
    with MAX_DRAWINGS drawings of MAX_POINTS points, every number NUMBER_BYTES long and every
    character of text CHAR_BYTES (a `fault` message's longest is far below). Compact JSON, as
    every writer of this protocol makes it: whitespace between tokens is not counted."""
    n = -1.2345678901234567e-300
    drawing = Drawing("", ((n, n),) * MAX_POINTS, -n, "", (255, 255, 255))  # a radius is never negative
    longest = CommandMsg(v=PROTOCOL_VERSION, tick=1 << 40, command=Command(n, n, (n, n, n), (drawing,) * MAX_DRAWINGS))
    command = len(_ENCODER.encode(longest)) + MAX_DRAWINGS * (KIND_CHARS + MAX_TEXT) * CHAR_BYTES
    fault = (
        len(_ENCODER.encode(FaultMsg(v=PROTOCOL_VERSION, kind="", message="")))
        + (NAME_CHARS + FAULT_CHARS) * CHAR_BYTES
    )
    return max(command, fault)


def answer(data: bytes | bytearray | memoryview) -> Message:
    """A controller's message to the referee, decoded once and checked, a `command` message's
    command made the API's Command. ProtocolError for a malformed message; CommandError (its
    text naming the field) for a well-formed `command` message whose command fails its checks."""
    try:
        msg = _decode(_ANSWER, data, "message")
    except ProtocolError as e:
        text = str(e)
        if text.rpartition(" - at `")[2].startswith("message.command"):
            raise CommandError(text.replace("message", "command", 1).replace("`message.command", "`command")) from None
        raise
    if isinstance(msg, CommandMsg):
        return CommandMsg(v=msg.v, tick=msg.tick, command=_dataclass(msg.command, Command))
    return msg


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
