"""Where an exception that a signal handler raises would not reach the code it interrupts, so
that the handler (the command's Ctrl-C, a grading worker's stop) takes the signal again a
moment later instead of raising it there."""

from __future__ import annotations

import _thread
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

RETRY = 0.02  # seconds before a signal that came at a fragile moment is taken again
# packages whose code, when an exception is raised inside it, loses it or turns it into another
FRAGILE = ("numba", "llvmlite", "pymunk")
LOSES_EXCEPTIONS = ("__del__", "__set_name__")  # functions whose raised exception Python drops or wraps
_steady = 0  # `steady()` sections under way


@contextmanager
def steady() -> Iterator[None]:
    """A section that a signal's exception must not cut short: a process started there and not
    yet recorded where the clean-up finds it would be left running (a sandbox half made by
    bwrap outlives its parent). A signal that comes meanwhile is taken once it has ended."""
    global _steady
    _steady += 1
    try:
        yield
    finally:
        _steady -= 1


def fragile(frame: FrameType | None) -> bool:
    """Whether `frame` runs where a raised exception must wait: in a `steady()` section, or
    where it would not reach the code it interrupts: in
    a finalizer (`__del__`: Python drops what it raises; numba's LLVM objects run them while
    compiled code loads), in a class body's `__set_name__` (Python turns it into a
    RuntimeError: numpy's `finfo` while numpy loads), in numba's or llvmlite's machinery (their
    C code turns it into a SystemError, or drops it in a ctypes callback), or in a pymunk
    callback from chipmunk (cffi prints it and goes on)."""
    if _steady:
        return True
    files = [getattr(sys.modules.get(name), "__file__", None) for name in FRAGILE]
    folders = tuple(os.path.dirname(file) + os.sep for file in files if file)
    while frame is not None:
        code = frame.f_code
        if code.co_name in LOSES_EXCEPTIONS or code.co_filename.startswith(folders):
            return True
        frame = frame.f_back
    return False


def take_again(signum: int) -> None:
    """Have signal `signum` taken again in the main thread `RETRY` seconds from now (its
    handler runs then as if it had just come)."""
    threading.Timer(RETRY, _thread.interrupt_main, (signum,)).start()
