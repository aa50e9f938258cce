"""The match: the simulation core (`simulation`) played by its controllers (`fleet`), one
control tick at a time, and recorded (a replay file or a `Recorder`).

One control tick: every controller gets its Observation (all are sent before any answer is
awaited, so controller processes compute at the same time, while the referee writes the
replay of the period just stepped); their answers go to the simulation, which steps physics
to the next tick. The match ends at the time limit, or as soon as every robot has finished
its task or been stopped by a fault.
"""

from __future__ import annotations

import functools
from pathlib import Path

from levels.match import ControllerLimits
from levels.model import Level
from referee.match.fleet import Fleet
from referee.match.simulation import Simulation
from referee.match.views import brief_for, replay_header
from referee.records.replay_writer import Recorder, ReplayWriter
from referee.records.results import MatchResult
from referee.sandbox.exchange import exchange
from referee.sandbox.teams import Team

__all__ = ["Match", "play_match"]


class Match:
    """One match of a level between teams (one per robot slot), run to its end by `run()`:
    its `simulation`, its `fleet` of controllers and its `recorder` (the replay)."""

    def __init__(
        self,
        level: Level,
        teams: list[Team],
        seed: int | None = None,
        replay: str | Path | None = None,
        ideal: bool = False,
        isolate: bool = True,
        limits: ControllerLimits | None = None,
        logs: Path | None = None,
        recorder: Recorder | None = None,
        noise_key: str | None = None,
    ):
        if len(teams) != len(level.robots):
            raise ValueError(f"{level.name} has {len(level.robots)} robot slots, got {len(teams)} teams")
        self.level, self.teams = level, teams
        # first: a root referee's controller template starts now and imports meanwhile
        self.fleet = Fleet(teams, level.limits if limits is None else limits, logs, isolate)
        seed = level.seed if seed is None else seed
        if replay is not None:
            recorder = ReplayWriter(replay, replay_header(level, teams, seed, ideal, noise_key))
        self.recorder = recorder
        self._made = (level, [t.label for t in teams], seed, ideal, noise_key, recorder)

    @functools.cached_property
    def simulation(self) -> Simulation:
        """The match's simulation core, made on first use: `run` makes it once the controllers
        are launched, so they boot while the world is made (and a process's first match loads
        the compiled kernels), or while their template still boots. The replay's writes wait
        while the controllers compute (docs/decisions/0028)."""
        level, labels, seed, ideal, noise_key, recorder = self._made
        return Simulation(level, labels, seed, ideal, noise_key, recorder, defer=True)

    def run(self) -> MatchResult:
        """Run the match to its end and return the result (see docs/results.md)."""
        try:
            self.fleet.launch(wait=False)  # they boot while the world is made
            sim, bots = self.simulation, self.fleet.bots
            tick = sim.start(self.fleet.start([brief_for(self.level, s) for s in range(len(self.teams))]))
            while not tick.ended:
                tick = sim.step(exchange(bots, tick.observations, meanwhile=sim.flush))
            self.fleet.ask_to_end()
            return sim.end()
        except BaseException:
            if self.recorder is not None:
                self.recorder.discard()  # an interrupted match leaves no half-written replay
            raise
        finally:
            self.fleet.close()


def play_match(
    level: Level,
    teams: list[Team],
    seed: int | None = None,
    replay: str | Path | None = None,
    ideal: bool = False,
    isolate: bool = True,
    limits: ControllerLimits | None = None,
    logs: Path | None = None,
    noise_key: str | None = None,
) -> MatchResult:
    """Play one match of loaded teams and return its result (the public `referee.run_match`
    names level and teams as a user does). `ideal` turns every sensor noise and failure and
    every drive error off; `isolate=False` runs the controllers inside this process instead of
    their own; `limits` replaces the level's controller limits (`fleet.NO_LIMITS` for debugging);
    `logs` is a folder for each controller's output (`slotN.log`), tracebacks included;
    `noise_key` (hex) mixes a secret into every random stream, so the public seed alone cannot
    reproduce the noise."""
    return Match(level, teams, seed, replay, ideal, isolate, limits, logs, noise_key=noise_key).run()
