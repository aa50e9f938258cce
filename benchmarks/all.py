"""`make bench`: every speed figure of LaserArena on this machine, side by side, in one run.

(a) the 4-robot asabe-race world: bare pymunk stepping vs a full match (isolated reference
    controllers, sensing, referee, recording), simulated seconds per wall second;
(b) localization solvers, scalar and vectorized; (c) rendering and encoding frames per second;
(d) grading throughput. Prints a table and writes the figures as JSON (--json).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import grading
import render
import sensing
import solvers

import levels
from arena.loader import load_level
from referee.match.loop import run_match
from referee.sandbox.teams import resolve


def world_vs_match() -> dict:
    """asabe-race: bare stepping vs the full isolated match, simulated s per wall s."""
    level = load_level(levels.path("asabe-race"))
    bare_wall, _ = sensing.run(level.time_limit, False)
    teams = [resolve(level.default_controller)] * len(level.robots)
    with tempfile.TemporaryDirectory() as d:
        start = time.perf_counter()
        result = run_match(level, teams, replay=Path(d) / "m.replay")
        full_wall = time.perf_counter() - start
    bare = level.time_limit / bare_wall
    full = result["end_time"] / full_wall
    return {"bare_x": bare, "match_x": full, "ratio": full / bare, "simulated_s": result["end_time"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="OUT", help="write the figures here as JSON")
    args = ap.parse_args()
    t0 = time.perf_counter()
    figures = {
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()}
    }
    figures["world"] = world_vs_match()
    figures["solvers"] = solvers.measure()
    figures["render"] = render.measure(300)
    figures["grading"] = grading.measure(4)
    w, s, r, g = figures["world"], figures["solvers"], figures["render"], figures["grading"]
    rows = [
        ("(a) asabe-race bare stepping", f"{w['bare_x']:.0f}x real time", ""),
        (
            "(a) asabe-race full match, isolated",
            f"{w['match_x']:.0f}x real time",
            f"{w['ratio']:.2f} of bare (target >= 0.5)",
        ),
        ("(b) ToTal scalar", f"{s['total_scalar_us']:.2f} us/call", "target < 3 us"),
        ("(b) ToTal vectorized", f"{s['total_vectorized_per_s'] / 1e6:.1f} M solves/s", "target >= 10 M/s"),
        ("(c) render 960x640", f"{r['draw_fps']:.0f} frames/s", ""),
        ("(c) encode H.264 960x640", f"{r['encode_fps']:.0f} frames/s", "target >= 100"),
        ("(d) grading: CPU per 180 s match", f"{g['cpu_per_match_s']:.2f} s", "target < 2 s"),
        (
            "(d) grading throughput",
            f"{g['per_hour_all']:.0f} matches/h on {g['workers']} workers",
            f"{g['speedup']:.2f}x of one worker",
        ),
    ]
    width = max(len(a) for a, _, _ in rows)
    print(f"LaserArena benchmarks on {figures['machine']['cpus']} CPUs, Python {figures['machine']['python']}")
    for a, b, c in rows:
        print(f"  {a:<{width}}  {b:<28} {c}")
    figures["seconds"] = time.perf_counter() - t0
    print(f"  ({figures['seconds']:.0f} s)")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
