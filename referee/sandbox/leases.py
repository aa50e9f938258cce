"""Names a root referee holds while it lives: the uid of each slot it runs (`uids`) and its
control groups (`cgroup`). A name is held by an exclusive lock on a file named after it, in a
folder of root's (`folder`); the kernel drops the lock when its holder ends, however it ends,
so no name is held twice on this machine, whatever PID namespace each referee sees its own pid
in (a container's referee is pid 1 in each), and a name a killed referee held is free at once.
"""

from __future__ import annotations

import functools
import os
import stat
import tempfile
from pathlib import Path

PLACES = ("/run/laserarena", "/var/run/laserarena")  # the first that is root's own; then a private temporary one


class Lease:
    """One name held: the open, locked file named after it."""

    def __init__(self, fd: int, path: Path):
        self.fd, self.path = fd, path

    @property
    def name(self) -> str:
        return self.path.name

    def release(self) -> None:
        """Give the name up: its file goes (while still locked, so no one holds a lock on a file
        that is gone from the folder), then the lock."""
        if self.fd < 0:
            return
        try:
            if os.stat(self.path, follow_symlinks=False).st_ino == os.fstat(self.fd).st_ino:
                os.unlink(self.path)
        except FileNotFoundError:
            pass
        os.close(self.fd)
        self.fd = -1


def _own_folder(path: Path) -> bool:
    """Make `path` (0700) unless it exists; whether it is a folder of root's that no one else may write."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.mkdir(mode=0o700, exist_ok=True)
        info = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.geteuid() and not info.st_mode & 0o022


@functools.cache
def folder(kind: str) -> Path:
    """The folder where names of `kind` are held (made 0700 on first use): under /run, where
    the machine has it, else a folder of this user's own in the temporary folder. OSError if
    none can be had."""
    for place in (*PLACES, os.path.join(tempfile.gettempdir(), f"laserarena-{os.geteuid()}")):
        if _own_folder(Path(place)) and _own_folder(Path(place, kind)):
            return Path(place, kind)
    raise OSError(f"no folder of root's to hold the referee's {kind} in (tried {', '.join(PLACES)})")


def take(kind: str, name: str) -> Lease | None:
    """Hold the name `name` of `kind`, or None if a live process holds it."""
    import fcntl  # POSIX only: leases are a root referee's, on Linux

    path = folder(kind) / name
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return None
        try:  # its last holder may have released it between our open and our lock: the file is gone
            if os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino:
                return Lease(fd, path)
        except FileNotFoundError:
            pass
        os.close(fd)


def held(kind: str, name: str) -> bool | None:
    """Whether a live process holds the name `name` of `kind`: True; False if its holder has
    ended without giving it up (a killed one: its file is left; taken and given up here); None
    if this process cannot tell (no file: given up, or held where this one cannot see, by a
    referee with a /run of its own)."""
    if not (folder(kind) / name).exists():
        return None
    lease = take(kind, name)
    if lease is None:
        return True
    lease.release()
    return False
