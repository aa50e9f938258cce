"""How a LaserArena process stops: one line, exit 130, nothing left running, no finished
result lost (docs/cli.md). Imports almost nothing: the console script loads it first.

- `first()`: a Ctrl-C before the command's own handler is in place ends the process at once.
- `Catcher`: signals raised as one exception in the main thread, once (a second is ignored,
  so the clean-up runs whole). Where that exception would be lost or mangled (`fragile`),
  or Python drops it (a finalizer, a weakref callback), the signal is taken again shortly.
- `steady()`: a section no signal cuts short (a process started, not yet recorded for the
  clean-up).
- `finish(code)`: the process ends with the command's code, its output flushed, without
  tearing its modules down (docs/decisions/0044).
- `Interrupted`: the interrupt, saying what a contest's journal kept.
"""

from __future__ import annotations

import _signal  # type: ignore[import-not-found]  # the C module: `signal` would first import enum
import _thread
import atexit
import os
import sys
from types import FrameType

from referee.errors import EXIT_INTERRUPTED, EXIT_PIPE

__all__ = ["Catcher", "Interrupted", "finish", "first", "fragile", "ignore", "steady", "take_again"]

RETRY = 0.02  # seconds before a signal that came at a fragile moment is taken again
# packages whose code, when an exception is raised inside it, loses it or turns it into another
FRAGILE = ("numba", "llvmlite", "pymunk")
LOSES_EXCEPTIONS = ("__del__", "__set_name__")  # functions whose raised exception Python drops or wraps
_steady = 0  # `steady()` sections under way
_code: int | None = None  # the command's exit code, once it has returned one


class Interrupted(KeyboardInterrupt):
    """A Ctrl-C (or SIGTERM) that ended a grade or tournament; its message says what the
    journal kept, and the command line prints it after `laserarena: interrupted; `."""


def _early(signum: int, frame: object) -> None:
    os.write(2, b"laserarena: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


def first() -> None:
    """The console script's first code: Ctrl-C and SIGTERM end the process with one line until
    the command's own `Catcher` replaces this; and `finish`'s exit, registered first, runs last."""
    _signal.signal(_signal.SIGINT, _early)
    _signal.signal(_signal.SIGTERM, _early)
    atexit.register(_leave)


def finish(code: int) -> None:
    """End with the command's `code`: Python's way out runs (threads joined, exit handlers run),
    then `_leave` ends the process before the modules' teardown."""
    global _code
    _code = code
    sys.exit(code)


def _leave() -> None:
    """The last exit handler: flush stdout and stderr and end with the command's code, skipping
    the interpreter's teardown of every module (numba's and NumPy's objects freed one by one).
    Where the command raised instead of returning, Python's own way out, traceback and all."""
    if _code is None:
        return
    code = _code
    try:
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went before the last of the output
        code = EXIT_PIPE
    except (OSError, ValueError):  # stdout closed or failing: nothing more can be said there
        pass
    try:
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os._exit(code)


def ignore() -> None:
    """Ignore Ctrl-C from now on: the way out is quiet, whatever comes."""
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)


class steady:  # (named as the function it stands for: `with steady():`)
    """A section that a signal's exception must not cut short: a process started there and not
    yet recorded where the clean-up finds it would be left running (a half-made bwrap sandbox
    outlives its parent). A signal that comes meanwhile is taken once it has ended."""

    def __enter__(self) -> None:
        global _steady
        _steady += 1

    def __exit__(self, *exc: object) -> None:
        global _steady
        _steady -= 1


def fragile(frame: FrameType | None) -> bool:
    """Whether `frame` runs where a raised exception must wait: in a `steady()` section; in a
    finalizer or a class body's `__set_name__` (Python drops or wraps what they raise); in
    numba's or llvmlite's machinery (their C code turns it into a SystemError, or drops it in a
    ctypes callback); or in a pymunk callback from chipmunk (cffi prints it and goes on)."""
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
    """Have signal `signum` taken again in the main thread `RETRY` seconds from now."""
    import threading

    threading.Timer(RETRY, _thread.interrupt_main, (signum,)).start()


class Catcher:
    """`signals` raised as `exception` in the main thread, once `install`ed: the first time only
    (`raised`), so a second signal does not cut the clean-up short; `before` runs first (a
    grading worker leaves there if it is not in a match)."""

    def __init__(self, exception: type[BaseException], signals: tuple[int, ...], before=None):
        self.exception, self.signals, self.before = exception, signals, before
        self.raised = False
        self._shown_before = sys.unraisablehook  # what shows a dropped exception that is not ours

    def install(self) -> None:
        """From now on, these signals raise the exception."""
        self.raised = False
        for signum in self.signals:
            _signal.signal(signum, self._caught)
        if sys.unraisablehook != self._dropped:
            self._shown_before, sys.unraisablehook = sys.unraisablehook, self._dropped

    def _caught(self, signum: int, frame: FrameType | None) -> None:
        if self.raised:
            return
        if fragile(frame):
            take_again(signum)
            return
        if self.before is not None:
            self.before()
        self.raised = True
        raise self.exception

    def _dropped(self, hook: sys.UnraisableHookArgs) -> None:
        """An exception Python dropped (raised in a finalizer or a weakref callback): ours is
        taken again a moment later, once the main thread has left that code; any other goes to
        the hook that was in place (Python's own, or a test runner's)."""
        if self.raised and hook.exc_type is self.exception:
            self.raised = False
            take_again(self.signals[0])
            return
        self._shown_before(hook)
