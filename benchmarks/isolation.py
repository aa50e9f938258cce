"""What isolating controllers costs: the per-step round trip, and a 4-robot match isolated
vs in-process. Run: python benchmarks/isolation.py

Target (issue 4): an isolated `asabe-race` match with the reference controllers takes under
2x the time of the same match in-process.
"""

from __future__ import annotations

import time

import levels
from arena.loader import load_level
from referee.match.loop import brief_for, run_match
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve
from robots.api import Observation, SensorEvent


def round_trip(steps: int = 3000) -> float:
    """Seconds per step exchange with a controller process (a typical observation of 4 hits)."""
    level = load_level(levels.path("asabe"))
    bot = ProcessBot(resolve("ref:dead-reckoning"), level.limits)
    assert bot.setup(brief_for(level, 0)) is None
    events = tuple(SensorEvent(0.01 * i, "hit", "OABC"[i]) for i in range(4))
    try:
        start = time.perf_counter()
        for k in range(steps):
            bot.step(Observation(k, 0.2 * k, events))
        return (time.perf_counter() - start) / steps
    finally:
        bot.close()


def match_time(isolate: bool) -> float:
    level = load_level(levels.path("asabe-race"))
    teams = [resolve(level.default_controller)] * len(level.robots)
    start = time.perf_counter()
    run_match(level, teams, isolate=isolate)
    return time.perf_counter() - start


def main() -> None:
    rt = round_trip()
    inproc = min(match_time(False) for _ in range(2))
    iso = min(match_time(True) for _ in range(2))
    print("controller isolation (best of 2)")
    print(f"  step round trip          {rt * 1e6:8.0f} us")
    print(f"  asabe-race in-process    {inproc:8.2f} s")
    print(f"  asabe-race isolated      {iso:8.2f} s")
    print(f"  isolated / in-process    {iso / inproc:8.2f} x   (target < 2 x)")


if __name__ == "__main__":
    main()
