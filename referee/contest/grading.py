"""Grading: teams x levels x seeds, headless, resumable, on a local pool or a Dask cluster.

Every match is a job (level, team, seed); the team drives slot 0 and any other slot gets the
level's default controller. A finished match is committed to the SQLite journal at once, so
a killed run resumes where it stopped. A journal row is keyed by everything its result
depends on: the team's code hash, the level file's hash, the seed, the software version and
the noise mode (ideal or not, and which secret) -- so an edited team or level is run again
and an old row never mixes in. Every random stream of a graded match derives from a secret
kept in the journal (or read from --secret-file), never from anything a controller can read
(docs/integrity.md). Wall time goes to the journal, never into the result.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from referee.contest.audit import AuditFailed
from referee.contest.dispatch import run_jobs
from referee.contest.journal import Journal
from referee.contest.noise_secret import noise_key, secret_id
from referee.contest.runner import MatchJob, file_part, replay_folder, write_replay
from referee.errors import UserError
from referee.records.faults import summary
from referee.sandbox.teams import Team, resolve
from referee.terminal import Progress, csv_text, markdown_text, safe

if TYPE_CHECKING:
    from levels.model import Level
    from referee.contest.cluster import Cluster


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
        tag = hashlib.sha256(json.dumps(self.key()).encode()).hexdigest()[:12]
        return f"{file_part(self.level[:60])}__{file_part(self.team[-60:])}__seed{self.seed}__{tag}.replay"


def make_jobs(levels: list, teams: list[tuple[str, str]], seeds: int, secret: str, software: str) -> list[Job]:
    """Every (level, team, seed), in a fixed order; `teams` holds (spec, code hash) pairs."""
    sid = secret_id(secret)
    return [
        Job(lv.name, str(path), lv.hash, spec, code, seed, software, sid, noise_key(secret, lv.hash, seed))
        for lv, path in levels
        for spec, code in teams
        for seed in range(1, seeds + 1)
    ]


def _match_jobs(jobs: list[Job], known: Sequence[Team], unsandboxed: bool) -> dict[tuple, MatchJob]:
    """Each job as data a worker can play anywhere: the level file's bytes and every slot's code
    (the team in slot 0, the level's default controller in the others). The `known` teams are
    shipped as resolved (their files read once, when the jobs were made); any other is
    resolved here, once, and checked against the hash its jobs were made with."""
    from levels.loader import parse_level

    texts: dict[str, tuple[bytes, Level]] = {}
    teams = {t.spec: t for t in known}

    def team(spec: str, expected: str | None = None) -> Team:
        if spec not in teams:
            teams[spec] = resolve(spec)
        if expected is not None and teams[spec].code_hash != expected:
            raise UserError(f"{safe(spec)}: the team's code changed while grading; run grade again")
        return teams[spec]

    out = {}
    for job in jobs:
        if job.level_path not in texts:
            data = Path(job.level_path).read_bytes()
            texts[job.level_path] = (data, parse_level(data, job.level))
        data, level = texts[job.level_path]
        if level.hash != job.level_hash:
            raise UserError(f"{job.level_path}: the level changed while grading; run grade again")
        slots = len(level.robots)
        lineup = (team(job.team, job.code_hash),) + (team(level.default_controller),) * (slots - 1)
        out[job.key()] = MatchJob(
            job.level, data, job.level_hash, lineup, job.seed, job.noise_key, job.ideal, job.software, unsandboxed
        )
    return out


def grade_jobs(
    jobs: list[Job],
    journal: Journal,
    workers: int = 1,
    cluster: Cluster | None = None,
    quiet: bool = False,
    teams: Sequence[Team] = (),
    unsandboxed: bool = False,
) -> int:
    """Run every job not yet in `journal`, on `workers` local processes or on `cluster`, and
    return how many ran now; replays go to the journal's folder/replays. Workers return each
    match's result and replay; only this process writes them. `teams`: the jobs' teams as
    resolved when they were made (any other is resolved here); `unsandboxed`: the organizer
    allows matches without a kernel sandbox (the journal then records it, as it records an
    insecure cluster). A worker that fails its audit: its results of this run are removed
    again, and AuditFailed goes on up."""
    replay_dir = replay_folder(journal.path)
    done = journal.done()
    todo = [j for j in jobs if j.key() not in done]
    if not todo:
        return 0
    by_key = {j.key(): j for j in todo}
    playable = _match_jobs(todo, teams, unsandboxed)
    progress = Progress(len(jobs), "match", quiet, already=len(jobs) - len(todo))
    if cluster is not None and cluster.insecure:
        journal.note_insecure_cluster(cluster.address)
    results = run_jobs([(k, playable[k]) for k in by_key], workers, cluster)
    try:  # the command line turns SIGTERM into KeyboardInterrupt, as Ctrl-C
        for key, played in results:
            job = by_key[key]
            replay = write_replay(replay_dir, job.replay_name(), played.replay)
            if played.unsandboxed:
                journal.note_unsandboxed(played.unsandboxed)
            journal.record(job, played.result, str(replay), played.wall)
            progress.tick(f"{job.level} {job.team} seed {job.seed}")
    except AuditFailed as failed:
        journal.forget(failed.discard)
        for key in failed.discard:
            (replay_dir / by_key[key].replay_name()).unlink(missing_ok=True)
        raise
    finally:
        progress.close()
        results.close()  # a pool's workers end here, even on an interrupt
    return len(todo)


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


def leaderboard_rows(journal: Journal, jobs: list[Job]) -> list[dict]:
    """One row per (team, level): mean score over seeds with its 95 % interval, and more;
    `fault_summary` tells its faults by kind, each kind's first message and line of code."""
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
                "position_rms": round(sum(rms) / len(rms), 6) if rms else None,
                "fouls": sum(len(r["fouls"]) for r in robots),
                "faults": sum(len(r["faults"]) for r in robots),
                "fault_summary": summary(f for r in robots for f in r["faults"]),
            }
        )
    rows.sort(key=lambda r: (r["level"], -r["score_mean"], r["team"]))
    return rows


def write_leaderboard(rows: list[dict], out: Path, notes: Sequence[str] = ()) -> str:
    """Write CSV (out), JSON and Markdown beside it; return the Markdown table (and `notes`)."""
    fields = list(rows[0]) if rows else ["team", "level"]
    out.write_text(csv_text(fields, [[r[f] for f in fields] for r in rows]))
    out.with_suffix(".json").write_text(json.dumps(rows, indent=2, sort_keys=True) + "\n")
    text = markdown(rows, notes)
    out.with_suffix(".md").write_text(text)
    return text


def markdown(rows: list[dict], notes: Sequence[str] = ()) -> str:
    """The leaderboard as a Markdown table (what `laserarena grade` prints; its faults column
    tells them by kind), then each of `notes` (a team refused, matches played without a
    sandbox) on a line of its own."""
    md = [
        "| level | team | matches | score (mean ± 95 %) | task | position RMS mm | fouls | faults |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        rms = "-" if r["position_rms"] is None else f"{1000 * r['position_rms']:.1f}"
        md.append(
            f"| {markdown_text(r['level'])} | {markdown_text(r['team'])} | {r['matches']} "
            f"| {r['score_mean']:.1f} ± {r['score_ci95']:.1f} "
            f"| {r['task_mean']:.1f} | {rms} | {r['fouls']} | {markdown_text(r['fault_summary'], 400) or 0} |"
        )
    md += [f"\nNote: {markdown_text(note, 500)}" for note in notes]
    return "\n".join(md) + "\n"
