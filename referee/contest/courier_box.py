"""How a root organizer starts the Dask courier as `nobody`, even when LaserArena is installed
below a folder other users cannot pass (a checkout in a 0700 folder, a pyenv under /root).

The courier needs the interpreter and the installed packages (Dask among them), nothing else
of the organizer's files: its order, keys included, comes on its stdin. Where bubblewrap
runs, the courier sees the system read-only with a private /tmp; each folder it needs that
lies below a closed one is bound again at its own path over an empty folder there, so that
`nobody` reaches it and nothing else of the closed folder. It keeps the network (it talks to
the scheduler). Without bubblewrap it runs as `nobody` directly, which must then reach them
all (a one-line error names the first it cannot).
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

from referee.errors import SandboxError
from referee.sandbox import kernel

__all__ = ["command"]


def _closed(folder: Path) -> Path | None:
    """The highest folder from the root down to `folder` (itself included) that other users
    cannot pass through, or None."""
    for f in [*reversed(folder.parents), folder]:
        try:
            mode = f.stat().st_mode
        except OSError:
            return None
        if stat.S_ISDIR(mode) and not mode & stat.S_IXOTH:
            return f
    return None


def _needed() -> list[Path]:
    """The folders the courier's interpreter reads: its prefixes and every folder on its path."""
    found = {
        Path(p).resolve() for p in (sys.prefix, sys.base_prefix, os.path.dirname(os.path.realpath(sys.executable)))
    }
    found |= {Path(p).resolve() for p in sys.path if p and os.path.isdir(p)}
    return sorted(found)


def command(python_args: list[str], uid: int, gid: int) -> list[str]:
    """The command line that runs `python_args` (this interpreter's arguments) as `uid`:`gid`,
    every privilege left behind (setpriv) before the interpreter starts."""
    privileges = ["--clear-groups", "--inh-caps=-all", "--bounding-set=-all", "--no-new-privs"]
    run_as = ["setpriv", f"--reuid={uid}", f"--regid={gid}", *privileges, sys.executable, *python_args]
    reason = kernel.unavailable()
    if reason is not None:
        for folder in _needed():
            closed = _closed(folder)
            if closed is not None:
                raise SandboxError(
                    f"the Dask courier runs as nobody, who cannot pass {closed} to reach {folder} ({reason}): "
                    "install LaserArena where other users can read it, or install bubblewrap"
                )
        return run_as
    args = ["bwrap", "--die-with-parent", "--unshare-pid", "--unshare-ipc", "--unshare-uts", "--ro-bind", "/", "/"]
    args += ["--dev", "/dev", "--proc", "/proc", "--perms", "1777", "--tmpfs", "/tmp"]
    covered: list[Path] = [Path("/tmp")]
    binds: list[Path] = []
    for folder in _needed():
        closed = Path("/tmp") if folder.is_relative_to("/tmp") else _closed(folder)
        if closed is None:
            continue
        if not any(closed.is_relative_to(c) for c in covered):
            args += ["--perms", "0755", "--tmpfs", str(closed)]
            covered.append(closed)
        binds.append(folder)
    for folder in binds:
        if not any(folder.is_relative_to(b) and folder != b for b in binds):  # a folder inside another comes with it
            top = next(c for c in covered if folder.is_relative_to(c))
            for parent in reversed(folder.parents):
                if parent.is_relative_to(top) and parent != top:
                    args += ["--perms", "0755", "--dir", str(parent)]
            args += ["--ro-bind", str(folder), str(folder)]
    args += ["--remount-ro", "/", "--chdir", "/"]
    return [*args, "--", *run_as]
