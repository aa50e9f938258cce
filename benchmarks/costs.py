"""Where a match's time goes: a cProfile of one match, summed by area, then the top functions.

Run: python benchmarks/costs.py [LEVEL] [--team SPEC] [--isolate] [--top 25]
Areas: physics (pymunk, the world and its drives), sensing (lasers, crossings, detectors),
referee checks (task progress, rules, scoring), replay (formatting and compression),
exchange (talking to controller processes, waiting included), controllers (their own code,
when they run in this process), numpy's own functions (called from any area), other. Isolated, the controllers' own CPU is in their
processes and shows here only as waiting in the exchange. A first match, not profiled, loads
what a process loads once (the compiled kernels, imports).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
from pathlib import Path

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

AREAS = [
    ("physics", ("pymunk", "_chipmunk", "arena/world.py", "arena/drive.py", "arena/chipmunk.py", "arena/stepping.py")),
    ("sensing", ("arena/sensing/", "arena/angles.py")),
    ("referee checks", ("referee/match/tasks.py", "referee/match/rules.py", "referee/match/estimates.py")),
    (
        "replay",
        (
            "referee/records/replay_writer.py",
            "referee/records/replay_lines.py",
            "gzip",
            "zlib",
            "json/",
            "TextIOWrapper",
        ),
    ),
    ("exchange", ("referee/sandbox/", "robots/_host/protocol.py", "select", "subprocess", "msgspec", "BufferedWriter")),
    ("controllers", ("robots/",)),
]


def area(filename: str, function: str) -> str:
    where = f"{filename}:{function}"
    for name, marks in AREAS:
        if any(m in where for m in marks):
            return name
    return "numpy" if "numpy" in where else "other"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("level", nargs="?", default="asabe-race")
    ap.add_argument("--team", default=None, help="controller for every slot (default: the level's)")
    ap.add_argument("--isolate", action="store_true", help="controllers in their sandboxed processes")
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args()
    level = load_level(levels.path(args.level))
    teams = [resolve(args.team or level.default_controller)] * len(level.robots)
    profile = cProfile.Profile()
    with tempfile.TemporaryDirectory() as d:
        # a first match, unprofiled: loading the compiled kernels and the first imports are a
        # process's cost, not a match's (a grading worker pays them once)
        play_match(level, teams, replay=Path(d) / "warm.replay", isolate=args.isolate)
        profile.enable()
        result = play_match(level, teams, replay=Path(d) / "m.replay", isolate=args.isolate)
        profile.disable()
    stats = pstats.Stats(profile)
    total = sum(v[2] for v in stats.stats.values())  # type: ignore[attr-defined]
    by_area: dict[str, float] = {}
    for (filename, _, function), (_, _, own, _, _) in stats.stats.items():  # type: ignore[attr-defined]
        by_area[area(filename, function)] = by_area.get(area(filename, function), 0.0) + own
    print(f"{args.level}: {result.end_time:.0f} s simulated, {total:.2f} s profiled in this process")
    for name, seconds in sorted(by_area.items(), key=lambda kv: -kv[1]):
        print(f"  {name:<16} {seconds:6.2f} s  {100 * seconds / total:5.1f} %")
    print()
    stats.sort_stats("tottime").print_stats(args.top)


if __name__ == "__main__":
    main()
