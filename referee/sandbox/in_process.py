"""A controller in the referee's own process (`--in-process`, for a debugger: the team's code
runs with the referee's rights, never for grading), with the `Bot` interface. Its commands
take the very checks and conversions of the wire. The team's output goes to the referee's,
and so does each fault's whole traceback: this terminal is the team's log."""

from __future__ import annotations

import os
import sys
import traceback
from pathlib import Path

from referee.records.results import Fault
from referee.sandbox.fault import fault, traceback_tail
from referee.sandbox.teams import Team
from robots._host import loading
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

    def prepare(self) -> None:
        """Nothing to make: the controller lives in this process."""

    def launch(self) -> None:
        """Nothing to start: the controller lives in this process."""

    def setup(self, brief: Brief) -> Fault | None:
        try:  # the one place a team's code is imported into the referee
            cls = self.team.factory or load_class(self._spec())
        except LoadError as e:  # named as the team was given, not by where its file is
            message = str(e).replace(f"team {self._spec()}:", f"team {self.team.label}:", 1)
            if e.__cause__ is not None:  # the team's code raised as it loaded
                return self._fault(0, 0.0, FaultKind.LOAD, message, e.__cause__)
            return fault(0, 0.0, FaultKind.LOAD, message)
        problem = api_problem(getattr(cls, "api_version", API_VERSION))
        if problem:
            return fault(0, 0.0, FaultKind.LOAD, problem)
        try:
            self.controller = controller = cls()
            controller.setup(brief)
        except Exception as e:  # a team's bug must not stop the match
            return self._fault(0, 0.0, FaultKind.EXCEPTION, f"in setup: {describe(e)}", e)
        return None

    def _spec(self) -> str:
        """The spec that loads the team's class from where its files are on this machine
        (`Team.home`): a file by its path, a folder team's modules and a package from their
        folder, which goes on the import path."""
        home, entry = self.team.home, self.team.entry
        if not home or not self.team.files:  # a module of the installed product (ref:NAME)
            return entry
        if (not is_file_spec(entry) or len(self.team.files) > 1) and home not in sys.path:
            sys.path.insert(0, home)  # a package, or a folder team's modules importing each other
        return str(Path(home) / entry) if is_file_spec(entry) else entry

    def _fault(self, tick: int, time: float, kind: FaultKind, message: str, e: BaseException) -> Fault:
        """The fault of the team's exception `e`: its whole traceback printed here, its tail
        (from the team's first frame, paths relative to the team's folder) in the record."""
        sys.stderr.write("".join(traceback.format_exception(e)))
        told = team_traceback(e, globals(), vars(loading))
        if self.team.home:
            told = told.replace(os.path.join(self.team.home, ""), "")
        return fault(tick, time, kind, message, traceback=traceback_tail(told))

    def step(self, obs: Observation) -> Command | Fault:
        if self.controller is None:
            return fault(obs.tick, obs.time, FaultKind.PROTOCOL, "a step before the controller's setup")
        try:
            cmd = self.controller.step(obs)
        except Exception as e:
            return self._fault(obs.tick, obs.time, FaultKind.EXCEPTION, f"in step: {describe(e)}", e)
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
