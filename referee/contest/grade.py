"""Grading: teams x levels x seeds, headless, resumable, on a local pool or a Dask cluster.

Every match is a job (level, team, seed); the team drives slot 0 and any other slot gets the
level's default controller. A finished match is committed to the SQLite journal at once, so
a killed run resumes where it stopped. A journal row is keyed by everything its result
depends on: the team's code hash, the level file's hash, the seed, the software version and
the noise mode (ideal or not, and which secret) -- so an edited team or level is run again
and an old row never mixes in. Every random stream of a graded match derives from a secret
kept in the journal (or given with --secret), never from anything a controller can read
(docs/integrity.md). Wall time goes to the journal, never into the result.
"""

from __future__ import annotations

import csv
import ctypes
import hashlib
import hmac
import io
import json
import math
import os
import secrets
import signal
import sqlite3
import sys
import time
from collections.abc import Generator, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

from referee.errors import UserError
from referee.terminal import safe

SCHEMA_VERSION = 2
SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS matches (
    level TEXT NOT NULL, level_hash TEXT NOT NULL, team TEXT NOT NULL, code_hash TEXT NOT NULL,
    seed INTEGER NOT NULL, software TEXT NOT NULL, ideal INTEGER NOT NULL, secret_id TEXT NOT NULL,
    result TEXT NOT NULL, replay TEXT NOT NULL, wall_seconds REAL NOT NULL, graded_at REAL NOT NULL,
    PRIMARY KEY (level_hash, team, code_hash, seed, software, ideal, secret_id)
);
"""
KEY = "level_hash, team, code_hash, seed, software, ideal, secret_id"


@dataclass(frozen=True)
class Job:
    """One match to grade. `level_path` is the level file, `team` the spec as given and
    `code_hash` the sha256 of its code when the run began; `noise_key` the match's secret
    noise key (derived from the run's secret, the level and the seed: every team meets the
    same noise on the same level and seed)."""

    level: str
    level_path: str
    level_hash: str
    team: str
    code_hash: str
    seed: int
    software: str
    secret_id: str
    noise_key: str
    ideal: bool = False

    def key(self) -> tuple:
        """The journal key: everything the result depends on."""
        return (self.level_hash, self.team, self.code_hash, self.seed, self.software, int(self.ideal), self.secret_id)

    def replay_name(self) -> str:
        """A readable, unique file name: two teams whose names clean up alike still differ."""
        clean = "".join(c if c.isalnum() or c in "-_." else "_" for c in self.team)[-60:]
        tag = hashlib.sha256(json.dumps(self.key()).encode()).hexdigest()[:12]
        return f"{self.level}__{clean}__seed{self.seed}__{tag}.replay"


def secret_id(secret: str) -> str:
    """A public name for a secret (sha256-based): it tells runs apart, reveals nothing."""
    return hashlib.sha256(b"laserarena-secret-id:" + secret.encode()).hexdigest()[:16]


def noise_key(secret: str, level_hash: str, seed: int) -> str:
    """The per-match noise key: HMAC-SHA256 of the level and seed under the run's secret."""
    return hmac.new(secret.encode(), f"laserarena-noise:{level_hash}:{seed}".encode(), hashlib.sha256).hexdigest()


def play(job: Job, replay_dir: str) -> tuple[Job, str, float]:
    """Run one job (in a worker); return it with its canonical result JSON and wall time."""
    from arena.loader import load_level
    from referee.match.loop import run_match
    from referee.records.canonical import dumps
    from referee.sandbox.teams import resolve

    start = time.perf_counter()
    level = load_level(job.level_path, display=job.level)
    if level.hash != job.level_hash:
        raise UserError(f"{job.level_path}: the level changed while grading; run grade again")
    team = resolve(job.team)
    if team.code_hash != job.code_hash:
        raise UserError(f"{safe(job.team)}: the team's code changed while grading; run grade again")
    teams = [team] + [resolve(level.default_controller)] * (len(level.robots) - 1)
    replay = Path(replay_dir) / job.replay_name()
    global _playing
    try:
        _playing = True
        result = run_match(level, teams, seed=job.seed, replay=replay, ideal=job.ideal, noise_key=job.noise_key)
    except _Stopped:  # the match has stopped its controllers on the way out; leave now, not
        os._exit(143)  # back into the pool's loop (which would wait for work for ever)
    finally:
        _playing = False
    return job, dumps(result), time.perf_counter() - start


def _private_file(path: Path) -> None:
    """Create `path` (0600) unless it exists; tighten it to 0600 if it does."""
    try:
        os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
    except FileExistsError:
        if not path.is_file():
            raise UserError(f"{path}: not a journal file") from None
        os.chmod(path, 0o600)


