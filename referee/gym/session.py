"""One match driven step by step by learning agents, for the Gymnasium and PettingZoo envs.

The agents ARE the controllers of their slots: the session runs the referee's simulation core
(`referee.match.simulation`: the same physics, sensing, rules and task tracking as a match),
reads each control tick's report, and answers for the agent slots with the agents' actions;
other slots run their controllers in this process. Rewards are the score of docs/rules.md spread over the ticks,
plus a potential-based shaping term (docs/rl.md).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from levels.model import Level
from referee.match.report import RobotReport, Tick
from referee.match.scoring import LOCALIZATION_POINTS, LOCALIZE_TASK_POINTS, TASK_POINTS, TIME_POINTS
from referee.match.simulation import Simulation
from referee.match.views import brief_for, replay_header
from referee.records.replay_writer import ReplayWriter
from referee.records.results import Fault, MatchResult
from referee.sandbox.in_process import InProcessBot
from referee.sandbox.teams import Team, controller_problem, fill_slots
from robots.api import Command
from robots.toolkit.features import ObservationEncoder
from robots.toolkit.policy import command

AGENT_SPEC = "ref:idle"  # what the replay header names for an agent slot (its answers come from the agent)
AGENT_HASH = "sha256:" + hashlib.sha256(AGENT_SPEC.encode()).hexdigest()  # no code ships for an agent


class Step(NamedTuple):
    """One control tick's outcome for the agent slots (dicts keyed by slot); a tuple, the
    cheapest record to build at every env step."""

    observations: dict[int, np.ndarray]
    rewards: dict[int, float]
    terminated: dict[int, bool]
    truncated: dict[int, bool]
    infos: dict[int, dict]


def match_seed(seed: int | None, generator: np.random.Generator) -> int:
    """The match an env's reset plays: `seed`, or else the next draw of the env's generator."""
    return seed if seed is not None else int(generator.integers(0, 2**31 - 1))


def load(level: str | Path | Level) -> Level:
    """A level by built-in name, file path, or already loaded."""
    if isinstance(level, Level):
        return level
    from levels.loader import find_level

    return find_level(str(level), controllers=controller_problem)


class AgentSession:
    """Matches of one level in which the slots `agents` are driven by actions.

    An action is a float array in -1..1: the left and right wheel speeds as fractions of the
    robot's top speed; with `report_estimate`, followed by the pose estimate that the referee
    scores, x and y scaled so -1..1 spans the field and heading / pi (robots.toolkit.policy's
    `command`, as a controller playing a trained policy maps it). Observations are the
    team-side encoder's (robots.toolkit.features), with its goal block if `goal`."""

    def __init__(
        self,
        level: str | Path | Level,
        agents: tuple[int, ...],
        others: list[str] | None = None,
        ideal: bool = False,
        report_estimate: bool = False,
        replay: str | Path | None = None,
        goal: bool = False,
    ):
        self.level = load(level)
        n = len(self.level.robots)
        if not agents or any(not 0 <= s < n for s in agents) or len(set(agents)) != len(agents):
            raise ValueError(f"{self.level.name} has robot slots 0..{n - 1}; agents {agents} do not fit")
        self.agents = tuple(agents)
        rest = [s for s in range(n) if s not in self.agents]
        self.others = dict(zip(rest, fill_slots(self.level, others, len(rest))))
        self.ideal, self.report_estimate, self.replay = ideal, report_estimate, replay
        samples = int(self.level.beacons.params.get("samples_per_turn", 0))
        self.briefs = {s: brief_for(self.level, s) for s in self.agents}
        self.encoders = {s: ObservationEncoder(self.briefs[s], samples, goal) for s in self.agents}
        self.total_ticks = self.level.control_ticks
        self.sim: Simulation | None = None
        self.bots: dict[int, InProcessBot] = {}  # the other slots' controllers
        self.answers: list[Command | Fault | None] = []  # the other slots' answers to the tick's observations
        self.result: MatchResult | None = None

    def action_size(self) -> int:
        """2 (wheel speeds), or 5 with a pose estimate; every component is in -1..1."""
        return 5 if self.report_estimate else 2

    def reset(self, seed: int) -> dict[int, np.ndarray]:
        """Start a new match with `seed`; return each agent's first observation."""
        self.close()
        level, n = self.level, len(self.level.robots)
        teams = [self.others.get(s) or Team(f"agent{s}", AGENT_SPEC, AGENT_HASH) for s in range(n)]
        recorder = None
        if self.replay is not None:
            recorder = ReplayWriter(self.replay, replay_header(level, teams, seed, self.ideal, None))
        self.sim = sim = Simulation(level, [t.label for t in teams], seed, self.ideal, recorder=recorder)
        self.bots = {s: InProcessBot(t) for s, t in self.others.items()}
        faults: list[Fault | None] = [None] * n
        for s, bot in self.bots.items():
            faults[s] = bot.setup(brief_for(level, s))
        tick = sim.start(faults)
        self.result = None
        self.done = {s: False for s in self.agents}
        for enc in self.encoders.values():
            enc.reset()
        self.free = {s: self._free(s) for s in self.agents}
        self.reports = {s: sim.report(s) for s in self.agents}
        self.potential = {s: self._potential(self.reports[s], s) for s in self.agents}
        self.fouls = {s: 0 for s in self.agents}
        return self._observe(tick)

    def _live(self) -> Simulation:
        """The match in play (reset() starts one)."""
        if self.sim is None:
            raise RuntimeError("no match in play: call reset()")
        return self.sim

    def _observe(self, tick: Tick) -> dict[int, np.ndarray]:
        """The control tick's first half: the other slots answer their observations, the
        agents' encoders take theirs."""
        self.answers = [None] * len(self.level.robots)
        for slot, obs in enumerate(tick.observations):
            if obs is None:
                continue
            bot = self.bots.get(slot)
            if bot is not None:
                self.answers[slot] = bot.step(obs)
            else:
                self.encoders[slot].take(obs)
        return self._encode(tick.time)

    def _encode(self, time: float) -> dict[int, np.ndarray]:
        """Every agent's observation vector at `time` (the encoders are keyed in agent order)."""
        return {slot: encoder.encode(time) for slot, encoder in self.encoders.items()}

    def step(self, actions: dict[int, np.ndarray]) -> Step:
        """Apply the agents' actions for one control period and return what follows."""
        sim = self.sim
        if sim is None or sim.ended:
            raise RuntimeError("the match has ended: call reset()")
        answers = self.answers
        for slot in self.agents:
            if self.reports[slot].stopped:  # (as the last step left it: only agents' answers stop agents)
                continue
            if self.done[slot]:  # a finished agent stands still while the others play on
                answers[slot] = Command(0.0, 0.0)
                continue
            action = actions[slot]
            cmd = command(action if self.report_estimate else action[:2], self.briefs[slot])
            answers[slot] = cmd
            self.encoders[slot].commanded(cmd.left, cmd.right)
        tick = sim.step(answers)
        self.reports = reports = {s: sim.report(s) for s in self.agents}
        terminated = {s: r.done for s, r in reports.items()}
        truncated: dict[int, bool] = {s: tick.ended and not terminated[s] for s in self.agents}
        if tick.ended or all(terminated.values()):
            self.result = sim.end()  # the rules' last fouls count in this last reward
            self.reports = reports = {s: sim.report(s) for s in self.agents}
            observations = self._encode(tick.time)
        else:
            observations = self._observe(tick)
        rewards: dict[int, float] = {}
        infos: dict[int, dict] = {}
        for slot in self.agents:
            report = reports[slot]
            earned = tick.earned[slot]  # the tick's quality, as the referee scored it
            rewards[slot] = self._reward(report, slot) + (0.0 if earned is None else self._localization(earned))
            infos[slot] = {"progress": report.progress, "time": report.time}
            if self.result is not None:
                infos[slot]["result"] = self.result
            self.done[slot] = terminated[slot]
        return Step(observations, rewards, terminated, truncated, infos)

    def _localization(self, quality: float) -> float:
        """One tick's share of the localization points (docs/rules.md) for an estimate of this
        tick quality."""
        points = LOCALIZE_TASK_POINTS if self.level.task.kind == "localize" else LOCALIZATION_POINTS
        return points / self.total_ticks * quality

    def _free(self, slot: int) -> int:
        """How many of the first waypoints the robot's true start already lies on: the referee
        counts them reached at the first physics step, whatever the agent does, so they must
        not pay as the first step's reward (reset's potential holds them)."""
        if self.level.task.kind not in ("waypoints", "race"):
            return 0
        report = self._live().report(slot)
        free = 0
        while free < len(report.targets) and math.dist(report.start, report.targets[free]) <= self.level.task.radius:
            free += 1
        return free

    def _potential(self, report: RobotReport, slot: int) -> float:
        """Task points reached so far plus the fraction of the current leg covered (shaping);
        the waypoints the start lies on count as reached from the start."""
        kind, targets = self.level.task.kind, report.targets
        if kind == "localize" or not targets:
            return 0.0
        i = max(report.reached, self.free[slot])
        value = TASK_POINTS * report.progress
        if kind != "goto":  # the start's own waypoints count from reset, whole
            value += TASK_POINTS * (i - report.reached) / len(targets)
        if kind != "goto" and i < len(targets):
            prev = targets[i - 1] if i else report.start
            leg = math.dist(prev, targets[i])
            if leg > 0:
                covered = 1.0 - math.dist(report.position, targets[i]) / leg
                value += TASK_POINTS / len(targets) * min(1.0, max(0.0, covered))
        return value

    def _reward(self, report: RobotReport, slot: int) -> float:
        phi = self._potential(report, slot)
        reward = phi - self.potential[slot]
        self.potential[slot] = phi
        if len(report.penalties) > self.fouls[slot]:
            reward -= sum(report.penalties[self.fouls[slot] :])
            self.fouls[slot] = len(report.penalties)
        if report.finished is not None and not self.done[slot] and self.level.task.kind != "localize":
            reward += TIME_POINTS * (1.0 - report.finished / self.level.time_limit) * report.quality
        return float(reward)

    def close(self) -> None:
        """End the current match; an episode left before its end still gets its replay, ending there."""
        if self.sim is not None:
            if self.result is None and self.sim.recorder is not None:
                self.result = self.sim.end()
            for bot in self.bots.values():
                bot.close()
            self.sim, self.bots = None, {}
