"""The narrow call site between the match and a team's controller.

`InProcessBot` runs the controller inside the referee's process (`--in-process`, for a
debugger: the team's code runs with the referee's rights, never for grading); `ProcessBot`
(referee/process.py) puts the same interface around a sandboxed process. Any exception or malformed command becomes
a typed `Fault`, and the bot stops answering: the match goes on without it.
"""

from __future__ import annotations

from dataclasses import dataclass

from referee.records.results import FaultRecord
from referee.sandbox.teams import Team
from robots.api import API_VERSION, Brief, Command, Controller, Observation
from robots.loading import LoadError, is_file_spec, load_class
from robots.protocol import ProtocolError, api_problem, command_from, command_problem, to_plain


@dataclass(frozen=True)
class Fault:
    """A controller fault: when it happened, its type and a one-line message. A fatal fault
    stops the robot; a skipped tick (`fatal=False`) keeps its last command in force."""

    tick: int
    time: float
    kind: str  # load | exception | bad_command | memory | crash | timeout | output_flood | protocol | skipped_tick
    message: str
    fatal: bool = True

    def to_record(self) -> FaultRecord:
        """The fault as it appears in the result and the replay."""
        return FaultRecord(tick=self.tick, time=self.time, kind=self.kind, message=self.message)


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
            cls = self.team.factory or load_class(self.team.spec if is_file_spec(self.team.spec) else self.team.entry)
        except LoadError as e:
            return Fault(0, 0.0, "load", str(e))
        problem = api_problem(getattr(cls, "api_version", API_VERSION))
        if problem:
            return Fault(0, 0.0, "load", problem)
        try:
            self.controller = controller = cls()
            controller.setup(brief)
        except Exception as e:  # a team's bug must not stop the match
            return Fault(0, 0.0, "exception", f"in setup: {one_line(e)}")
        return None

    def step(self, obs: Observation) -> Command | Fault:
        if self.controller is None:
            return Fault(obs.tick, obs.time, "protocol", "a step before the controller's setup")
        try:
            cmd = self.controller.step(obs)
        except Exception as e:
            return Fault(obs.tick, obs.time, "exception", f"in step: {one_line(e)}")
        problem = command_problem(cmd)
        if problem:
            return Fault(obs.tick, obs.time, "bad_command", problem)
        try:  # the very checks and conversions of the wire (numpy scalars become floats, caps apply)
            return command_from(to_plain(cmd))
        except ProtocolError as e:
            return Fault(obs.tick, obs.time, "bad_command", str(e))

    def close(self) -> None:
        """Nothing to end: the controller lived in this process."""
