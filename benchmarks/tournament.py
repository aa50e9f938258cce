"""Tournament overhead on this machine: what scheduling, rating and the report cost beside
the heats themselves.

Run: python benchmarks/tournament.py [--rounds 1] [--workers 2]
Plays a real tournament of four reference teams on asabe-race (180 s heats, isolated
controllers) into a scratch journal, timing each stage in the same run, then times the
schedule and the ratings alone for a large synthetic field (32 teams, 10 rounds: 320 heats).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import levels
from levels.loader import load_level
from referee.contest import report
from referee.contest import tournaments as t
from referee.contest.journal import Journal
from referee.contest.ratings import Placing, ranks, rate
from referee.contest.schedule import schedule
from referee.media.viewer import write_viewer
from referee.sandbox.teams import resolve
from referee.version import __version__

TEAMS = ["ref:bac", "ref:starter", "ref:dead-reckoning", "ref:idle"]


def real(rounds: int, workers: int) -> dict:
    """Seconds spent in each stage of a real tournament, and the heats' own time."""
    path = levels.path("asabe-race")
    found = [(load_level(path), path)]
    with tempfile.TemporaryDirectory() as d:
        journal = Journal(Path(d) / "t.sqlite")
        teams = t.entrants([resolve(s) for s in TEAMS])
        c0 = time.perf_counter()
        heats = t.plan(found, teams, rounds, journal.secret(None), __version__)
        c1 = time.perf_counter()
        t.play_heats(heats, found, journal, workers=workers, quiet=True)
        c2 = time.perf_counter()
        outcome = t.outcome(heats, teams, journal)
        c3 = time.perf_counter()
        report.write(outcome, Path(d) / "out", "benchmark")
        c4 = time.perf_counter()
        for h in outcome.heats:
            write_viewer(Path(d) / "out" / report.replay_file(h), Path(d) / "out" / report.viewer_file(h))
        c5 = time.perf_counter()
    return {
        "heats": len(heats),
        "workers": workers,
        "plan_s": c1 - c0,
        "play_wall_s": c2 - c1,
        "heat_own_s": sum(h.wall for h in outcome.heats),
        "rate_s": c3 - c2,
        "report_s": c4 - c3,
        "viewers_s": c5 - c4,
    }


def synthetic(teams: int = 32, slots: int = 4, rounds: int = 10) -> dict:
    """Schedule and rating time for a large field with random scores (no matches run)."""
    c0 = time.perf_counter()
    heats = schedule(teams, slots, rounds)
    c1 = time.perf_counter()
    rng = np.random.default_rng(1)
    placed = []
    for h in heats:
        scores = [float(s) for s in rng.normal(50, 20, slots)]
        placed.append([Placing(e.team, s, r) for e, s, r in zip(h.entries, scores, ranks(scores))])
    c2 = time.perf_counter()
    rate(teams, placed)
    c3 = time.perf_counter()
    return {"teams": teams, "heats": len(heats), "schedule_s": c1 - c0, "rate_s": c3 - c2}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    a = ap.parse_args()
    r = real(a.rounds, a.workers)
    n = r["heats"]
    overhead = r["plan_s"] + r["rate_s"]
    print(f"tournament: 4 reference teams on asabe-race (180 s heats), {n} heats on {r['workers']} workers")
    print(f"  heats' own time          {r['heat_own_s'] / n:8.2f} s per heat ({r['play_wall_s']:.1f} s wall for all)")
    print(
        f"  scheduling + rating      {1000 * overhead / n:8.2f} ms per heat "
        f"({100 * overhead / r['heat_own_s']:.3f} % of the heats' own time)"
    )
    print(f"  report files             {1000 * r['report_s'] / n:8.2f} ms per heat")
    print(f"  viewer pages             {1000 * r['viewers_s'] / n:8.2f} ms per heat")
    s = synthetic()
    print(
        f"synthetic: {s['teams']} teams, {s['heats']} heats: schedule {1000 * s['schedule_s'] / s['heats']:.2f} ms "
        f"per heat, rating {1000 * s['rate_s'] / s['heats']:.2f} ms per heat"
    )


if __name__ == "__main__":
    main()
