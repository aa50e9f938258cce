"""The narrow call site between the match and a team's controller: what every bot does,
wherever its controller runs (`ProcessBot` in `process`, sandboxed; `InProcessBot` in
`in_process`, for a debugger). Whatever goes wrong becomes a typed `Fault`, and the bot stops
answering: the match goes on without it."""

from __future__ import annotations

from typing import Protocol

from referee.sandbox.fault import Fault
from robots.api import Brief, Command, Observation


class Bot(Protocol):
    """A team's controller as the match drives it: launched, set up, stepped, ended."""

    def launch(self) -> None:
        """Start the controller (every bot is launched before any is set up: start-ups overlap)."""

    def setup(self, brief: Brief) -> Fault | None:
        """Give the controller its brief: None once it is ready, else the Fault."""

    def step(self, obs: Observation) -> Command | Fault:
        """The controller's answer to `obs`, or a Fault (a skipped tick's is not fatal)."""

    def ask_to_end(self) -> None:
        """Tell the controller the match is over, without waiting for it."""

    def close(self) -> None:
        """End the controller and everything it holds; safe to call again."""
