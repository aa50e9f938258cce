"""A controller's time allowance over a match (docs/rules.md): each answer within `step_time`;
up to `step_deadline` accepted, the excess drawn from the overage bank; later, a skipped tick
whose late answer is awaited (and charged) before the next observation. `max_skips` skipped
ticks in a row, an empty bank, or answers that together take longer than the think budget
end the controller with a `timeout` fault, whose message says which rule it broke."""

from __future__ import annotations

from dataclasses import dataclass, field

from levels.match import ControllerLimits


@dataclass
class Allowance:
    """What one controller has used of its time so far this match."""

    limits: ControllerLimits
    bank: float = field(init=False)  # s of overage left
    thinking: float = 0.0  # s of answer time so far this match (steps, and waits for late answers)
    think_limit: float = float("inf")  # the match's think budget in s, known at setup (`begin`)
    skips: int = 0  # consecutive skipped ticks
    pending: int | None = None  # tick of an observation still unanswered

    def __post_init__(self) -> None:
        self.bank = self.limits.overage_bank

    def begin(self, time_limit: float) -> None:
        """The match lasts `time_limit` simulated seconds: its think budget follows."""
        self.think_limit = self.limits.think_budget * time_limit

    def answered(self, took: float) -> bool:
        """Charge an answer that came `took` s after its observation; False if that broke a rule."""
        self.thinking += took
        self.skips = 0
        if took > self.limits.step_time:
            self.bank -= took - self.limits.step_time
            if self.bank <= 0:
                return False
        return self.thinking <= self.think_limit

    def skipped(self, tick: int, took: float) -> bool:
        """Charge tick `tick`, unanswered by its deadline (`took` s); False if that broke a rule,
        else the tick is skipped and its answer awaited before the next observation."""
        self.thinking += took
        self.pending = tick
        self.bank -= self.limits.step_deadline - self.limits.step_time
        self.skips += 1
        return self.skips < self.limits.max_skips and self.bank > 0 and self.thinking <= self.think_limit

    def late_wait(self) -> float:
        """How long a skipped tick's late answer may still be awaited (s)."""
        return max(min(self.bank, self.think_limit - self.thinking), 0.0)

    def waited(self, seconds: float) -> None:
        """Charge `seconds` spent awaiting a late answer."""
        self.bank -= seconds
        self.thinking += seconds

    def broken(self, where: str) -> str:
        """The message of a `timeout` fault in `where` (setup or step): which limit it broke,
        by the limits' names in the level file (docs/security.md), and what to do."""
        lim = self.limits
        if self.skips >= lim.max_skips:
            return (
                f"in {where}: {self.skips} ticks in a row without an answer within step_deadline "
                f"({lim.step_deadline:g} s, max_skips {lim.max_skips}); keep step() within step_time ({lim.step_time:g} s)"
            )
        if self.thinking > self.think_limit:
            return (
                f"in {where}: think budget used up: answers took over the {self.think_limit:g} s this match allows "
                f"(think_budget {lim.think_budget:g} s per simulated second); make step() faster"
            )
        if where == "step" and self.pending is not None:
            return (
                f"in step: step() did not return within step_deadline ({lim.step_deadline:g} s), nor before the "
                f"overage_bank ({lim.overage_bank:g} s a match) ran out: a step that loops or waits never answers"
            )
        if where == "step":
            return (
                f"in step: steps over step_time ({lim.step_time:g} s) used up the overage_bank "
                f"({lim.overage_bank:g} s of excess a match); make step() faster"
            )
        return (
            f"in {where}: no answer within setup_time ({lim.setup_time:g} s): loading and setup() must finish within it"
        )
