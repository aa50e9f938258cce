"""Grading: teams x levels x seeds, headless, resumable, on a local pool or a Dask cluster.

Every match is a job (level, team, seed); the team drives slot 0 and any other slot gets the
level's default controller. A finished match is committed to the SQLite journal at once, so
a killed run resumes where it stopped: jobs already in the journal are not run again. The
result of a job depends only on the job, never on the number of workers or their order.
Wall time goes to the journal, never into the result.
"""

from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Iterable

from referee.errors import UserError

SCHEMA = """
CREATE TABLE IF NOT EXISTS matches (
    level TEXT NOT NULL, level_hash TEXT NOT NULL, team TEXT NOT NULL, seed INTEGER NOT NULL,
    result TEXT NOT NULL, replay TEXT NOT NULL, wall_seconds REAL NOT NULL, graded_at REAL NOT NULL,
    PRIMARY KEY (level_hash, team, seed)
)
"""


@dataclass(frozen=True)
class Job:
    """One match to grade; `level_path` is the level file, `team` the spec as given."""

    level: str
    level_path: str
    level_hash: str
    team: str
    seed: int

    def replay_name(self) -> str:
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in self.team)
        return f"{self.level}__{safe}__seed{self.seed}.replay"


def play(job: Job, replay_dir: str) -> tuple[Job, str, float]:
    """Run one job (in a worker); return it with its canonical result JSON and wall time."""
    from arena.loader import load_level
    from referee.records.canonical import dumps
    from referee.match.loop import run_match
    from referee.sandbox.teams import resolve

    start = time.perf_counter()
    level = load_level(job.level_path, display=job.level)
    teams = [resolve(job.team)] + [resolve(level.default_controller)] * (len(level.robots) - 1)
    replay = Path(replay_dir) / job.replay_name()
    result = run_match(level, teams, seed=job.seed, replay=replay)
    return job, dumps(result), time.perf_counter() - start


class Journal:
    """The SQLite journal of finished matches."""

    def __init__(self, path: Path):
        self.db = sqlite3.connect(path)
        self.db.execute("PRAGMA journal_mode=WAL")
        self.db.execute(SCHEMA)
        self.db.commit()

    def done(self) -> set[tuple[str, str, int]]:
        return {tuple(r) for r in self.db.execute("SELECT level_hash, team, seed FROM matches")}

    def record(self, job: Job, result: str, replay: str, wall: float) -> None:
        self.db.execute("INSERT OR REPLACE INTO matches VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                        (job.level, job.level_hash, job.team, job.seed, result, replay, wall, time.time()))
        self.db.commit()  # at once: a killed run loses nothing that finished

    def results(self, jobs: Iterable[Job]) -> list[tuple[Job, dict]]:
        out = []
        for job in jobs:
            row = self.db.execute("SELECT result FROM matches WHERE level_hash=? AND team=? AND seed=?",
                                  (job.level_hash, job.team, job.seed)).fetchone()
            if row:
                out.append((job, json.loads(row[0])))
        return out


class Progress:
    """A one-line progress bar on stderr: matches done, rate and ETA."""

    def __init__(self, total: int, already: int, quiet: bool):
        self.total, self.done, self.quiet = total, already, quiet
        self.start = time.monotonic()
        self.fresh = 0

    def tick(self, label: str) -> None:
        self.done += 1
        self.fresh += 1
        if self.quiet:
            return
        elapsed = time.monotonic() - self.start
        rate = self.fresh / elapsed if elapsed > 0 else 0.0
        left = (self.total - self.done) / rate if rate else 0.0
        width = 24
        filled = round(width * self.done / self.total) if self.total else width
        bar = "#" * filled + "." * (width - filled)
        end = "\n" if self.done == self.total or not sys.stderr.isatty() else ""
        print(f"\r[{bar}] {self.done}/{self.total} matches  {rate * 60:.1f}/min  ETA {left:4.0f} s  {label[:40]:<40}",
              end=end, file=sys.stderr, flush=True)


def make_jobs(levels: list, teams: list[str], seeds: int) -> list[Job]:
    """Every (level, team, seed), in a fixed order."""
    return [Job(lv.name, str(path), lv.hash, team, seed)
            for lv, path in levels for team in teams for seed in range(1, seeds + 1)]


def grade(jobs: list[Job], db: Path, workers: int = 1, scheduler: str | None = None,
          quiet: bool = False) -> Journal:
    """Run every job not yet in the journal at `db`; replays go to `db`'s folder/replays."""
    journal = Journal(db)
    replay_dir = db.resolve().parent / "replays"
    replay_dir.mkdir(exist_ok=True)
    done = journal.done()
    todo = [j for j in jobs if (j.level_hash, j.team, j.seed) not in done]
    progress = Progress(len(jobs), len(jobs) - len(todo), quiet)
    if not todo:
        return journal
    if scheduler:
        results = _on_dask(todo, str(replay_dir), scheduler)
    elif workers <= 1:
        results = (play(j, str(replay_dir)) for j in todo)
    else:
        results = _on_pool(todo, str(replay_dir), workers)
    for job, result, wall in results:
        journal.record(job, result, str(replay_dir / job.replay_name()), wall)
        progress.tick(f"{job.level} {job.team} seed {job.seed}")
    return journal


def _on_pool(todo: list[Job], replay_dir: str, workers: int):
    # spawn, never fork: a forked worker would inherit the parent's state
    with ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        futures = [pool.submit(play, j, replay_dir) for j in todo]
        for f in as_completed(futures):
            yield f.result()


def _on_dask(todo: list[Job], replay_dir: str, scheduler: str):
    try:
        from dask.distributed import Client, as_completed as dask_completed
    except ImportError:
        raise UserError("--scheduler needs Dask: pip install 'laserarena[dask]'") from None
    with Client(scheduler) as client:
        futures = [client.submit(play, j, replay_dir, pure=False) for j in todo]
        for f in dask_completed(futures):
            yield f.result()


# ---- the leaderboard --------------------------------------------------------------------

T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042]  # Student's t, 97.5 %, df = 1..30


