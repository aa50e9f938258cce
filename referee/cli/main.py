"""The `laserarena` entry point: runs a command (referee.cli.commands, its arguments parsed by
referee.cli.arguments) and turns every way it can end into one line and an exit code (docs/cli.md). It imports almost nothing itself, so
that a Ctrl-C that comes while the commands' modules are still loading ends quietly too.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from types import FrameType
from typing import TextIO

from arena.heap import lasting
from levels.errors import LaserArenaError
from referee.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_PIPE, LaserArenaWarning, UserError
from referee.fragile import fragile, take_again
from referee.terminal import safe
from referee.threads import one_blas_thread

_raised = False  # this command's interrupt is on its way out (`_interrupt`)
_shown_before = sys.unraisablehook  # what shows a dropped exception that is not our interrupt


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """Ctrl-C (SIGINT) or SIGTERM: unwind the command, closing every controller sandbox and
    worker on the way out. Once raised, further signals are ignored, so that a second Ctrl-C
    does not cut that clean-up short (SIGKILL still ends the process).

    Raised at a fragile moment (`referee.fragile`), the interrupt would be lost or mangled and, with
    further signals ignored, the command left unstoppable: there it is taken again a moment later.
    Raised where Python drops it all the same (a weakref callback: importlib's module locks
    have them), it is raised again a moment later (`_unraisable`). Raised where C code turns it into
    another exception, that one is taken as the interrupt (`main`): an extension module's import
    does so, as NumPy's does when the interrupt lands in the `datetime` import of its
    `PyCapsule_Import`."""
    global _raised
    if _raised:
        return
    if fragile(frame):
        take_again(signum)
        return
    _raised = True
    raise KeyboardInterrupt


def _unraisable(hook: sys.UnraisableHookArgs) -> None:
    """An exception Python drops (raised in a finalizer or a weakref callback): our interrupt,
    lost there, is raised again a moment later, once the main thread has left that code (and
    again, should it land in such code once more); any other goes to the hook that was in
    place (Python's own, or a test runner's)."""
    global _raised
    if _raised and hook.exc_type is KeyboardInterrupt:
        _raised = False
        take_again(signal.SIGINT)
        return
    _shown_before(hook)


def handle_interrupts() -> None:
    """Make Ctrl-C and SIGTERM this command's interrupt (`_interrupt`), from now on."""
    global _raised, _shown_before
    _raised = False
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    if sys.unraisablehook is not _unraisable:
        _shown_before, sys.unraisablehook = sys.unraisablehook, _unraisable


_python_show_warning = warnings.showwarning


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Our warnings as one line, `laserarena: warning: ...`; any other as Python shows it."""
    if issubclass(category, LaserArenaWarning):
        print(f"laserarena: warning: {safe(message, 500)}", file=sys.stderr)
    else:
        _python_show_warning(message, category, filename, lineno, file, line)


def main(argv: list[str] | None = None) -> int:
    """Run `laserarena ARGV` and return its exit code."""
    if "PYGAME_HIDE_SUPPORT_PROMPT" not in os.environ:  # no pygame banner in our output
        os.environ["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
    one_blas_thread()  # before NumPy loads; a team's code run --in-process gets its sandbox's one
    handle_interrupts()
    warnings.showwarning = _show_warning
    try:
        try:
            with lasting():  # the commands' modules (numpy, the levels' loader, ...) live as long as the process
                from referee.cli.arguments import parser

            args = parser().parse_args(argv)
            return int(args.func(args))
        except Exception:
            if _raised:  # the interrupt, turned into this by the C code it landed in (`_interrupt`)
                raise KeyboardInterrupt from None
            raise
    except LaserArenaError as e:
        print(f"laserarena: {safe(e, 1000)}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the way out is quiet, whatever comes now
        print("laserarena: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # the reader went away (`laserarena levels | head -1`): stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # no second error when Python flushes stdout at exit
        return EXIT_PIPE
    except OSError as e:  # a file the command was given or writes: named, in one line
        if e.filename is None:
            raise
        print(f"laserarena: {safe(UserError.of(e), 1000)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        # the interpreter's own shutdown (joining worker pools' threads) follows: a Ctrl-C there
        # would print a traceback after the command's last line
        signal.signal(signal.SIGINT, signal.SIG_IGN)
