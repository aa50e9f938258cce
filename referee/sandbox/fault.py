"""A controller's fault as the sandbox finds it (`fault`: the result's own `Fault` record, its
message made terminal-safe once, here, whatever sent it: a team's own exception text, a
protocol error naming a team's field), and the tail of a team's traceback that goes with it."""

from __future__ import annotations

from referee.records.faults import FRAME, own_file
from referee.records.results import Fault
from referee.terminal import safe
from robots._host.protocol import FaultKind

MESSAGE = 500  # characters of a fault's message kept


def fault(tick: int, time: float, kind: FaultKind, message: str, traceback: str | None = None) -> Fault:
    """The fault of kind `kind` at control tick `tick` (`time` s): fatal unless a skipped tick."""
    text = safe(message, MESSAGE)
    if traceback is None:
        return Fault(tick=tick, time=time, kind=kind.value, message=text)
    return Fault(tick=tick, time=time, kind=kind.value, message=text, traceback=traceback)


TRACEBACK_LINES, TRACEBACK_BYTES = 12, 8192


def _frames(body: list[str]) -> list[str]:
    """`body` from a frame's first line, not the middle of one (unless it holds no frame)."""
    while body and not body[0].startswith("  File ") and any(b.startswith("  File ") for b in body):
        body = body[1:]
    return body


def _own(line: str) -> bool:
    """Whether a traceback line is the first line of a frame in the team's own files."""
    found = FRAME.match(line)
    return found is not None and own_file(found.group(1))


def traceback_tail(log: str) -> str | None:
    """The last traceback in a team's log (printed from the team's own first frame, by
    robots._host.tracebacks, the team's files named relative), cut to its last
    TRACEBACK_LINES lines, or None. Where those hold none of the team's frames (an error deep
    in a library), its last frame comes first, then `...` and the last lines that fit: the
    tail always shows where the team's code was."""
    start = log.rfind("Traceback (most recent call last):")
    if start < 0:
        return None
    lines = log[start:].rstrip().splitlines()
    body = lines[1:]
    tail = _frames(body[-(TRACEBACK_LINES - 1) :])
    own = [i for i, line in enumerate(body) if _own(line)]
    if own and not any(_own(line) for line in tail):
        end = next((j for j in range(own[-1] + 1, len(body)) if body[j].startswith("  File ")), len(body))
        frame = body[own[-1] : end][:4]  # its file line, its code and the markers under it
        tail = frame + ["  ..."] + _frames(body[-(TRACEBACK_LINES - 2 - len(frame)) :])
    return "\n".join(lines[:1] + tail)
