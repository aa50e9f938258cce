"""The one base of every error LaserArena reports to a person: a one-line message, no traceback."""

from __future__ import annotations


class LaserArenaError(Exception):
    """Bad input or a failed promise (a level, a team, a replay, a journal, an argument).

    Its text is one line naming what and where; the command line prints it and exits with
    `exit_code`. Subclasses say which kind of input was at fault."""

    exit_code = 2