class Journal:
    """The SQLite journal of finished matches (0600), held by one grading run at a time."""

    def __init__(self, path: Path):
        self.path = path
        try:
            _private_file(path)
            self.lock = open(path, "rb")
        except OSError as e:
            raise UserError(f"{path}: cannot open the journal: {e.strerror or e}") from None
        try:
            import fcntl  # POSIX only: without it (Windows) two runs on one journal are not kept apart

            fcntl.flock(self.lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:
            print(f"laserarena: warning: {path}: no file locks here; run one grading per journal", file=sys.stderr)
        except BlockingIOError:
            raise UserError(f"{path}: another grading run is using this journal") from None
        try:
            self.db = sqlite3.connect(path)
            version = self.db.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if version != SCHEMA_VERSION and tables:
                raise UserError(
                    f"{path}: a journal of another LaserArena version (schema {version}, "
                    f"this is {SCHEMA_VERSION}); grade into a new --db"
                )
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.executescript(SCHEMA)
            self.db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
            self.db.commit()
        except sqlite3.DatabaseError as e:
            raise UserError(f"{path}: not a readable LaserArena journal ({e})") from None

    def _query(self, sql: str, args: tuple = ()) -> list:
        try:
            return self.db.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as e:
            raise UserError(f"{self.path}: a damaged journal ({e})") from None

    def secret(self, given: str | None) -> str:
        """The run's noise secret: `given`, else the journal's own (made on first use with
        `secrets`, kept in the journal so a resumed run draws the same noise)."""
        if given:
            return given
        row = self._query("SELECT value FROM meta WHERE key='secret'")
        if row:
            return row[0][0]
        made = secrets.token_hex(32)
        self.db.execute("INSERT INTO meta VALUES ('secret', ?)", (made,))
        self.db.commit()
        return made

    def done(self) -> set[tuple]:
        return {tuple(r) for r in self._query(f"SELECT {KEY} FROM matches")}

    def record(self, job: Job, result: str, replay: str, wall: float) -> None:
        self.db.execute(
            "INSERT OR REPLACE INTO matches VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (
                job.level,
                job.level_hash,
                job.team,
                job.code_hash,
                job.seed,
                job.software,
                int(job.ideal),
                job.secret_id,
                result,
                replay,
                wall,
                time.time(),
            ),
        )
        self.db.commit()  # at once: a killed run loses nothing that finished

    def results(self, jobs: Iterable[Job]) -> list[tuple[Job, dict]]:
        out = []
        where = " AND ".join(f"{k.strip()}=?" for k in KEY.split(","))
        for job in jobs:
            row = self._query(f"SELECT result FROM matches WHERE {where}", job.key())
            if row:
                try:
                    out.append((job, json.loads(row[0][0])))
                except ValueError:
                    raise UserError(f"{self.path}: a damaged result for {safe(job.team)} seed {job.seed}") from None
        return out


