"""The `laserarena` process's first and last code.

First: a Ctrl-C (or SIGTERM) that comes before the command's own handler is in place
(`referee.cli.main` and what it imports: some 20 ms) ends the process as an interrupt, not
with a traceback. Nothing has started yet that would need closing.

Last: once the command has returned its exit code and Python's way out has done its part
(the command's threads joined, every other exit handler run), the process ends with that
code, its output flushed, without tearing its modules down object by object (docs/decisions/0044).
"""

from __future__ import annotations

import _signal  # type: ignore[import-not-found]  # the C module: `signal` would first import enum
import atexit
import os
import sys

from referee.errors import EXIT_INTERRUPTED, EXIT_PIPE

_code: int | None = None  # the command's exit code, once it has returned one


def _early(signum: int, frame: object) -> None:
    os.write(2, b"laserarena: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


def _leave() -> None:
    """The last exit handler (registered first): end with the command's code once stdout and
    stderr are flushed, skipping the interpreter's teardown of every module: some 40 ms after a
    match (numba's and NumPy's objects freed one by one), and no file or child of the command
    waits on it. Where the command raised instead of returning, Python's own way out, traceback
    and all."""
    if _code is None:
        return
    code = _code
    try:
        sys.stdout.flush()
    except BrokenPipeError:  # the reader went before the last of the output: as during the command
        code = EXIT_PIPE
    except (OSError, ValueError):  # stdout closed or failing: nothing more can be said there
        pass
    try:
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os._exit(code)


def run() -> None:
    """The console script: the early handler, then the command (`referee.cli.main.main`), whose
    own handler replaces it; the process ends with the command's code (`_leave`)."""
    global _code
    _signal.signal(_signal.SIGINT, _early)
    _signal.signal(_signal.SIGTERM, _early)
    atexit.register(_leave)
    from referee.cli.main import main

    _code = main()
    sys.exit(_code)
