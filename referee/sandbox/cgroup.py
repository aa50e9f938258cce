"""Control groups: the memory, process and CPU boundary the kernel keeps around each controller slot.

- **memory**: an address-space limit sees only what a process maps. A slot's private /tmp and
  /dev/shm, memfds, pipe and socket buffers and the page cache it fills are memory too, owned
  by no mapping: the slot's group counts them all against its `memory_mb`, and its
  out-of-memory killer then chooses within the slot, never another slot or the referee.
- **pids**: at most so many processes and threads.
- **cpu**: every slot weighs what one process at the organizer's `nice` weighs, whatever
  sessions, threads or children it has (a process in a group of its own is in no session's
  autogroup); the referee's own group weighs `REFEREE_WEIGHT` slots, so it keeps time.

How it works, in detail: docs/internals.md, `referee/sandbox/cgroup.py`.
"""

from __future__ import annotations

import atexit
import functools
import itertools
import os
import re
import secrets
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from referee.sandbox import leases
from referee.sandbox.privacy import is_root

PREFIX = "laserarena-"
GROUP_NAME = re.compile(r"laserarena-([0-9a-f]{12})-(referee|slot-\d+)")  # older referees' named no run
NEEDED, OPTIONAL = ("memory", "pids"), ("cpu",)
KIND = "cgroups"  # the runs' leases
REMOVE_TIME = 2.0  # seconds a slot's group may take to empty once its processes are killed
GRACE = 60.0  # seconds a new group is left alone by other referees' sweeps (it may be being made)
REFEREE_WEIGHT = 8  # the referee's group weighs this many slots
# the kernel's weight of each nice value -20..19 (sched_prio_to_weight), for cpu.shares (v1)
NICE_WEIGHTS = (
    *(88761, 71755, 56483, 46273, 36291, 29154, 23254, 18705, 14949, 11916),
    *(9548, 7620, 6100, 4904, 3906, 3121, 2501, 1991, 1586, 1277),
    *(1024, 820, 655, 526, 423, 335, 272, 215, 172, 137),
    *(110, 87, 70, 56, 45, 36, 29, 23, 18, 15),
)


@dataclass(frozen=True)
class Place:
    """Where groups are made: a folder per hierarchy (one for v2), the cgroup version, and
    whether the cpu controller is among them; each folder's hierarchy (its mount point, and
    its controller for v1, None for the unified one)."""

    folders: tuple[Path, ...]
    version: int
    cpu: bool
    cpu_folder: Path | None = None  # where groups are made in the hierarchy that has cpu
    mounts: tuple[tuple[Path, str | None], ...] = ()


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


def _own(controller: str | None) -> str | None:
    """This process's group in the v1 hierarchy of `controller`, or in the unified one (None)."""
    for line in Path("/proc/self/cgroup").read_text().splitlines():
        number, names, path = line.split(":", 2)
        if controller in names.split(",") or controller is None and number == "0":
            return path
    return None


def _base(own: str) -> str:
    """Where a referee in group `own` makes its groups: beside it, or, for a process started
    from within another referee's group, beside that one, where every referee's are (and are
    swept)."""
    parts = own.rstrip("/").split("/")
    cut = next((i for i, part in enumerate(parts) if GROUP_NAME.fullmatch(part)), len(parts))
    return "/".join(parts[:cut]) or "/"


def weight(nice: int, version: int, slots: int = 1) -> int:
    """The cpu weight of `slots` processes at `nice`: cpu.shares (v1, the kernel's table) or
    cpu.weight (v2: 100 for a nice-0 process, 1 to 10000)."""
    shares = NICE_WEIGHTS[max(-20, min(19, nice)) + 20] * slots
    return shares if version == 1 else max(1, min(10000, round(shares * 100 / 1024)))


def _enable(folder: Path, controllers: tuple[str, ...]) -> None:
    (folder / "cgroup.subtree_control").write_text(" ".join(f"+{c}" for c in controllers))


def _v2(mounts: list[tuple[str, str, set[str]]]) -> Place | None:
    for point, fstype, _ in mounts:
        if fstype != "cgroup2":
            continue
        root = Path(point)
        try:
            enabled = set((root / "cgroup.controllers").read_text().split())
        except OSError:
            continue
        if set(NEEDED) <= enabled:
            _enable(root, NEEDED)
            cpu = "cpu" in enabled
            try:  # the cpu controller (refused where a real-time process sits in a group)
                if cpu:
                    _enable(root, ("cpu",))
            except OSError:
                cpu = False
            return Place((root,), 2, cpu, root if cpu else None, ((root, None),))
    return None