class Progress:
    """A progress bar on stderr (tqdm): matches done, rate and ETA, the match just finished. It
    shows only on a terminal and vanishes when done: a log or a pipe gets no bar lines."""

    def __init__(self, total: int, already: int, quiet: bool):
        from tqdm import tqdm

        self.bar = tqdm(
            total=total,
            initial=already,
            unit="match",
            leave=False,
            file=sys.stderr,
            disable=quiet or not sys.stderr.isatty(),
            dynamic_ncols=True,
        )

    def tick(self, label: str) -> None:
        self.bar.set_postfix_str(safe(label, 40), refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        """Take the bar off the terminal."""
        self.bar.close()


def make_jobs(levels: list, teams: list[tuple[str, str]], seeds: int, secret: str, software: str) -> list[Job]:
    """Every (level, team, seed), in a fixed order; `teams` holds (spec, code hash) pairs."""
    sid = secret_id(secret)
    return [
        Job(lv.name, str(path), lv.hash, spec, code, seed, software, sid, noise_key(secret, lv.hash, seed))
        for lv, path in levels
        for spec, code in teams
        for seed in range(1, seeds + 1)
    ]


def _replay_folder(db: Path) -> Path:
    """The journal's replay folder (0700), cleared of replays a killed run left unfinished."""
    folder = db.resolve().parent / "replays"
    folder.mkdir(mode=0o700, exist_ok=True)
    os.chmod(folder, 0o700)
    for part in folder.glob(".laserarena-*.part"):  # we hold the journal's lock: no run writes these
        part.unlink(missing_ok=True)
    return folder


def grade(
    jobs: list[Job], journal: Journal, workers: int = 1, scheduler: str | None = None, quiet: bool = False
) -> Journal:
    """Run every job not yet in `journal`; replays go to the journal's folder/replays."""
    replay_dir = _replay_folder(journal.path)
    done = journal.done()
    todo = [j for j in jobs if j.key() not in done]
    if not todo:
        return journal
    progress = Progress(len(jobs), len(jobs) - len(todo), quiet)
    results: Generator[tuple[Job, str, float]]  # closed below, so a pool ends on an interrupt
    if scheduler:
        results = _on_dask(todo, str(replay_dir), scheduler)
    elif workers <= 1:
        results = (play(j, str(replay_dir)) for j in todo)
    else:
        results = _on_pool(todo, str(replay_dir), workers)
    try:  # the command line turns SIGTERM into KeyboardInterrupt, as Ctrl-C
        for job, result, wall in results:
            journal.record(job, result, str(replay_dir / job.replay_name()), wall)
            progress.tick(f"{job.level} {job.team} seed {job.seed}")
    finally:
        progress.close()
        results.close()  # a pool's workers end here, even on an interrupt
    return journal


PR_SET_PDEATHSIG = 1
_playing = False  # a pool worker is inside a match


class _Stopped(BaseException):
    """A pool worker was told to stop (SIGTERM) in the middle of a match."""


def _worker_stop(signum: int, frame) -> None:
    if _playing:
        raise _Stopped  # unwinds the match, which ends its controllers; `play` then exits
    os._exit(143)


def _worker_init(parent: int) -> None:
    """In each pool worker: die with the grading process, however it ends (even SIGKILL).
    The kernel sends SIGTERM when the parent goes; SIGTERM ends the match cleanly (its
    controllers are stopped by the match's own clean-up). Ctrl-C is the parent's to handle."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_stop)
    if not sys.platform.startswith("linux"):
        return  # no parent-death signal elsewhere: the pool's own shutdown ends the workers
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    if os.getppid() != parent:  # the parent died before the line above: follow it now
        os._exit(143)


def _on_pool(todo: list[Job], replay_dir: str, workers: int) -> Generator[tuple[Job, str, float]]:
    # spawn, never fork: a forked worker would inherit the parent's state
    pool = ProcessPoolExecutor(
        max_workers=workers, mp_context=get_context("spawn"), initializer=_worker_init, initargs=(os.getpid(),)
    )
    try:
        futures = [pool.submit(play, j, replay_dir) for j in todo]
        for f in as_completed(futures):
            yield f.result()
    except BaseException:
        # stop now, not after the running matches: end the workers (each stops its match)
        for proc in list(getattr(pool, "_processes", {}).values()):
            proc.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


SCHEDULER_TIMEOUT = "10s"  # a scheduler that does not answer by then is a bad --scheduler


def _on_dask(todo: list[Job], replay_dir: str, scheduler: str) -> Generator[tuple[Job, str, float]]:
    try:
        from dask.distributed import Client
        from dask.distributed import as_completed as dask_completed
    except ImportError:
        raise UserError("--scheduler needs Dask: pip install 'laserarena[dask]'") from None
    try:
        client = Client(scheduler, timeout=SCHEDULER_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as e:
        raise UserError(
            f"--scheduler {scheduler}: cannot reach the Dask scheduler ({' '.join(str(e).split()) or type(e).__name__})"
        ) from None
    with client:
        futures = [client.submit(play, j, replay_dir, pure=False) for j in todo]
        for f in dask_completed(futures):
            yield f.result()


# ---- the leaderboard --------------------------------------------------------------------

T975 = [
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
]  # Student's t, 97.5 %, df = 1..30


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
        rows.append(
            {
                "team": team,
                "level": level,
                "matches": len(robots),
                "score_mean": round(mean, 3),
                "score_ci95": round(half, 3),
                "task_mean": round(sum(r["score"]["task"] for r in robots) / len(robots), 3),
                "position_rms_mm": round(1000 * sum(rms) / len(rms), 3) if rms else None,
                "fouls": sum(len(r["fouls"]) for r in robots),
                "faults": sum(len(r["faults"]) for r in robots),
            }
        )
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
    md = [
        "| level | team | matches | score (mean ± 95 %) | task | position RMS mm | fouls | faults |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        rms = "-" if r["position_rms_mm"] is None else f"{r['position_rms_mm']:.1f}"
        team = safe(r["team"]).replace("|", "\\|")
        md.append(
            f"| {r['level']} | {team} | {r['matches']} | {r['score_mean']:.1f} ± {r['score_ci95']:.1f} "
            f"| {r['task_mean']:.1f} | {rms} | {r['fouls']} | {r['faults']} |"
        )
    text = "\n".join(md) + "\n"
    out.with_suffix(".md").write_text(text)
    return text
