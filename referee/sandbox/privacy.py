"""Keeping the truth from controllers: a non-dumpable referee and unprivileged controllers
(`nobody` without a kernel sandbox; a uid per slot inside one, see referee/sandbox/uids.py).

See docs/security.md for the threat model.
"""

from __future__ import annotations

import ctypes
import functools
import os
import signal
import stat
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from referee.errors import UserError

if TYPE_CHECKING:  # imported where used: Windows has no pwd module
    import pwd

PR_SET_DUMPABLE = 4
UNPRIVILEGED_USER = "nobody"


def make_undumpable() -> bool:
    """Mark this process non-dumpable, so no same-user process can read its memory or
    environment through /proc or ptrace. Returns whether it worked (Linux only)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) == 0
    except (OSError, AttributeError, TypeError):
        return False


def is_root() -> bool:
    """Whether this process runs as root (never on a system without POSIX users)."""
    return getattr(os, "geteuid", lambda: -1)() == 0


def drop_to() -> pwd.struct_passwd | None:
    """The user controllers run as without a kernel sandbox: `nobody` when the referee is root,
    else None (same user). None too where root cannot become `nobody` (a container's user
    namespace that maps root alone): `cannot_drop` then says so."""
    if not is_root():
        return None
    import pwd  # POSIX only: reached as root alone

    try:
        user = pwd.getpwnam(UNPRIVILEGED_USER)
    except KeyError:
        raise UserError(
            f"the referee runs as root but there is no user {UNPRIVILEGED_USER!r} to run controllers as"
        ) from None
    return None if cannot_drop() else user


def switches_users() -> bool:
    """Whether controllers run as other users than the referee: root, able to become them."""
    return is_root() and not cannot_drop()


@functools.cache
def cannot_drop() -> bool:
    """Whether this root process is unable to start a process as `nobody` (tried once)."""
    import pwd

    user = pwd.getpwnam(UNPRIVILEGED_USER)
    # Ctrl-C and SIGTERM wait until the child has been reaped: delivered during the fork, the
    # parent's handler would run inside an at-fork hook (which swallows its exception), and the
    # child, a copy of the referee in the same process group, would run on as a second one
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        pid = os.fork()
        if pid == 0:  # the child only tries, and ends at once
            try:
                os.setgroups([])
                os.setgid(user.pw_gid)
                os.setuid(user.pw_uid)
            except OSError:
                os._exit(1)
            os._exit(0)
        return os.waitpid(pid, 0)[1] != 0
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def check_readable_by_others(*paths: str) -> None:
    """Fail in one line unless every path (and each folder above it) lets other users in."""
    for p in paths:
        path = Path(p).resolve()
        for part in [path, *path.parents]:
            mode = part.stat().st_mode
            need = stat.S_IXOTH if part.is_dir() else stat.S_IROTH
            if not mode & need:
                raise UserError(
                    f"controllers run as {UNPRIVILEGED_USER!r} when the referee is root, but "
                    f"{part} is closed to other users; install laserarena where they can read it"
                )


def share_team_files(files: tuple[tuple[str, bytes], ...], folder: Path) -> None:
    """Write a team's files into `folder`, readable by the controller's user (no kernel sandbox)."""
    for rel, data in files:
        target = folder / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        target.parent.chmod(0o755)
        target.write_bytes(data)
        os.chmod(target, 0o644)
