"""What isolating controllers costs: the per-step round trip, one control tick's exchange with 4
controllers one after another vs all sent before any is awaited, and a 4-robot `asabe-race`
match isolated (forked controllers, scattered exchange) vs the old way (spawned sandboxes,
one exchange after another) vs in-process, with cheap controllers and with the level's own.
Run: python benchmarks/isolation.py

Target: an isolated `asabe-race` match with the reference controllers takes under
2x the time of the same match in-process.
"""

from __future__ import annotations

import time

import levels
from levels.loader import load_level
from referee.match.loop import Match
from referee.match.views import brief_for
from referee.sandbox.exchange import exchange
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve
from robots.api import Observation, SensorEvent

EVENTS = tuple(SensorEvent(0.01 * i, "hit", "OABC"[i]) for i in range(4))  # a typical observation


def _bots(team: str, n: int) -> list[ProcessBot]:
    level = load_level(levels.path("asabe"))
    bots = [ProcessBot(resolve(team), level.limits, slot=i) for i in range(n)]
    for bot in bots:
        assert bot.setup(brief_for(level, 0)) is None
    return bots


def round_trip(steps: int = 3000) -> float:
    """Seconds per step exchange with a controller process."""
    (bot,) = _bots("ref:dead-reckoning", 1)
    try:
        start = time.perf_counter()
        for k in range(steps):
            bot.step(Observation(k, 0.2 * k, EVENTS))
        return (time.perf_counter() - start) / steps
    finally:
        bot.close()


def tick_exchange(team: str, scattered: bool, ticks: int = 500) -> float:
    """Seconds per control tick exchanging with 4 controllers of `team`."""
    bots = _bots(team, 4)
    try:
        start = time.perf_counter()
        for k in range(ticks):
            obs = [Observation(k, 0.2 * k, EVENTS)] * 4
            if scattered:
                exchange(bots, obs)
            else:
                for bot, o in zip(bots, obs):
                    bot.step(o)
        return (time.perf_counter() - start) / ticks
    finally:
        for bot in bots:
            bot.close()


def _sequential(level, teams) -> None:
    """The match as it was: each controller spawned in a sandbox of its own, exchanged with in turn."""
    match = Match(level, teams)
    sim, fleet = match.simulation, match.fleet
    fleet.bots = [ProcessBot(t, level.limits, slot=i, forked=False) for i, t in enumerate(teams)]
    try:
        tick = sim.start(fleet.start([brief_for(level, s) for s in range(len(teams))]))
        while not tick.ended:
            tick = sim.step([None if o is None else b.step(o) for b, o in zip(fleet.bots, tick.observations)])
        sim.end()
    finally:
        fleet.close()


def match_time(controller: str, mode: str) -> float:
    """Seconds for the whole `asabe-race` match (start and end of the controllers included)."""
    level = load_level(levels.path("asabe-race"))
    teams = [resolve(controller)] * len(level.robots)
    start = time.perf_counter()
    if mode == "in-process":
        Match(level, teams, isolate=False).run()
    elif mode == "isolated":
        Match(level, teams).run()
    else:
        _sequential(level, teams)
    return time.perf_counter() - start


def main() -> None:
    rt = round_trip()
    print("controller isolation")
    print(f"  step round trip (1 controller)        {rt * 1e6:8.0f} us")
    for team in ("ref:dead-reckoning", "ref:bac"):
        one, all_ = tick_exchange(team, False), tick_exchange(team, True)
        print(
            f"  tick exchange, 4 x {team:18s} one by one {one * 1e6:6.0f} us   "
            f"scattered {all_ * 1e6:6.0f} us   ({one / all_:.2f} x)"
        )
    level = load_level(levels.path("asabe-race"))
    for controller in ("ref:dead-reckoning", level.default_controller):
        times = {m: min(match_time(controller, m) for _ in range(2)) for m in ("in-process", "isolated", "old")}
        print(f"  asabe-race, 4 x {controller} (best of 2)")
        print(f"    in-process                          {times['in-process']:8.2f} s")
        print(f"    isolated (forked, scattered)        {times['isolated']:8.2f} s")
        print(f"    isolated (spawned, one by one)      {times['old']:8.2f} s")
        print(
            f"    isolated / in-process               {times['isolated'] / times['in-process']:8.2f} x   (target < 2 x)"
        )
        print(f"    old / new isolated                  {times['old'] / times['isolated']:8.2f} x")


if __name__ == "__main__":
    main()