def _v1(mounts: list[tuple[str, str, set[str]]]) -> Place | str:
    folders, cpu, hierarchies = [], None, []
    for controller in NEEDED + OPTIONAL:
        point = next((p for p, t, options in mounts if t == "cgroup" and controller in options), None)
        own = _own(controller)
        if point is None or own is None:
            if controller in OPTIONAL:
                continue
            return f"no cgroup hierarchy with the {controller} controller is mounted"
        folder = Path(point + _base(own).rstrip("/"))
        folders.append(folder)
        hierarchies.append((Path(point), controller))
        cpu = folder if controller == "cpu" else cpu
    return Place(tuple(folders), 1, cpu is not None, cpu, tuple(hierarchies))


def _place() -> Place | str:
    """Where groups can be made, or why not."""
    mounts = _mounts()
    return _v2(mounts) or _v1(mounts)


def _remove_tree(group: Path) -> None:
    """Remove a group and the groups below it, where they are empty; leave what is not."""
    for below in sorted((p for p in group.rglob("*") if p.is_dir()), key=lambda p: -len(p.parts)):
        try:
            below.rmdir()
        except OSError:
            pass
    try:
        group.rmdir()
    except OSError:
        pass


def _alive(group: Path) -> bool:
    """Whether a process is in `group`."""
    try:
        return bool((group / "cgroup.procs").read_text().strip())
    except OSError:
        return False


def _sweep(place: Place) -> None:
    """Remove the groups of runs that no live referee holds (a killed one's), and empty groups
    of older referees (named by their pid). The groups of a run with a process in any of them
    are left (a live referee is in its own), and so are those of a run held by a lease this
    referee can see. Where it cannot tell (no lease: a referee with a /run of its own, a
    container's, holds it where this one cannot see), a run with a group made or changed in
    the last GRACE seconds is left too: it may be being set up. Nothing here may fail a run."""
    holders: dict[str, bool | None] = {}  # each run's lease, asked once (asking of a free one gives it up)
    for folder in place.folders:
        try:
            groups = [p for p in folder.glob(f"{PREFIX}*") if p.is_dir()]
        except OSError:
            continue
        runs: dict[str, list[Path]] = {}
        for group in groups:
            named = GROUP_NAME.fullmatch(group.name)
            runs.setdefault(named.group(1) if named else group.name, []).append(group)
        for name, members in runs.items():
            try:
                if any(_alive(group) for group in members):
                    continue
                ours = GROUP_NAME.fullmatch(members[0].name) is not None
                if ours and name not in holders:
                    holders[name] = leases.held(KIND, f"{PREFIX}{name}")
                holder = holders[name] if ours else False
                if holder or holder is None and any(time.time() - g.stat().st_mtime < GRACE for g in members):
                    continue
                for group in members:
                    _remove_tree(group)
            except OSError:
                continue


def _write(path: str, text: str) -> None:
    """Write `text` to the control file `path`; FileNotFoundError where the kernel has no such file."""
    fd = os.open(path, os.O_WRONLY | os.O_CLOEXEC)
    try:
        os.write(fd, text.encode())
    finally:
        os.close(fd)


BEST_EFFORT = (
    "memory.kmem.tcp.limit_in_bytes",
    "memory.memsw.limit_in_bytes",
    "memory.swap.max",
)  # kernels refuse some


def _settle(settings: dict[str, object], folders: list[str]) -> None:
    """Write each setting to each folder that has it (a hierarchy without it, or a kernel
    without it, is passed over, as is a refusal of one of BEST_EFFORT)."""
    for key, value in settings.items():
        for group in folders:
            try:
                _write(f"{group}/{key}", str(value))
            except FileNotFoundError:
                pass
            except OSError:
                if key not in BEST_EFFORT:
                    raise


