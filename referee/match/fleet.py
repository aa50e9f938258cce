"""The match's controllers, one per robot slot, from launch to close: each in a process and
kernel sandbox of its own (or, where isolation is off or unavailable, in this process), a
lone controller sharing one CPU with its referee, each given its brief at setup."""

from __future__ import annotations

import warnings
from pathlib import Path

from levels.match import ControllerLimits
from referee.errors import LaserArenaWarning
from referee.records.results import Fault
from referee.sandbox import affinity, forkserver
from referee.sandbox.bot import Bot
from referee.sandbox.in_process import InProcessBot
from referee.sandbox.privacy import make_undumpable
from referee.sandbox.process import ProcessBot, isolation_unavailable
from referee.sandbox.teams import Team
from robots.api import Brief

NO_LIMITS = ControllerLimits(
    setup_time=float("inf"),
    step_time=float("inf"),
    step_deadline=float("inf"),
    overage_bank=float("inf"),
    max_skips=1 << 62,
    think_budget=float("inf"),
    memory=0,
    log_bytes=0,
)


class Fleet:
    """One controller per team, in slot order (`bots`), and the CPU a lone isolated one
    shares with this thread while they run (`cpu`). `logs` is a folder for each isolated
    controller's output (`slotN.log`)."""

    def __init__(self, teams: list[Team], limits: ControllerLimits, logs: Path | None, isolate: bool):
        reason = isolation_unavailable() if isolate else None
        if reason:  # said once per match, in one line; the match still runs
            warnings.warn(
                f"controllers run in this process ({reason}): nothing isolates them", LaserArenaWarning, stacklevel=3
            )
            isolate = False
        if isolate:
            make_undumpable()  # before any controller exists: no one reads our memory via /proc
        self.bots: list[Bot] = [
            ProcessBot(t, limits, Path(logs) / f"slot{i}.log" if logs else None, slot=i) if isolate else InProcessBot(t)
            for i, t in enumerate(teams)
        ]
        self.cpu: affinity.Claim | None = None

    def launch(self, wait: bool = True) -> None:
        """Launch every controller not launched yet (a lone process on the referee's CPU):
        they boot side by side, and meanwhile, this thread's own work. Every slot is prepared
        before any process starts (ProcessBot.prepare). With `wait` False, none while their
        template still boots: this thread's work comes first then (`start` launches them)."""
        if not wait and forkserver.booting():
            return
        processes = [bot for bot in self.bots if bot.isolated]
        if len(processes) == 1 and self.cpu is None:  # referee and controller on one CPU
            self.cpu = affinity.claim()
            if self.cpu is not None:
                processes[0].pin([self.cpu.cpu])
        for bot in self.bots:
            bot.prepare()
        for bot in self.bots:
            bot.launch()

    def start(self, briefs: list[Brief]) -> list[Fault | None]:
        """Launch every controller (if `launch` has not), then set each up with its brief:
        each slot's setup fault, or None."""
        self.launch()
        return [bot.setup(brief) for bot, brief in zip(self.bots, briefs)]

    def ask_to_end(self) -> None:
        """Tell every controller the match is over, without waiting: told all at once, they end
        side by side, while this thread writes the result and the replay (`close` waits)."""
        for bot in self.bots:
            bot.ask_to_end()

    def close(self) -> None:
        """End every controller (their processes, if isolated) and give back the CPU, if one was claimed."""
        try:
            try:
                self.ask_to_end()
            finally:
                for bot in self.bots:
                    bot.close()
        finally:
            if self.cpu is not None:
                affinity.release(self.cpu)
                self.cpu = None
