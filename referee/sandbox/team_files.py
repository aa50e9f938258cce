"""Reading a team's files for shipping: each file once, never through a link, within bounds.

The referee may run as root, so reading a team is reading what a stranger chose. Every file is
opened relative to its folder's descriptor with O_NOFOLLOW (a symbolic link anywhere is
refused) and O_NONBLOCK (a fifo cannot stall the referee), then checked on that descriptor
(fstat): a regular file with one hard link only, so a link to /etc/shadow or to a journal is
refused, with no window between the check and the read. As root, a file must also be readable
by the team folder's owner or by anyone (docs/security.md says why). A package is walked
depth-first with bounded depth, entries and bytes, and refused as soon as one bound is passed;
a folder team without `__init__.py` ships the Python files at its top alone.
"""

from __future__ import annotations

import errno
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

from referee.errors import TeamError
from referee.sandbox.privacy import is_root
from referee.terminal import safe

MAX_FILES = 500  # files and folders a team may ship: each becomes a descriptor and a mount in its sandbox
MAX_BYTES = 64 << 20
MAX_DEPTH = 32  # folders below a package's own
SKIPPED_DIRS = ("__pycache__",)  # bytecode caches: never shipped, never read
LINK = "a symbolic link; a team ships plain files of its own"
OPEN = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC


@dataclass
class _Walk:
    """One team's reading: its name for messages, its folder's owner, what is left to spend."""

    team: str
    owner: int
    files: int = MAX_FILES
    size: int = MAX_BYTES
    found: list[tuple[str, bytes]] = field(default_factory=list)

    def refuse(self, where: object, why: str) -> TeamError:
        return TeamError(f"team {safe(self.team)}: {safe(str(where), 300)}: {why}")

    def spend(self, where: object) -> None:
        """Count one more file or folder against MAX_FILES."""
        self.files -= 1
        if self.files < 0:
            raise self.refuse(where, f"over {MAX_FILES} files and folders")


def _open(walk: _Walk, name: str, shown: object, folder: int | None) -> tuple[int, os.stat_result]:
    """Open `name` (relative to the descriptor `folder`) without following a link; its fstat."""
    try:
        fd = os.open(name, OPEN, dir_fd=folder)
    except OSError as e:
        if e.errno == errno.ELOOP:
            raise walk.refuse(shown, LINK) from None
        raise walk.refuse(shown, f"cannot be read ({e.strerror or e})") from None
    return fd, os.fstat(fd)


def _read(walk: _Walk, fd: int, st: os.stat_result, shown: object) -> bytes:
    """The bytes of the opened file `fd`, after the checks on its own descriptor."""
    if not stat.S_ISREG(st.st_mode):
        raise walk.refuse(shown, "not a regular file; a team ships plain files of its own")
    if st.st_nlink > 1:
        raise walk.refuse(shown, f"a file with {st.st_nlink} hard links; a team ships files of its own")
    if is_root() and not (st.st_mode & stat.S_IROTH or st.st_uid == walk.owner and st.st_mode & stat.S_IRUSR):
        raise walk.refuse(shown, "closed to the team folder's owner; make it readable by its owner or by all")
    walk.spend(shown)
    if st.st_size > walk.size:
        raise walk.refuse(shown, f"over {MAX_BYTES >> 20} MiB in all")
    chunks, left = [], walk.size
    while chunk := os.read(fd, min(left + 1, 1 << 20)):  # a file that grows as it is read stops at the bound
        chunks.append(chunk)
        left -= len(chunk)
        if left < 0:
            raise walk.refuse(shown, f"over {MAX_BYTES >> 20} MiB in all")
    walk.size = left
    return b"".join(chunks)


def read_file(path: Path, team: str) -> bytes:
    """The bytes of a one-file team at `path` (its own name not a link); TeamError in one line."""
    try:
        owner = os.stat(path.parent).st_uid
    except OSError as e:
        raise TeamError(f"team {safe(team)}: {safe(str(path.parent), 300)}: {e.strerror or e}") from None
    walk = _Walk(team, owner)
    fd, st = _open(walk, str(path), path, None)
    try:
        return _read(walk, fd, st, path)
    finally:
        os.close(fd)


def _names(walk: _Walk, folder: int, shown: Path) -> list[os.DirEntry]:
    """A folder's entries, sorted, bytecode caches left out; refused once over the bound."""
    entries: list[os.DirEntry] = []
    with os.scandir(folder) as it:
        for entry in it:
            if entry.name in SKIPPED_DIRS or entry.name.endswith(".pyc"):
                continue
            if len(entries) >= walk.files:  # a folder of a million entries stops early
                raise walk.refuse(shown, f"over {MAX_FILES} files and folders")
            if not entry.name.isprintable():  # it goes into hashes and mount points
                raise walk.refuse(shown / entry.name, "a name that is not printable")
            entries.append(entry)
    return sorted(entries, key=lambda e: e.name)


def _walk(walk: _Walk, folder: int, shown: Path, rel: str, depth: int | None) -> None:
    """Read every file below the opened folder `folder` into `walk.found`; with `depth` None,
    its Python files alone (`*.py`, not below it), named without a folder."""
    for entry in _names(walk, folder, shown):
        if depth is None and not entry.name.endswith(".py"):
            continue  # a folder team's other files and folders stay home, unread
        where, inner = shown / entry.name, f"{rel}/{entry.name}" if rel else entry.name
        if entry.is_symlink():
            raise walk.refuse(where, LINK)
        if not (entry.is_file(follow_symlinks=False) or entry.is_dir(follow_symlinks=False)):
            raise walk.refuse(where, "not a regular file or folder")  # never opened: a device, a fifo, a socket
        fd, st = _open(walk, entry.name, where, folder)
        try:
            if stat.S_ISDIR(st.st_mode):
                if depth is None:
                    continue
                if depth >= MAX_DEPTH:
                    raise walk.refuse(where, f"more than {MAX_DEPTH} folders deep")
                walk.spend(where)
                _walk(walk, fd, where, inner, depth + 1)
            else:
                walk.found.append((inner, _read(walk, fd, st, where)))
        finally:
            os.close(fd)


def _read_folder(root: Path, team: str, rel: str, depth: int | None) -> tuple[tuple[str, bytes], ...]:
    """The files `_walk` finds below the folder `root` (its own name not a link), in path order."""
    walk = _Walk(team, -1)
    fd, st = _open(walk, str(root), root, None)
    try:
        if not stat.S_ISDIR(st.st_mode):
            raise walk.refuse(root, "not a folder")
        walk.owner = st.st_uid
        _walk(walk, fd, root, rel, depth)
    finally:
        os.close(fd)
    return tuple(sorted(walk.found))


def read_package(root: Path, team: str) -> tuple[tuple[str, bytes], ...]:
    """Every file of the package folder `root` (its own name not a link), as (path relative to
    its parent, bytes) in path order; TeamError in one line on a link, a special file, a file
    with other hard links or one closed to the folder's owner, or past a bound."""
    return _read_folder(root, team, root.name, 0)


def read_modules(root: Path, team: str) -> tuple[tuple[str, bytes], ...]:
    """The Python files at the top of the folder `root` (a folder team without `__init__.py`),
    as (file name, bytes) in name order: its modules import each other by name; its other files
    and folders are not shipped. TeamError in one line as `read_package`."""
    return _read_folder(root, team, "", None)
