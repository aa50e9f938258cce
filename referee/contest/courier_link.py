"""What the organizer's process and its courier (the process that holds the Dask client,
`referee.contest.courier`) say to each other: typed msgpack frames, each a length and its
bytes, decoded by msgspec into the types below and nothing else. No pickle crosses this link:
whatever Dask unpickles stays in the courier.
"""

from __future__ import annotations

import struct
from typing import IO, Annotated

import msgspec

from referee.contest.cluster_keys import Credentials
from referee.contest.runner import MatchJob
from referee.records.replay_format import MAX_REPLAY

MAX_FRAME = MAX_REPLAY + (16 << 20)  # a replay and its result, with room to spare
_LENGTH = struct.Struct(">Q")
_Text = Annotated[str, msgspec.Meta(max_length=4096)]


class Order(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """Organizer -> courier, once: the scheduler, the client's TLS material (None: plain
    tcp://, the organizer accepted it) and every job, in order."""

    address: str
    keys: Credentials | None
    jobs: list[MatchJob]


class Returned(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="returned"):
    """A job's match came back: its index in the order, the worker the scheduler says held
    it, and what the worker returned (result JSON, replay bytes, wall seconds)."""

    index: int
    worker: _Text
    result: str
    replay: bytes
    wall: float


class Refused(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="refused"):
    """A job the worker would not or could not play: its one-line reason, as the worker says.
    `worker` is "" when no worker could be named (the task erred before its result was kept)."""

    index: int
    worker: _Text
    reason: _Text


class Failed(msgspec.Struct, frozen=True, forbid_unknown_fields=True, tag="failed"):
    """The cluster cannot be used (unreachable, refused, a worker of another version): one line."""

    reason: _Text


Report = Returned | Refused | Failed


def send(stream: IO[bytes], message: Order | Report) -> None:
    """Write one frame and flush it."""
    data = msgspec.msgpack.encode(message)
    stream.write(_LENGTH.pack(len(data)) + data)
    stream.flush()


def _frame(stream: IO[bytes]) -> bytes | None:
    head = stream.read(_LENGTH.size)
    if not head:
        return None
    if len(head) < _LENGTH.size:
        raise ValueError("a frame cut short")
    (size,) = _LENGTH.unpack(head)
    if size > MAX_FRAME:
        raise ValueError(f"a frame of {size} bytes, more than {MAX_FRAME}")
    data = stream.read(size)
    if len(data) < size:
        raise ValueError("a frame cut short")
    return data


def receive_order(stream: IO[bytes]) -> Order:
    """The courier's one order (ValueError if there is none or it is not one)."""
    data = _frame(stream)
    if data is None:
        raise ValueError("no order")
    return msgspec.msgpack.decode(data, type=Order)


def receive_report(stream: IO[bytes]) -> Report | None:
    """The courier's next report, or None once it has closed its end; ValueError on bytes
    that are not a report (msgspec's ValidationError is one)."""
    data = _frame(stream)
    return None if data is None else msgspec.msgpack.decode(data, type=Report)
