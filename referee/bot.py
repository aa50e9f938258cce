"""The narrow call site between the match and a team's controller.

`InProcessBot` runs the controller inside the referee's process; the isolation issue puts
the same interface around a separate process. Any exception or malformed command becomes
a typed `Fault`, and the bot stops answering: the match goes on without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from referee.teams import Team
from robots.api import Brief, Command, Observation


@dataclass(frozen=True)
class Fault:
    """A controller fault: when it happened, its type and a one-line message."""

    tick: int
    time: float
    kind: str  # exception | bad_command
    message: str

    def to_dict(self) -> dict:
        return {"tick": self.tick, "time": self.time, "kind": self.kind, "message": self.message}


def one_line(e: BaseException) -> str:
    """An exception as `Type: message` on one line."""
    text = " ".join(str(e).split())
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def check_command(cmd: object) -> str | None:
    """Why `cmd` is not a usable Command, or None if it is."""
    if not isinstance(cmd, Command):
        return f"step() returned {type(cmd).__name__}, not Command"
    for name in ("left", "right"):
        v = getattr(cmd, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            return f"Command.{name} must be a finite number, got {v!r}"
    est = cmd.estimate
    if est is not None:
        if not (isinstance(est, tuple) and len(est) == 3 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in est)):
            return f"Command.estimate must be None or three finite numbers, got {est!r}"
    return None


class InProcessBot:
    """A controller running in the referee's own process."""

    def __init__(self, team: Team):
        self.team = team
        self.controller = None

    def setup(self, brief: Brief) -> Fault | None:
        try:
            self.controller = self.team.factory()
            self.controller.setup(brief)
        except Exception as e:  # a team's bug must not stop the match
            return Fault(0, 0.0, "exception", f"in setup: {one_line(e)}")
        return None

    def step(self, obs: Observation) -> Command | Fault:
        try:
            cmd = self.controller.step(obs)
        except Exception as e:
            return Fault(obs.tick, obs.time, "exception", f"in step: {one_line(e)}")
        problem = check_command(cmd)
        if problem:
            return Fault(obs.tick, obs.time, "bad_command", problem)
        return cmd
