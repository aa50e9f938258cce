"""A team's traceback, from its own first frame: the host's frames that called into the team's
code are left out by the module each frame runs in, never by matching file paths."""

from __future__ import annotations

import traceback
from types import TracebackType

HOST = ("robots._host.", "importlib.", "referee.")  # the modules that call a team's code


def team_traceback(e: BaseException) -> str:
    """The traceback of `e` as Python prints it, its leading frames in `HOST` modules left out
    (all of them, where the error is the host's own)."""
    tb = e.__traceback__
    while tb is not None and tb.tb_next is not None and _hosts(tb):
        tb = tb.tb_next
    return "".join(traceback.format_exception(type(e), e, tb))


def _hosts(tb: TracebackType) -> bool:
    name = tb.tb_frame.f_globals.get("__name__", "")
    return isinstance(name, str) and (name + ".").startswith(HOST)
