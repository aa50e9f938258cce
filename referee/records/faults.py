"""A controller's faults told in a line, for the score table, the leaderboard and the standings:
each fault's kind, message and where in the team's own code it happened (`site`: FILE:LINE of
the last frame in the team's files, read from the traceback tail the result keeps). The
referee writes a team's own files into that tail by their paths inside the team (the folder
they were put in left out), where Python's, a library's and `robots`' files stay absolute, so
the last relative frame is the team's. Texts are left raw: each output escapes them its way.
"""

from __future__ import annotations

import ntpath
import posixpath
import re
from collections.abc import Iterable, Mapping
from typing import Any

FRAME = re.compile(r'^ *File "([^"\n]+)", line (\d+)', re.MULTILINE)
TEAM_PREFIX = re.compile(r"^team .*?: ")  # a load fault's message names the team its row names already
MESSAGE = 80  # characters of a fault's message in a table cell


def own_file(path: str) -> bool:
    """Whether a traceback's file is one of the team's own (named relative), not Python's,
    a library's or `robots`' (absolute, or `<frozen ...>`)."""
    return not (path.startswith("<") or posixpath.isabs(path) or ntpath.isabs(path))


def site(traceback: str | None) -> tuple[str, int] | None:
    """The file and line of the last frame of a traceback tail that lies in the team's own
    files, or None."""
    found = [(path, int(line)) for path, line in FRAME.findall(traceback or "") if own_file(path)]
    return found[-1] if found else None


def located(fault: Mapping[str, Any], message: str | None = None) -> str:
    """A fault's message (or `message`, a part of it) with the team's file and line where it
    happened: "in step: KeyError: 'pose' (bot.py:12)"; a message that names them already (a
    SyntaxError's "(bot.py, line 12)") is left as it is."""
    text = fault["message"] if message is None else message
    where = site(fault.get("traceback"))
    if where is None or f"{where[0]}, line {where[1]}" in text:
        return text
    return f"{text} ({where[0]}:{where[1]})"


def told(fault: Mapping[str, Any], width: int = MESSAGE) -> str:
    """One fault for a table: its message without the team's name (the row has it), cut to
    `width` characters, `located`."""
    message = TEAM_PREFIX.sub("", fault["message"], count=1)
    return located(fault, message if len(message) <= width else message[: width - 3] + "...")


def summary(faults: Iterable[Mapping[str, Any]], width: int = MESSAGE) -> str:
    """Faults by kind, in order of first appearance: how many, the kind, and the first one
    `told` ("2 exception: in step: KeyError: 'pose' (bot.py:12); 1 timeout: ..."); "" for none."""
    kinds: dict[str, tuple[int, Mapping[str, Any]]] = {}
    for f in faults:
        count, first = kinds.get(f["kind"], (0, f))
        kinds[f["kind"]] = (count + 1, first)
    return "; ".join(f"{count} {kind}: {told(first, width)}" for kind, (count, first) in kinds.items())
