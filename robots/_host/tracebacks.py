"""A team's traceback, from its own first frame: the frames of the host's code that called into
the team's (the handler that caught the error and the helpers it called through) are left out
by the module each frame runs in, never by matching file paths."""

from __future__ import annotations

import traceback
from types import TracebackType
from typing import Any


def team_traceback(e: BaseException, *hosts: dict[str, Any]) -> str:
    """The traceback of `e` as Python prints it, from the first frame that runs neither in one
    of the modules whose globals are `hosts` (the caller's own `globals()` among them: right
    even for a module run as `__main__`) nor in importlib's machinery. Where every frame is the
    host's, the whole of it."""
    tb = e.__traceback__
    while tb is not None and tb.tb_next is not None and _hosts(tb, hosts):
        tb = tb.tb_next
    return "".join(traceback.format_exception(type(e), e, tb))


def _hosts(tb: TracebackType, hosts: tuple[dict[str, Any], ...]) -> bool:
    module = tb.tb_frame.f_globals
    name = module.get("__name__", "")
    return any(module is h for h in hosts) or (isinstance(name, str) and name.startswith("importlib"))
