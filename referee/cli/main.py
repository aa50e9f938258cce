"""The `laserarena` entry point: runs a command (referee.cli.commands, its arguments parsed by
referee.cli.arguments) and turns every way it can end into one line and an exit code (docs/cli.md). It imports almost nothing itself, so
that a Ctrl-C that comes while the commands' modules are still loading ends quietly too.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from typing import TextIO

from levels.errors import LaserArenaError
from referee.errors import EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_PIPE, LaserArenaWarning, UserError
from referee.interrupts import Catcher, Interrupted, ignore
from referee.terminal import safe
from referee.threads import one_blas_thread

# Ctrl-C or SIGTERM unwinds the command, closing every controller sandbox and worker on the way out
INTERRUPT = Catcher(KeyboardInterrupt, (signal.SIGINT, signal.SIGTERM))
handle_interrupts = INTERRUPT.install


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
            from referee.cli.arguments import parser

            args = parser().parse_args(argv)
            return args.func(args)
        except Exception:
            if INTERRUPT.raised:  # the interrupt, turned into another error by the C code it landed in
                raise KeyboardInterrupt from None
            raise
    except LaserArenaError as e:
        print(f"laserarena: {safe(e, 1000)}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt as stop:
        ignore()
        kept = f"; {safe(stop, 500)}" if isinstance(stop, Interrupted) else ""  # what the journal kept
        print(f"laserarena: interrupted{kept}", file=sys.stderr)
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
        ignore()
