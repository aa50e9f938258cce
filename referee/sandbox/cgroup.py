"""A control group per controller slot: the memory and process boundary the kernel keeps.

An address-space limit sees only what a process maps. A slot's private /tmp and /dev/shm,
memfds, pipe buffers and the page cache it fills are memory too, owned by no mapping: a
cgroup counts them all, with the process's own, against the slot's `memory_mb`, and its
out-of-memory killer then chooses within the slot, never another slot or the referee. It
also caps the slot's processes and threads (`pids`).

Made where the referee is root and finds the controllers mounted: cgroup v2 (a `laserarena`
group at the root of the unified hierarchy, with `memory` and `pids` enabled below it) or
cgroup v1 (a group under the referee's own in the `memory` and `pids` hierarchies). Elsewhere
`available()` says why not, and a slot keeps the limits its runner sets (docs/security.md).
A controller joins its groups itself, before it drops root, by writing to descriptors of the
groups' `cgroup.procs` that the referee opened (`SlotGroup.procs`).
"""

from __future__ import annotations

import functools
import itertools
import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path

from referee.sandbox.privacy import is_root

PREFIX = "laserarena-"
V2_PARENT = "laserarena"  # at the root of the unified hierarchy
CONTROLLERS = ("memory", "pids")
REMOVE_TIME = 2.0  # seconds a slot's group may take to empty once its processes are killed
_names = itertools.count()


@dataclass(frozen=True)
class Place:
    """Where slot groups are made: a folder per hierarchy, and the cgroup version."""

    folders: tuple[Path, ...]
    version: int


def _mounts() -> list[tuple[str, str, set[str]]]:
    """(mount point, file system type, options) of every cgroup mount, from mountinfo."""
    found = []
    for line in Path("/proc/self/mountinfo").read_text().splitlines():
        left, _, right = line.partition(" - ")
        fstype, _, rest = right.partition(" ")
        if fstype in ("cgroup", "cgroup2"):
            options = set(rest.split(" ", 1)[1].split(",")) if " " in rest else set()
            found.append((left.split()[4], fstype, options))
    return found


def _own_v1(controller: str) -> str | None:
    """This process's group in the v1 hierarchy of `controller` (/proc/self/cgroup)."""
    for line in Path("/proc/self/cgroup").read_text().splitlines():
        _, names, path = line.split(":", 2)
        if controller in names.split(","):
            return path
    return None


def _place() -> Place | str:
    """Where slot groups can be made, or why not."""
    mounts = _mounts()
    for unified, fstype, _ in mounts:
        if fstype == "cgroup2":
            root = Path(unified)
            try:
                enabled = set((root / "cgroup.controllers").read_text().split())
            except OSError:
                continue
            if set(CONTROLLERS) <= enabled:
                parent = root / V2_PARENT
                parent.mkdir(exist_ok=True)
                for folder in (root, parent):
                    (folder / "cgroup.subtree_control").write_text(" ".join(f"+{c}" for c in CONTROLLERS))
                return Place((parent,), 2)
    folders = []
    for controller in CONTROLLERS:
        point = next((p for p, t, options in mounts if t == "cgroup" and controller in options), None)
        own = _own_v1(controller)
        if point is None or own is None:
            return f"no cgroup hierarchy with the {controller} controller is mounted"
        folders.append(Path(point + own.rstrip("/")) if own != "/" else Path(point))
    return Place(tuple(folders), 1)


def _sweep(place: Place) -> None:
    """Remove the empty groups a referee that was killed left behind (its pid is gone)."""
    for folder in place.folders:
        for group in folder.glob(f"{PREFIX}*"):
            pid = group.name[len(PREFIX) :].split("-")[0]
            if pid.isdigit() and not Path(f"/proc/{pid}").exists():
                try:
                    group.rmdir()
                except OSError:
                    pass


@functools.cache
def available() -> Place | str:
    """Where this referee makes its slots' groups, or why it cannot (probed once: a group is
    made, limited and removed)."""
    if not is_root():
        return "the referee is not root"
    try:
        place = _place()
        if isinstance(place, str):
            return place
        _sweep(place)
        SlotGroup(place, 64 << 20, 8).close()
    except OSError as e:
        return f"cannot make a control group: {e.strerror or e}"
    return place


def _write(path: str, text: str) -> None:
    """Write `text` to the control file `path`; FileNotFoundError where the kernel has no such file."""
    fd = os.open(path, os.O_WRONLY | os.O_CLOEXEC)
    try:
        os.write(fd, text.encode())
    finally:
        os.close(fd)


class SlotGroup:
    """One slot's group in each hierarchy of `place`: at most `memory` bytes (no swap; 0: no
    bound) and `pids` processes and threads. Its folders are plain strings: made and removed
    for every controller, where pathlib's objects cost more than the system calls."""

    def __init__(self, place: Place, memory: int, pids: int):
        self.place, self.folders = place, list[str]()
        name = f"{PREFIX}{os.getpid()}-{next(_names)}"
        try:
            for folder in place.folders:
                group = f"{folder}/{name}"
                os.mkdir(group)
                self.folders.append(group)
            self._limit(memory, pids)
        except OSError:
            self.close()
            raise

    def _limit(self, memory: int, pids: int) -> None:
        """Set the limits; `memory` 0: none (`--no-limits`)."""
        bound: int | str = memory or ("max" if self.place.version == 2 else -1)
        settings = (
            {"memory.max": bound, "memory.swap.max": 0, "memory.oom.group": 1, "pids.max": pids}
            if self.place.version == 2
            else {"memory.limit_in_bytes": bound, "memory.memsw.limit_in_bytes": bound, "pids.max": pids}
        )
        for key, value in settings.items():
            for group in self.folders:
                try:
                    _write(f"{group}/{key}", str(value))
                except FileNotFoundError:
                    pass  # not in this hierarchy, or not on this kernel (swap accounting off)

    def procs(self) -> list[int]:
        """Descriptors of the groups' `cgroup.procs`, opened for writing by this process: the
        controller writes `0` to each to join (the caller closes them once it has started)."""
        return [os.open(f"{group}/cgroup.procs", os.O_WRONLY | os.O_CLOEXEC) for group in self.folders]

    def oom_kills(self) -> int:
        """How many processes of the slot the kernel killed for holding more than its memory."""
        for group in self.folders:
            for key in ("memory.events", "memory.oom_control"):
                path = Path(group, key)
                if path.exists():
                    for line in path.read_text().splitlines():
                        name, _, count = line.partition(" ")
                        if name == "oom_kill":
                            return int(count)
        return 0

    def close(self) -> None:
        """Kill whatever still runs in the slot and remove its groups."""
        deadline = time.monotonic() + REMOVE_TIME
        for group in reversed(self.folders):
            while True:
                try:
                    os.rmdir(group)
                    break
                except FileNotFoundError:
                    break
                except OSError:
                    if time.monotonic() > deadline:
                        break  # left for the next referee's sweep
                    for pid in Path(group, "cgroup.procs").read_text().split():
                        try:
                            os.kill(int(pid), signal.SIGKILL)
                        except ProcessLookupError:
                            pass
                    time.sleep(0.01)
        self.folders = []
