"""Keeping the truth from controllers: a non-dumpable referee and unprivileged controllers.

See docs/security.md for the threat model.
"""

from __future__ import annotations

import ctypes
import os
import pwd
import shutil
import stat
from pathlib import Path

from referee.errors import UserError

PR_SET_DUMPABLE = 4
UNPRIVILEGED_USER = "nobody"


def make_undumpable() -> bool:
    """Mark this process non-dumpable, so no same-user process can read its memory or
    environment through /proc or ptrace. Returns whether it worked (Linux only)."""
    try:
        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def drop_to() -> pwd.struct_passwd | None:
    """The user controllers run as: `nobody` when the referee is root, else None (same user)."""
    if os.geteuid() != 0:
        return None
    try:
        return pwd.getpwnam(UNPRIVILEGED_USER)
    except KeyError:
        raise UserError(f"the referee runs as root but there is no user {UNPRIVILEGED_USER!r} "
                        "to run controllers as") from None


def check_readable_by_others(*paths: str) -> None:
    """Fail in one line unless every path (and each folder above it) lets other users in."""
    for p in paths:
        path = Path(p).resolve()
        for part in [path, *path.parents]:
            mode = part.stat().st_mode
            need = stat.S_IXOTH if part.is_dir() else stat.S_IROTH
            if not mode & need:
                raise UserError(f"controllers run as {UNPRIVILEGED_USER!r} when the referee is root, but "
                                f"{part} is closed to other users; install laserarena where they can read it")


def share_team_file(spec: str, folder: Path) -> str:
    """Copy a team's file into `folder` (readable by the controller's user); the spec for the copy."""
    path, _, rest = spec.partition(".py")
    source = Path(path + ".py")
    target = folder / source.name
    shutil.copyfile(source, target)
    os.chmod(target, 0o644)
    return str(target) + rest
