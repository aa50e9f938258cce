"""A controller in the referee's own process (`--in-process`, for a debugger: the team's code
runs with the referee's rights, never for grading), with the `Bot` interface. Its commands
take the very checks and conversions of the wire."""

from __future__ import annotations

import sys
from pathlib import Path

from referee.records.results import Fault
from referee.sandbox.fault import fault, traceback_tail
from referee.sandbox.teams import Team
from robots._host.loading import LoadError, is_file_spec, load_class
from robots._host.protocol import FaultKind, ProtocolError, api_problem, command_problem, describe, sendable, wired
from robots._host.tracebacks import team_traceback
from robots.api import API_VERSION, Brief, Command, Controller, Observation


class InProcessBot:
    """A controller running in the referee's own process (`--in-process`, for a debugger)."""

    def __init__(self, team: Team):
        self.team = team
        self.controller: Controller | None = None
        self.isolated = False

    def pin(self, cpus: list[int]) -> None:
        """Nothing to pin: the controller runs on the referee's own thread."""

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
            return fault(0, 0.0, FaultKind.LOAD, str(e))
        problem = api_problem(getattr(cls, "api_version", API_VERSION))
        if problem:
            return fault(0, 0.0, FaultKind.LOAD, problem)
        try:
            self.controller = controller = cls()
            controller.setup(brief)
        except Exception as e:  # a team's bug must not stop the match
            tail = traceback_tail(team_traceback(e, globals()))
            return fault(0, 0.0, FaultKind.EXCEPTION, f"in setup: {describe(e)}", traceback=tail)
        return None

    def step(self, obs: Observation) -> Command | Fault:
        if self.controller is None:
            return fault(obs.tick, obs.time, FaultKind.PROTOCOL, "a step before the controller's setup")
        try:
            cmd = self.controller.step(obs)
        except Exception as e:
            tail = traceback_tail(team_traceback(e, globals()))
            return fault(obs.tick, obs.time, FaultKind.EXCEPTION, f"in step: {describe(e)}", traceback=tail)
        sent = sendable(cmd)  # drawings that cannot be drawn become warnings, as over the wire
        problem = command_problem(sent)
        if problem:
            return fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, problem)
        try:  # the very checks and conversions of the wire (numpy scalars become floats, caps apply)
            return wired(sent)  # type: ignore[arg-type]  # a Command: command_problem said so
        except ProtocolError as e:
            return fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, str(e))

    def send(self, obs: Observation) -> Command | Fault:
        """In this process the answer comes at once: a step."""
        return self.step(obs)

    def ask_to_end(self) -> None:
        """Nothing to tell: the match's end reaches a controller in this process by `close`."""

    def close(self) -> None:
        """Nothing to end: the controller lived in this process."""
