"""The narrow call site between the match and a team's controller.

`InProcessBot` runs the controller inside the referee's process (`--in-process`, for a
debugger: the team's code runs with the referee's rights, never for grading); `ProcessBot`
(referee/process.py) puts the same interface around a sandboxed process. Any exception or malformed command becomes
a typed `Fault`, and the bot stops answering: the match goes on without it.
"""

from __future__ import annotations

import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

from referee.records.results import FaultRecord
from referee.sandbox.teams import Team
from robots.api import API_VERSION, Brief, Command, Controller, Observation
from robots.loading import LoadError, is_file_spec, load_class
from robots.protocol import FaultKind, ProtocolError, api_problem, command_problem, sendable, wired


@dataclass(frozen=True)
class Fault:
    """A controller fault: when it happened, its type and a one-line message. A fatal fault
    stops the robot; a skipped tick (`fatal=False`) keeps its last command in force."""

    tick: int
    time: float
    kind: FaultKind
    message: str
    fatal: bool = True
    traceback: str | None = None  # the tail of the team's traceback, from its log, when there is one

    def to_record(self) -> FaultRecord:
        """The fault as it appears in the result and the replay."""
        if self.traceback is None:
            return FaultRecord(tick=self.tick, time=self.time, kind=self.kind.value, message=self.message)
        return FaultRecord(
            tick=self.tick, time=self.time, kind=self.kind.value, message=self.message, traceback=self.traceback
        )


TRACEBACK_LINES, TRACEBACK_BYTES = 12, 8192


def traceback_tail(log: str) -> str | None:
    """The last traceback in a team's log, cut to its last TRACEBACK_LINES lines, or None."""
    start = log.rfind("Traceback (most recent call last):")
    if start < 0:
        return None
    lines = log[start:].rstrip().splitlines()
    ours = [
        i
        for i, line in enumerate(lines)
        if line.startswith("  File ")
        and any(f'{p}"' in line.replace("\\", "/") for p in ("robots/runner.py", "referee/sandbox/bot.py"))
    ]
    body = lines[ours[-1] + 1 :] if ours else lines[1:]  # the team's frames: not the call site's
    while body and not body[0].startswith("  File ") and any(b.startswith("  File ") for b in body):
        body = body[1:]
    return "\n".join(lines[:1] + body[-(TRACEBACK_LINES - 1) :])


def one_line(e: BaseException) -> str:
    """An exception as `Type: message` on one line."""
    text = " ".join(str(e).split())
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


class InProcessBot:
    """A controller running in the referee's own process (`--in-process`, for a debugger)."""

    def __init__(self, team: Team):
        self.team = team
        self.controller: Controller | None = None

    def launch(self) -> None:
        """Nothing to start: the controller lives in this process."""

    def setup(self, brief: Brief) -> Fault | None:
        try:  # the one place a team's code is imported into the referee
            folder = Path(self.team.spec.rpartition(":")[0])
            if self.team.files and not is_file_spec(self.team.entry) and folder.is_absolute():
                home = str(folder.parent)  # a package team: import it from its folder (not the bytes shipped)
                if home not in sys.path:
                    sys.path.insert(0, home)
            cls = self.team.factory or load_class(self.team.spec if is_file_spec(self.team.spec) else self.team.entry)
        except LoadError as e:
            return Fault(0, 0.0, FaultKind.LOAD, str(e))
        problem = api_problem(getattr(cls, "api_version", API_VERSION))
        if problem:
            return Fault(0, 0.0, FaultKind.LOAD, problem)
        try:
            self.controller = controller = cls()
            controller.setup(brief)
        except Exception as e:  # a team's bug must not stop the match
            return Fault(
                0,
                0.0,
                FaultKind.EXCEPTION,
                f"in setup: {one_line(e)}",
                traceback=traceback_tail(traceback.format_exc()),
            )
        return None

    def step(self, obs: Observation) -> Command | Fault:
        if self.controller is None:
            return Fault(obs.tick, obs.time, FaultKind.PROTOCOL, "a step before the controller's setup")
        try:
            cmd = self.controller.step(obs)
        except Exception as e:
            return Fault(
                obs.tick,
                obs.time,
                FaultKind.EXCEPTION,
                f"in step: {one_line(e)}",
                traceback=traceback_tail(traceback.format_exc()),
            )
        sent = sendable(cmd)  # drawings that cannot be drawn become warnings, as over the wire
        problem = command_problem(sent)
        if problem:
            return Fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, problem)
        try:  # the very checks and conversions of the wire (numpy scalars become floats, caps apply)
            return wired(sent)  # type: ignore[arg-type]  # a Command: command_problem said so
        except ProtocolError as e:
            return Fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, str(e))

    def ask_to_end(self) -> None:
        """Nothing to tell: the match's end reaches a controller in this process by `close`."""

    def close(self) -> None:
        """Nothing to end: the controller lived in this process."""
