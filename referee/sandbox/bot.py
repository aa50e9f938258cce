"""The narrow call site between the match and a team's controller: what every bot does,
wherever its controller runs (`ProcessBot` in `process`, sandboxed; `InProcessBot` in
`in_process`, for a debugger). Whatever goes wrong becomes a typed `Fault`, and the bot stops
answering: the match goes on without it. A controller in a process of its own answers later
(`Awaited`): `exchange` waits for several at once through that protocol alone."""

from __future__ import annotations

from typing import Protocol

from referee.records.results import Fault
from referee.sandbox.channel import Trouble
from robots._host import protocol
from robots.api import Brief, Command, Observation

Reply = tuple[protocol.Message | Trouble, float]  # an answer (or trouble) and the seconds it took


class Awaited(Protocol):
    """A controller computing its answer in a process of its own, as `exchange` waits for it:
    its observation may still be going out, its answer coming in piece by piece."""

    sent: float  # when its observation began to go out (time.monotonic): its clock
    deadline: float  # when its answer is late (time.monotonic)

    def reader(self) -> int:
        """The descriptor its answers come on."""

    def writer(self) -> int | None:
        """The descriptor of its input while part of its observation is unwritten, else None."""

    def write_more(self) -> Trouble | None:
        """Write what its input takes now of the observation; Trouble if its input is closed."""

    def read_more(self, since: float) -> bool:
        """Read what it has written (an answer arriving now is stamped no earlier than
        `since`); False once its output is closed."""

    def answered(self) -> bool:
        """Whether a whole answer has been read."""

    def decoded(self) -> Reply:
        """The whole answer decoded, and the seconds it took: from the sending of its
        observation to its arrival, plus its decoding."""

    def refuse(self, problem: str) -> None:
        """Name the protocol breach its fault will report."""

    def judge(self, obs: Observation, reply: protocol.Message | Trouble, took: float) -> Command | Fault:
        """Its answer `reply` (or trouble), `took` seconds after sending, as `step` would give it."""


class Bot(Protocol):
    """A team's controller as the match drives it: launched, set up, stepped, ended."""

    isolated: bool  # its controller runs in a process of its own

    def pin(self, cpus: list[int]) -> None:
        """Before `launch`: run its controller's process on `cpus` only (nothing in this process)."""

    def prepare(self) -> None:
        """Make what the controller needs before it starts (every bot's, before any starts)."""

    def launch(self) -> None:
        """Start the controller (every bot is launched before any is set up: start-ups overlap)."""

    def setup(self, brief: Brief) -> Fault | None:
        """Give the controller its brief: None once it is ready, else the Fault."""

    def step(self, obs: Observation) -> Command | Fault:
        """The controller's answer to `obs`, or a Fault (a skipped tick's is not fatal)."""

    def send(self, obs: Observation) -> Command | Fault | Awaited:
        """The first half of a step: hand `obs` over. The answer or Fault at once (a controller
        in this process), or what to wait on for it (`exchange` then gathers and judges it)."""

    def ask_to_end(self) -> None:
        """Tell the controller the match is over, without waiting for it."""

    def close(self) -> None:
        """End the controller and everything it holds; safe to call again."""
