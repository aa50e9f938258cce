"""The `laserarena` process's first code: a Ctrl-C (or SIGTERM) that comes before the command's
own handler is in place (`referee.cli.main` and what it imports: some 20 ms) ends the process
as an interrupt, not with a traceback. Nothing has started yet that would need closing."""

from __future__ import annotations

import _signal  # type: ignore[import-not-found]  # the C module: `signal` would first import enum
import os
import sys

from referee.errors import EXIT_INTERRUPTED


def _early(signum: int, frame: object) -> None:
    os.write(2, b"laserarena: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


def run() -> None:
    """The console script: the early handler, then the command (`referee.cli.main.main`), whose
    own handler replaces it."""
    _signal.signal(_signal.SIGINT, _early)
    _signal.signal(_signal.SIGTERM, _early)
    from referee.cli.main import main

    sys.exit(main())
