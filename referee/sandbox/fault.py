"""A controller's fault, as the sandbox reports it to the match (which records it), and the
tail of a team's traceback that goes with it."""

from __future__ import annotations

from dataclasses import dataclass

from robots._host.protocol import FaultKind


@dataclass(frozen=True)
class Fault:
    """A controller fault: when it happened, its kind and a one-line message. A fatal fault
    stops the robot; a skipped tick (`fatal=False`) keeps its last command in force."""

    tick: int
    time: float
    kind: FaultKind
    message: str
    fatal: bool = True
    traceback: str | None = None  # the tail of the team's traceback, from its log, when there is one


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