class Run:
    """This referee process's groups: its own `referee` group in each hierarchy (it moves in),
    weighing REFEREE_WEIGHT slots in the cpu hierarchy, and its slots' groups beside it.

    The move is made on a thread of its own: the kernel makes a process's first move wait a
    read-copy-update grace period (10-40 ms) without using a CPU, which the referee's start
    spends loading its modules meanwhile. Children started before it ends (a controller
    template) stay where the referee was; each slot joins its own groups anyway."""

    def __init__(self, place: Place):
        self.place, self.pid = place, os.getpid()
        self.slots = itertools.count()
        self.name = f"{PREFIX}{secrets.token_hex(6)}"
        lease = leases.take(KIND, self.name)
        if lease is None:
            raise OSError(f"the control group name {self.name} is held")
        self.lease, self.folders = lease, list[str]()
        self.homes = list[str]()  # the groups this process left for its `referee` groups
        self._leaving: threading.Thread | None = None  # its move back (`leave`)
        self.nice = os.getpriority(os.PRIO_PROCESS, 0)  # the organizer's, carried to every group
        try:
            for folder in place.folders:
                os.mkdir(f"{folder}/{self.name}-referee")
                self.folders.append(f"{folder}/{self.name}-referee")
            if place.cpu:
                _settle({self.cpu_key(): weight(self.nice, place.version, REFEREE_WEIGHT)}, self.folders)
        except OSError:
            self.close()
            raise
        self._entering = threading.Thread(target=self._enter, name="laserarena-cgroup", daemon=True)
        self._entering.start()

    def cpu_key(self) -> str:
        return "cpu.weight" if self.place.version == 2 else "cpu.shares"

    def _enter(self) -> None:
        """Move this process into its `referee` group in each hierarchy (where the kernel
        refuses, it stays where it was: its slots still weigh one each)."""
        for group, (mount, controller) in zip(self.folders, self.place.mounts):
            home = f"{mount}{(_own(controller) or '/').rstrip('/')}"
            try:
                _write(f"{group}/cgroup.procs", str(os.getpid()))
            except OSError:
                continue
            self.homes.append(home)

    def group(self) -> list[str]:
        """A new slot group's folder in each hierarchy (made)."""
        name = f"{self.name}-slot-{next(self.slots)}"
        made = []
        try:
            for folder in self.place.folders:
                os.mkdir(f"{folder}/{name}")
                made.append(f"{folder}/{name}")
        except OSError:
            for group in made:
                os.rmdir(group)
            raise
        return made

    def leave(self) -> None:
        """Back to where this process was, on a thread of its own: the move waits a grace
        period, as the move in did (`close` joins it, or moves back itself where Python
        starts no thread at its exit, as 3.12 does)."""
        if os.getpid() != self.pid or self._leaving is not None:
            return
        leaving = threading.Thread(target=self._go_home, name="laserarena-cgroup-out", daemon=True)
        try:
            leaving.start()
        except RuntimeError:  # "can't create new thread at interpreter shutdown"
            return
        self._leaving = leaving

    def _go_home(self) -> None:
        """Move this process back into the groups it left (where it moved in at all)."""
        entering = getattr(self, "_entering", None)
        if entering is not None:
            entering.join()  # in, before it moves back out
        for home in self.homes:
            try:
                _write(f"{home}/cgroup.procs", str(os.getpid()))
            except OSError:
                pass

    def close(self) -> None:
        """Back to where this process was; remove its groups (what cannot be removed is left
        for the next referee's sweep) and give the name up."""
        if os.getpid() != self.pid or self.lease.fd < 0:
            return
        self.leave()
        if self._leaving is None:
            self._go_home()
        else:
            self._leaving.join()
        for folder in self.folders:
            _remove_tree(Path(folder))
        self.lease.release()


_runs: dict[int, Run] = {}


def run() -> Run:
    """This process's groups (made on first use; a forked child makes its own)."""
    current = _runs.get(os.getpid())
    if current is None:
        place = available()
        if isinstance(place, str):
            raise OSError(place)
        current = _runs[os.getpid()] = Run(place)
    return current


def leave_soon() -> None:
    """This process leaves its groups now, at exit, while other work ends (`Run.leave`)."""
    current = _runs.get(os.getpid())
    if current is not None:
        current.leave()


@atexit.register
def _close_run() -> None:
    current = _runs.pop(os.getpid(), None)
    if current is not None:
        current.close()


@functools.cache
def available() -> Place | str:
    """Where this referee makes its slots' groups, or why it cannot (probed once: stale groups
    swept, a group made, limited and removed)."""
    if not is_root():
        return "the referee is not root"
    try:
        place = _place()
        if isinstance(place, str):
            return place
        _sweep(place)
        _runs[os.getpid()] = Run(place)
    except OSError as e:
        return f"cannot make a control group: {e.strerror or e}"
    return place


class SlotGroup:
    """One slot's group in each hierarchy, beside this process's: at most `memory` bytes (no
    swap; TCP buffers too where cgroup v1 counts them apart; 0: no bound), `pids` processes and
    threads, and the CPU weight of one process at the organizer's nice. Its folders are plain strings: made and removed for
    every controller, where pathlib's objects cost more than the system calls."""

    def __init__(self, memory: int, pids: int):
        current = run()
        self.place, self.nice = current.place, current.nice
        self.folders = current.group()
        try:
            self._limit(memory, pids)
        except OSError:
            self.close()
            raise

    def _limit(self, memory: int, pids: int) -> None:
        """Set the limits; `memory` 0: none (`--no-limits`)."""
        v2 = self.place.version == 2
        bound: int | str = memory or ("max" if v2 else -1)
        settings: dict[str, object] = (
            {"memory.max": bound, "memory.swap.max": 0, "memory.oom.group": 1, "pids.max": pids}
            if v2
            else {
                "memory.limit_in_bytes": bound,
                "memory.memsw.limit_in_bytes": bound,
                "memory.kmem.tcp.limit_in_bytes": bound,
                "pids.max": pids,
            }
        )
        if self.place.cpu:
            settings["cpu.weight" if v2 else "cpu.shares"] = weight(self.nice, self.place.version)
        _settle(settings, self.folders)

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
