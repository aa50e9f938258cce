"""`make bench`: every speed figure of LaserArena on this machine, side by side, in one run.

(a) the 4-robot asabe-race world: bare stepping, sensing, full matches isolated and in-process
    with two controllers, grading's CPU beside bare stepping's (benchmarks/speed.py);
(b) localization solvers, scalar and vectorized; (c) rendering and encoding frames per second;
(d) grading throughput. Prints a table and writes the figures as JSON (--json).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import grading
import render
import solvers
import speed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="OUT", help="write the figures here as JSON")
    ap.add_argument("--repeat", type=int, default=3, help="runs per speed figure (the median is kept)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    figures = {
        "machine": {
            "cpus": os.cpu_count(),
            "cpu": speed.cpu_model(),
            "python": platform.python_version(),
            "platform": platform.platform(),
        }
    }
    figures["speed"] = speed.measure(args.repeat)
    figures["solvers"] = solvers.measure()
    figures["render"] = render.measure(300)
    figures["grading"] = grading.measure(8)  # enough matches that each pool worker's start (imports, numba) is spread
    s, r, g = figures["solvers"], figures["render"], figures["grading"]
    rows = [(f"(a) {a.strip()}", b, c) for a, b, c in speed.table(figures["speed"])]
    rows += [
        ("(b) ToTal scalar", f"{s['total_scalar_us']:.2f} us/call", "target < 3 us"),
        ("(b) ToTal vectorized", f"{s['total_vectorized_per_s'] / 1e6:.1f} M solves/s", "target >= 10 M/s"),
        ("(c) render 960x640", f"{r['draw_fps']:.0f} frames/s", ""),
        ("(c) encode H.264 960x640", f"{r['encode_fps']:.0f} frames/s", "target >= 100"),
        ("(d) grading: CPU per asabe match", f"{g['cpu_per_match_s']:.2f} s", "the match ends when ASABE is drawn"),
        (
            "(d) grading throughput",
            f"{g['per_hour_all']:.0f} matches/h on {g['workers']} workers",
            f"{g['speedup']:.2f}x of one worker",
        ),
    ]
    width = max(len(a) for a, _, _ in rows)
    m = figures["machine"]
    print(f"LaserArena benchmarks on {m['cpus']} x {m['cpu']}, Python {m['python']} (medians of {args.repeat} runs)")
    for a, b, c in rows:
        print(f"  {a:<{width}}  {b:<28} {c}")
    figures["seconds"] = time.perf_counter() - t0
    print(f"  ({figures['seconds']:.0f} s)")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
