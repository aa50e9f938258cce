"""Grading throughput on this machine: `asabe` with its reference controller (ref:bac).

Run: python benchmarks/grading.py [--matches 6]
Prints the CPU seconds one 180 s match costs (referee and controller processes, isolation
included) and matches per hour with one worker and with the local pool (all cores).
Targets (issue 6): under 2 s of CPU per 180 s match (over 90x real time), near-linear scaling.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from speed import machine_cpu

import levels
from levels.loader import load_level
from referee.contest import grading as g
from referee.sandbox.teams import resolve
from referee.version import __version__


def run(matches: int, workers: int) -> tuple[float, float]:
    """Wall and CPU seconds to grade `matches` seeds of asabe."""
    path = levels.path("asabe")
    team = resolve("ref:bac")
    with tempfile.TemporaryDirectory() as d:
        journal = g.Journal(Path(d) / "bench.sqlite")
        jobs = g.make_jobs(
            [(load_level(path), path)], [(team.spec, team.code_hash)], matches, journal.secret(None), __version__
        )
        c0, w0 = machine_cpu(), time.perf_counter()
        g.grade_jobs(jobs, journal, workers=workers, quiet=True)
        return time.perf_counter() - w0, machine_cpu() - c0


def measure(n: int = 6) -> dict:
    """CPU per 180 s match, and matches per hour on one worker and on every core."""
    wall1, cpu1 = run(n, 1)
    workers = os.cpu_count() or 1
    wall_k, _ = run(n, workers)
    return {
        "matches": n,
        "cpu_per_match_s": cpu1 / n,
        "per_hour_1": 3600 * n / wall1,
        "workers": workers,
        "per_hour_all": 3600 * n / wall_k,
        "speedup": wall1 / wall_k,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matches", type=int, default=6)
    m = measure(ap.parse_args().matches)
    print(f"grading asabe (180 s matches, ref:bac, isolated), {m['matches']} matches")
    print(
        f"  CPU per match            {m['cpu_per_match_s']:8.2f} s   ({180 / m['cpu_per_match_s']:.0f}x real time; target < 2 s)"
    )
    print(f"  1 worker                 {m['per_hour_1']:8.0f} matches/hour")
    print(
        f"  {m['workers']} workers                {m['per_hour_all']:8.0f} matches/hour   "
        f"(speed-up {m['speedup']:.2f}x on {m['workers']} cores)"
    )


if __name__ == "__main__":
    main()
