"""What the slot's boundary costs per slot and per answer, median of several runs each:

- `cpu_group_ms`: a slot's group in the cpu hierarchy made, weighed and removed (a root
  referee with a cpu controller; beside it `groups_ms`, the slot's memory and pids groups);
- `lease_us`: a slot uid leased and given up (a root referee: once per thread and slot);
- `stage_ms`: the staged installation found and held, as a referee process does once (its
  sources' identities read and hashed; the stage itself is made once per installation);
- `answer_us` and `answer_twice_us`: a typical answer (a command with an estimate and three
  drawings) decoded once, as the referee does, and as it did before, envelope then payload
  checked then decoded again; `largest_answer_ms` (and `largest_answer_twice_ms`): the largest
  legal answer, its numbers the slowest to read (what its sender's think budget pays).

Run: python benchmarks/boundary.py (prints the figures as JSON).
"""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable

import msgspec

from referee.sandbox import cgroup, leases, stage, uids
from robots._host import protocol
from robots.api import Command, Drawing

SLOW = -1.2345678901234567e-300  # a number of the slowest kind to read: 17 digits, an extreme exponent


def _median(work: Callable[[], object], runs: int) -> float:
    """Median seconds of `runs` calls of `work`."""
    took = []
    for _ in range(runs):
        t = time.perf_counter()
        work()
        took.append(time.perf_counter() - t)
    return statistics.median(took)


def _cpu_group() -> None:
    current = cgroup.run()
    folder = f"{current.place.cpu_folder}/{current.name}-bench"
    os.mkdir(folder)
    cgroup._settle({current.cpu_key(): cgroup.weight(0, current.place.version)}, [folder])
    os.rmdir(folder)


def _groups() -> None:
    cgroup.SlotGroup(64 << 20, 64).close()


def _lease() -> None:
    held = leases.take(uids.KIND, str(uids.SLOT_UIDS.stop - 1))
    assert held is not None
    held.release()


def _stage() -> None:
    stage.stage.cache_clear()
    stage.stage()


def typical() -> bytes:
    """A command as a localizing team sends it: wheels, an estimate, a few drawings."""
    debug = (
        Drawing("circle", ((0.61, 0.42),), 0.05, "", (0, 200, 0)),
        Drawing("line", ((0.61, 0.42), (0.7, 0.5)), 0.0, "", (0, 0, 255)),
        Drawing("text", ((0.61, 0.47),), 0.0, "est", (0, 0, 0)),
    )
    cmd = Command(0.0731, 0.0694, (0.6123, 0.4187, 1.5321), debug)
    return msgspec.json.encode(protocol.CommandMsg(v=1, tick=412, command=cmd))


def largest() -> bytes:
    """The largest command the schema allows, every number of the slowest kind to read."""
    drawing = Drawing("x" * 16, ((SLOW, SLOW),) * protocol.MAX_POINTS, -SLOW, "y" * protocol.MAX_TEXT)
    cmd = Command(SLOW, SLOW, (SLOW, SLOW, SLOW), (drawing,) * protocol.MAX_DRAWINGS)
    return msgspec.json.encode(protocol.CommandMsg(v=1, tick=412, command=cmd))


def measure(runs: int = 51) -> dict:
    data, big = typical(), largest()
    twin = msgspec.json.Decoder(protocol._twin(Command))  # made once, as the referee's are
    plain = msgspec.json.Decoder(Command)

    def twice(frame: bytes) -> None:
        msg = protocol.parse(frame)
        assert isinstance(msg, protocol.CommandMsg)
        twin.decode(msg.command)
        plain.decode(msg.command)

    out = {
        "answer_us": _median(lambda: protocol.answer(data), runs * 20) * 1e6,
        "answer_twice_us": _median(lambda: twice(data), runs * 20) * 1e6,
        "answer_bytes": len(data),
        "largest_answer_ms": _median(lambda: protocol.answer(big), 5) * 1e3,
        "largest_answer_twice_ms": _median(lambda: twice(big), 5) * 1e3,
        "largest_answer_bytes": len(big),
        "stage_ms": _median(_stage, runs) * 1e3,
    }
    place = cgroup.available()
    if not isinstance(place, str):
        out["groups_ms"] = _median(_groups, runs) * 1e3
        out["lease_us"] = _median(_lease, runs) * 1e6
        if place.cpu:
            out["cpu_group_ms"] = _median(_cpu_group, runs) * 1e3
    return out


if __name__ == "__main__":
    print(json.dumps(measure(), indent=1, sort_keys=True))