def interval(values: list[float]) -> tuple[float, float]:
    """Mean and the half-width of its 95 % confidence interval (0 for a single value)."""
    n = len(values)
    mean = sum(values) / n
    if n < 2:
        return mean, 0.0
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
    t = T975[n - 2] if n - 1 <= len(T975) else 1.96
    return mean, t * sd / math.sqrt(n)


def leaderboard(journal: Journal, jobs: list[Job]) -> list[dict]:
    """One row per (team, level): mean score over seeds with its 95 % interval, and more."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for job, result in journal.results(jobs):
        groups.setdefault((job.team, job.level), []).append(result["robots"][0])
    rows = []
    for (team, level), robots in groups.items():
        mean, half = interval([r["score"]["total"] for r in robots])
        rms = [r["localization"]["position_rms"] for r in robots if r["localization"]["position_rms"] is not None]
        rows.append({
            "team": team, "level": level, "matches": len(robots),
            "score_mean": round(mean, 3), "score_ci95": round(half, 3),
            "task_mean": round(sum(r["score"]["task"] for r in robots) / len(robots), 3),
            "position_rms_mm": round(1000 * sum(rms) / len(rms), 3) if rms else None,
            "fouls": sum(len(r["fouls"]) for r in robots),
            "faults": sum(len(r["faults"]) for r in robots),
        })
    rows.sort(key=lambda r: (r["level"], -r["score_mean"], r["team"]))
    return rows


def write_leaderboard(rows: list[dict], out: Path) -> str:
    """Write CSV (out), JSON and Markdown beside it; return the Markdown table."""
    fields = list(rows[0]) if rows else ["team", "level"]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    out.write_text(buf.getvalue())
    out.with_suffix(".json").write_text(json.dumps(rows, indent=2, sort_keys=True) + "\n")
    md = ["| level | team | matches | score (mean ± 95 %) | task | position RMS mm | fouls | faults |",
          "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        rms = "-" if r["position_rms_mm"] is None else f"{r['position_rms_mm']:.1f}"
        md.append(f"| {r['level']} | {r['team']} | {r['matches']} | {r['score_mean']:.1f} ± {r['score_ci95']:.1f} "
                  f"| {r['task_mean']:.1f} | {rms} | {r['fouls']} | {r['faults']} |")
    text = "\n".join(md) + "\n"
    out.with_suffix(".md").write_text(text)
    return text

