"""How a match's cost grows with its robots (1-8) and with its beacons, beside bare stepping.

Run: python benchmarks/scaling.py [--seconds 20] [--repeat 3] [--json]
Worlds are the asabe-race table (Bac's sensor arrays, coded crosstalk) with N robots set on a
grid, each driving laps of its own rectangle for the whole match, and M arrays on the table's edge. For each
world, measured side by side in one run (medians of `--repeat`): bare stepping (the world a
`World.step` at a time, nothing else: pymunk's stepping, the reference of every match ratio in
`make bench`) and a full match with
`ref:dead-reckoning` in every slot (a controller whose own cost is next to nothing: what is
measured is the platform), in this process and isolated (each controller in its sandbox), with
the replay written. Printed: simulated seconds per wall second of each, the match's ratio to
bare, and the referee's CPU per simulated second. Robots grow with 4 beacons; beacons grow
with 4 robots.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import tempfile
import time
from pathlib import Path

import yaml

import levels
from arena.world import World
from levels.loader import parse_level
from levels.model import Level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

ROBOTS = (1, 2, 4, 6, 8)
BEACONS = (3, 4, 6, 8)
# grid starts on the 1.83 x 1.22 m table, clear of each other and of the edge arrays
STARTS = [(0.30 + 0.41 * i, 0.30 + 0.62 * j) for j in range(2) for i in range(4)]
# arrays along the edge: the four corners first, then the middles of the long and short sides
LAP = ((0.25, 0.0), (0.25, 0.25), (0.0, 0.25), (0.0, 0.0))  # a robot's rectangle, from its start
EDGE = [(0.0, 0.0), (1.83, 0.0), (1.83, 1.22), (0.0, 1.22), (0.915, 0.0), (0.915, 1.22), (1.83, 0.61), (0.0, 0.61)]


def world(robots: int, beacons: int, seconds: float) -> Level:
    """asabe-race's table with `robots` robots and `beacons` arrays, for `seconds`."""
    data = yaml.safe_load(levels.path("asabe-race").read_text())
    data.update(name=f"scaling-{robots}r-{beacons}b", time_limit=seconds, task={"kind": "waypoints", "radius": 0.05})
    data["beacons"]["items"] = [{"id": f"B{k}", "at": list(EDGE[k])} for k in range(beacons)]
    data["robots"] = [
        {
            "start": [x, y, 0],
            "placement": {"position": 0.01, "heading": 10},
            "start_known": True,
            "path": [[x + dx, y + dy] for _ in range(8) for dx, dy in LAP],  # laps past the time limit
        }
        for x, y in STARTS[:robots]
    ]
    return parse_level(yaml.safe_dump(data).encode(), f"scaling-{robots}r-{beacons}b")


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bare(level: Level) -> float:
    """Simulated seconds per wall second of the world stepped alone, every robot driving."""
    w = World(level)
    for slot in range(len(level.robots)):
        w.command(slot, 0.08, 0.12)
    steps = round(level.time_limit * level.physics_rate)
    start = time.perf_counter()
    for _ in range(steps):
        w.step()
    return level.time_limit / (time.perf_counter() - start)


def match(level: Level, isolate: bool) -> tuple[float, float]:
    """(simulated s per wall s, referee CPU per simulated s) of a full match, replay written."""
    teams = [resolve("ref:dead-reckoning")] * len(level.robots)
    with tempfile.TemporaryDirectory() as d:
        c0, w0 = cpu(), time.perf_counter()
        r = play_match(level, teams, replay=Path(d) / "m.replay", isolate=isolate)
        wall, used = time.perf_counter() - w0, cpu() - c0
    return r.end_time / wall, used / r.end_time


def measure(level: Level, repeat: int) -> dict:
    """The figures of one world, medians of `repeat` interleaved runs."""
    runs = []
    for _ in range(repeat):
        b = bare(level)
        (inx, incpu), (isx, iscpu) = match(level, False), match(level, True)
        runs.append(
            {"bare_x": b, "in_process_x": inx, "isolated_x": isx, "in_process_cpu": incpu, "isolated_cpu": iscpu}
        )
    out = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    out["in_process_ratio"] = statistics.median(r["in_process_x"] / r["bare_x"] for r in runs)
    out["isolated_ratio"] = statistics.median(r["isolated_x"] / r["bare_x"] for r in runs)
    return out


def scaling(seconds: float, repeat: int) -> dict:
    """{"robots": {N: figures with 4 beacons}, "beacons": {M: figures with 4 robots}}."""
    match(world(1, 4, 2.0), True)  # warm-up, untimed: kernels loaded, the sandbox's template started
    robots = {n: measure(world(n, 4, seconds), repeat) for n in ROBOTS}
    beacons = {m: measure(world(4, m, seconds), repeat) for m in BEACONS}
    return {"robots": robots, "beacons": beacons, "seconds": seconds, "repeat": repeat}


def rows(figures: dict) -> list[tuple[str, str]]:
    """(what, figures) per world, for `make bench`'s table."""
    out = []
    for what, unit in (("robots", "robots, 4 beacons"), ("beacons", "beacons, 4 robots")):
        for n, f in figures[what].items():
            out.append(
                (
                    f"{n} {unit}",
                    f"isolated {f['isolated_ratio']:.2f}, in-process {f['in_process_ratio']:.2f} of bare "
                    f"({f['bare_x']:.0f}x real time)",
                )
            )
    return out


def table(figures: dict) -> str:
    lines = []
    for what, rows in (("robots (4 beacons)", figures["robots"]), ("beacons (4 robots)", figures["beacons"])):
        lines.append(
            f"{what:<20} {'bare x':>9} {'in-process x':>13} {'ratio':>6} {'isolated x':>11} {'ratio':>6} {'referee ms/s':>13}"
        )
        for n, f in rows.items():
            lines.append(
                f"{n:<20} {f['bare_x']:>9.0f} {f['in_process_x']:>13.0f} {f['in_process_ratio']:>6.2f} "
                f"{f['isolated_x']:>11.0f} {f['isolated_ratio']:>6.2f} {1000 * f['isolated_cpu']:>13.1f}"
            )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per match")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = ap.parse_args()
    figures = scaling(args.seconds, args.repeat)
    print(json.dumps(figures, indent=2) if args.json else table(figures))


if __name__ == "__main__":
    main()
