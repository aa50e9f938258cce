"""A controller's fault as the sandbox finds it (`fault`: the result's own `Fault` record, its
message made terminal-safe once, here, whatever sent it: a team's own exception text, a
protocol error naming a team's field), and the tail of a team's traceback that goes with it."""

from __future__ import annotations

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


def traceback_tail(log: str) -> str | None:
    """The last traceback in a team's log (printed from the team's own first frame, by
    robots._host.tracebacks), cut to its last TRACEBACK_LINES lines, or None."""
    start = log.rfind("Traceback (most recent call last):")
    if start < 0:
        return None
    lines = log[start:].rstrip().splitlines()
    body = lines[1:][-(TRACEBACK_LINES - 1) :]
    while body and not body[0].startswith("  File ") and any(b.startswith("  File ") for b in body):
        body = body[1:]  # from a frame's first line, not the middle of one
    return "\n".join(lines[:1] + body)
