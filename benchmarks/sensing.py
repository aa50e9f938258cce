"""Sensing cost on the 4-robot `asabe-race` level: world stepping with and without the lasers.

Run: python benchmarks/sensing.py [--seconds 60]
Prints simulated seconds per wall second for bare stepping and stepping + sensing, the
ratio, and the cost per crossing. Target (issue 3): sensing adds under 50 % to stepping.
"""

from __future__ import annotations

import argparse
import json
import time

import levels
from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.world import World
from levels.loader import load_level


def run(seconds: float, sensing_on: bool) -> tuple[float, int]:
    """Wall time to simulate `seconds` of asabe-race with every robot circling; and events."""
    level = load_level(levels.path("asabe-race"))
    world = World(level)
    sensing = Sensing(world, RandomTree(1)) if sensing_on else None
    for slot in range(len(level.robots)):  # a trivial controller: gentle circles
        world.command(slot, 0.08, 0.12)
    steps, spc = round(seconds * level.physics_rate), level.steps_per_control
    events = 0
    start = time.perf_counter()
    for k in range(steps):
        world.step()
        if sensing:
            sensing.record()
            if (k + 1) % spc == 0:
                events += sum(len(e) for e in sensing.flush())
    return time.perf_counter() - start, events


def run_periods(seconds: float) -> float:
    """Wall time to simulate `seconds` of the same world with nothing else, a control period
    at a time through `World.run` (compiled, as a match steps it)."""
    level = load_level(levels.path("asabe-race"))
    world = World(level)
    for slot in range(len(level.robots)):
        world.command(slot, 0.08, 0.12)
    steps, spc = round(seconds * level.physics_rate), level.steps_per_control
    start = time.perf_counter()
    for _ in range(steps // spc):
        world.run(spc)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run")
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = ap.parse_args()
    pairs = [(run(args.seconds, False)[0], run(args.seconds, True)) for _ in range(3)]  # interleaved
    bare = min(b for b, _ in pairs)
    sensed, events = min((s for _, s in pairs), key=lambda r: r[0])
    out = {
        "level": "asabe-race",
        "simulated_s": args.seconds,
        "bare_speed_x": args.seconds / bare,
        "sensing_speed_x": args.seconds / sensed,
        "sensing_overhead": (sensed - bare) / bare,
        "events": events,
        "us_per_event": 1e6 * (sensed - bare) / max(events, 1),
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"asabe-race, 4 robots, {args.seconds:g} s simulated (best of 3)")
    print(f"  bare stepping      {out['bare_speed_x']:8.1f} x real time")
    print(f"  stepping + sensing {out['sensing_speed_x']:8.1f} x real time")
    print(f"  sensing adds       {100 * out['sensing_overhead']:8.1f} %   (target < 50 %)")
    print(f"  events             {events:8d}   {out['us_per_event']:.2f} us of sensing per event")


if __name__ == "__main__":
    main()
