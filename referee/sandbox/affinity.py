"""One CPU for a match with one controller process: its referee thread and its controller share it.

Talking to a controller costs a wake-up of the other side at every control tick, each way. On
one CPU a wake-up is a switch between the two processes; across two CPUs it is a signal to a
sleeping processor, several times dearer (a pipe round trip: about 6 us against about 60 us
on the development machine's virtual CPUs, `benchmarks/isolation.py`). A match with one
controller gains nothing from a second CPU, since the referee waits while its controller
thinks; so it pins both to the CPU the referee runs on (docs/decisions/0026). Matches with
several controllers keep every CPU: their controllers think side by side.

Two referees pinned to one CPU would halve each other's speed while another CPU idles, so a
CPU is claimed with a lock file (`laserarena-cpu-N.lock` in the temporary folder) before it is
taken: a referee whose CPU is claimed takes a free one, or none (the match runs unpinned).
"""

from __future__ import annotations

import ctypes
import os
import tempfile
from dataclasses import dataclass


@dataclass(frozen=True)
class Claim:
    """A CPU this thread holds: the lock's descriptor and the CPUs it ran on before."""

    cpu: int
    lock: int
    before: frozenset[int]


def _current_cpu() -> int | None:
    """The CPU this thread runs on now (glibc's sched_getcpu), or None where it cannot say."""
    try:
        cpu = ctypes.CDLL(None).sched_getcpu()
    except (OSError, AttributeError):
        return None
    return cpu if cpu >= 0 else None


def _lock(cpu: int) -> int | None:
    """The lock file of `cpu`, held (its descriptor), or None if another process holds it."""
    import fcntl  # POSIX; claim() is never called without sched_setaffinity (Linux)

    path = os.path.join(tempfile.gettempdir(), f"laserarena-cpu-{cpu}.lock")
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC  # a lock needs no write access: any user's file serves
    try:
        try:
            fd = os.open(path, flags)
        except FileNotFoundError:
            fd = os.open(path, flags | os.O_CREAT | os.O_EXCL, 0o644)
    except OSError:  # a link, a file we may not read, or one made meanwhile: not ours to take
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def claim() -> Claim | None:
    """Pin this thread to a CPU no other LaserArena referee holds, the one it runs on if it
    can; None (nothing changed) where there is no choice of CPU or no CPU is free."""
    if not hasattr(os, "sched_setaffinity"):
        return None  # not Linux
    before = frozenset(os.sched_getaffinity(0))
    if len(before) < 2:
        return None
    now = _current_cpu()
    for cpu in ([now] if now in before else []) + sorted(before - {now}):
        fd = _lock(cpu)
        if fd is None:
            continue
        try:
            os.sched_setaffinity(0, {cpu})
        except OSError:
            os.close(fd)
            return None
        return Claim(cpu, fd, before)
    return None


def release(held: Claim) -> None:
    """Give the CPU back: this thread runs where it ran before, and the lock is freed."""
    try:
        os.sched_setaffinity(0, held.before)
    finally:
        os.close(held.lock)
