"""A child process's end, seen as it comes: by its pidfd, which wakes a wait the moment the
child ends, where polls at growing steps could sleep past it by milliseconds."""

from __future__ import annotations

import os
import select
import subprocess
import time

__all__ = ["ended"]


def ended(proc: subprocess.Popen, timeout: float) -> bool:
    """Whether `proc`, a child of this process, has ended or ends within `timeout` seconds. It
    is left unreaped: until its parent reaps it, its pid names it alone. Where the system has
    no pidfd, polled at growing steps instead (os.waitid, WNOWAIT)."""
    if proc.returncode is not None:
        return True
    try:
        pidfd = os.pidfd_open(proc.pid)
    except AttributeError:  # no pidfd on this system
        return _polled(proc, timeout)
    except OSError:  # reaped meanwhile (by a poll), or a kernel without pidfd_open
        return proc.poll() is not None or _polled(proc, timeout)
    try:
        return bool(select.select([pidfd], [], [], timeout)[0])
    finally:
        os.close(pidfd)


def _polled(proc: subprocess.Popen, timeout: float) -> bool:
    """`ended`, by polls at growing steps (at most 50 ms apart)."""
    deadline, delay = time.monotonic() + timeout, 0.0005
    while True:
        try:
            if os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None:
                return True
        except ChildProcessError:  # reaped already
            return True
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        delay = min(delay * 2, left, 0.05)
        time.sleep(delay)
