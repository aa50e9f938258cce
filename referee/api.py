"""The Python API: `referee.run_match`, `referee.grade` and `referee.tournament`, for scripts
and notebooks; the command line's `run`, `grade` and `tournament` call the same code.

A team is a spec string (as on the command line) or a Controller class. An isolated match
ships a class's SOURCE into the sandbox, never the live object (`referee.sandbox.class_source`).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from levels.loader import find_level, load_level
from levels.model import Level
from referee.errors import TeamError, UserError
from referee.records.results import MatchResult
from referee.sandbox.class_source import class_team
from referee.sandbox.process import isolation_unavailable
from referee.sandbox.teams import Team, controller_problem, resolve
from referee.terminal import safe

if TYPE_CHECKING:
    from referee.contest.cluster import Cluster
    from referee.contest.journal import Journal


def _level(level: str | Path | Level) -> Level:
    if isinstance(level, Level):
        return level
    if isinstance(level, Path):
        return load_level(level, controllers=controller_problem)
    if isinstance(level, str):
        return find_level(level, controllers=controller_problem)
    raise UserError(f"level must be a name, a path or a Level, got {type(level).__name__}")


def run_match(
    level: str | Path | Level,
    teams: Sequence[str | type] | None = None,
    seed: int | None = None,
    ideal: bool = False,
    isolate: bool = True,
    replay: str | Path | None = None,
    logs: str | Path | None = None,
    limits: bool = True,
) -> MatchResult:
    """Run one match and return its typed result (`r.robots[0].score.total`); `laserarena run`
    is this call.

    `level`: a built-in name, a YAML path or a Level; `teams`: one per slot, in order, each a
    spec string (`ref:NAME`, `FILE.py[:Class]`, `DIR[:Class]`, `module:Class`) or a Controller
    class; slots left over get the level's default controller. `isolate=False` runs the
    controllers in this process (a debugger can stop in them); `limits=False` lifts their time
    and memory limits (debugging)."""
    from referee.match.fleet import NO_LIMITS
    from referee.match.loop import play_match  # the match loop loads pymunk: only when called

    lv = _level(level)
    check_seed(seed)
    given = list(teams or [])
    if len(given) > len(lv.robots):
        raise TeamError(f"{lv.name}: {len(given)} teams for {len(lv.robots)} robot slot(s)")
    given += [lv.default_controller] * (len(lv.robots) - len(given))
    folder = None  # where Controller classes are shipped as source, made only for them
    try:
        resolved = []
        for t in given:
            if isinstance(t, str):
                resolved.append(resolve(t))
                continue
            if folder is None:
                folder = Path(tempfile.mkdtemp(prefix="laserarena-api-"))
                folder.chmod(0o755)  # the controller, another user, reads the shipped source
            ship = isolate and isolation_unavailable() is None  # else the match warns and runs them here
            resolved.append(class_team(t, ship, folder))
        if logs is not None:
            Path(logs).mkdir(parents=True, exist_ok=True)
        return play_match(
            lv,
            resolved,
            seed=seed,
            replay=replay,
            ideal=ideal,
            isolate=isolate,
            limits=None if limits else NO_LIMITS,
            logs=Path(logs) if logs is not None else None,
        )
    finally:
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)


def check_seed(seed: object, name: str = "seed") -> None:
    """A match seed is a whole number >= 0 (None: the level's own); UserError naming it as
    `name` (the command line's `--seed`) otherwise."""
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise UserError(f"{name} {seed!r}: a seed is a whole number >= 0")


# ---- grading and tournaments ---------------------------------------------------------------

Levels = str | Path | Sequence[str | Path]
Teams = Sequence[str | type]
CLASS_TEAMS = "class-teams"  # beside a journal: the source each Controller class team ran as


@dataclass(frozen=True)
class LeaderboardRow:
    """A team's line on one level of a grade: matches, mean score with the half-width of its
    95 % interval, mean task progress, mean position RMS (m, None without estimates), fouls
    and faults, and the faults told by kind (each kind's count, first message and the team's
    file and line: "1 exception: in step: KeyError: 'pose' (bot.py:12)"; "" for none). The
    fields are leaderboard.csv's columns."""

    team: str
    level: str
    matches: int
    score_mean: float
    score_ci95: float
    task_mean: float
    position_rms: float | None
    fouls: int
    faults: int
    fault_summary: str = ""


@dataclass(frozen=True)
class LevelFigure:
    """A team's heats on one level of a tournament: their number, mean score and 95 % bootstrap interval."""

    level: str
    heats: int
    mean_score: float
    low: float
    high: float


@dataclass(frozen=True)
class StandingRow:
    """A team's line in a tournament's standings (standings.csv): rank, name, rating (mu - 3
    sigma), mu, sigma, heats played, mean score over them, its figures per level, and its
    faults told by kind, with each kind's first message and the team's file and line ("" for
    none). Where no rating can be formed (one team alone, or every heat a tie: the result's
    notes say which) rating, mu and sigma are None and the teams are ranked by mean score."""

    rank: int
    team: str
    rating: float | None
    mu: float | None
    sigma: float | None
    heats: int
    mean_score: float
    levels: tuple[LevelFigure, ...]
    faults: str = ""


@dataclass(frozen=True)
class HeatRow:
    """One robot in one heat (a heats.csv row): heat number, level, seed, slot, team, its rank
    and score in the heat, and whether it was a filler (the level's default controller, unrated)."""

    heat: int
    level: str
    seed: int
    slot: int
    team: str
    rank: int
    score: float
    filler: bool


@dataclass(frozen=True)
class TournamentResult:
    """A tournament's standings (best first) and every robot of every heat (heat and slot
    order); `ran` heats were played by this call, the others came from the journal. Times in
    seconds: the heats' own, scheduling and rating, and writing the report. `notes`: what the
    report says beside the standings (teams refused, heats played without a kernel sandbox,
    why no rating could be formed)."""

    standings: tuple[StandingRow, ...]
    heats: tuple[HeatRow, ...]
    ran: int
    heat_seconds: float
    overhead_seconds: float
    report_seconds: float
    notes: tuple[str, ...] = ()


def contest_levels(levels: Levels) -> list[tuple[Level, Path]]:
    """Each level (a built-in name or a YAML path) loaded, with its file (one line on a bad one)."""
    import levels as built_in

    names = [levels] if isinstance(levels, (str, Path)) else list(levels)
    if not names:
        raise UserError("give at least one level")
    found = []
    for name in names:
        if not isinstance(name, (str, Path)):
            raise UserError(f"a contest level is a name or a path, got {type(name).__name__}")
        lv = find_level(str(name), controllers=controller_problem)
        path = Path(name) if Path(name).is_file() else built_in.path(str(name))
        found.append((lv, path.resolve()))
    return found


def _contest_team(team: str | type, db: Path) -> Team:
    """One contest team resolved (TeamError in one line). A Controller class is shipped as
    source into `class-teams/` beside the journal, under a name from its code hash, so a rerun
    of the same class resumes and the journal's rows name code that is kept."""
    if isinstance(team, str):
        return resolve(team)
    _outputs(db, None)
    folder = db.resolve().parent / CLASS_TEAMS
    folder.mkdir(mode=0o755, exist_ok=True)
    folder.chmod(0o755)  # the controller, another user, reads the shipped source
    shipped = class_team(team, True, folder)
    return replace(resolve(shipped.spec), label=shipped.label)


def _contest_teams(teams: Teams, db: Path) -> tuple[list[Team], list[str]]:
    """Each team resolved before any match, and a one-line refusal for each that cannot be
    (the contest goes on with the others; TeamError if none is left)."""
    if isinstance(teams, (str, type)) or not teams:
        raise UserError("teams must be a non-empty list of spec strings or Controller classes")
    resolved, refused = [], []
    for t in teams:
        try:
            resolved.append(_contest_team(t, db))
        except TeamError as e:
            refused.append(f"refused {e}")
    if not resolved:
        raise TeamError("; ".join(refused))
    return resolved, refused


def _notes(journal: Journal, refused: list[str]) -> tuple[str, ...]:
    """What a published result must say beside its table: the teams refused, whether any
    match in the journal ran without a kernel sandbox, and whether any was played on a Dask
    cluster that any machine could join."""
    reason = journal.unsandboxed()
    address = journal.insecure_cluster()
    return (
        *refused,
        *([f"played without a kernel sandbox (--unsandboxed): {reason}"] if reason else []),
        *([f"played on a Dask cluster any machine could join (--insecure-cluster): {address}"] if address else []),
    )


def _cluster(
    scheduler: str | None, cluster_keys: str | Path | None, insecure_cluster: bool, audit: float
) -> Cluster | None:
    """The contest's Dask cluster, checked before any match (None: no `scheduler`)."""
    from referee.contest.cluster import cluster

    if scheduler is None:
        if cluster_keys is not None or insecure_cluster:
            raise UserError("--cluster-keys and --insecure-cluster go with --scheduler")
        return None
    return cluster(scheduler, cluster_keys, insecure_cluster, audit)


def warn(notes: tuple[str, ...]) -> None:
    """A contest's notes (teams refused, played unsandboxed) on stderr, where a library caller
    or a quiet command line still sees them."""
    for note in notes:
        print(f"laserarena: warning: {safe(note, 500)}", file=sys.stderr)


def _outputs(db: Path, out: Path | None) -> None:
    """Refuse, before any match, a journal or output whose folder does not exist."""
    for path in (db, out):
        if path is not None and not path.resolve().parent.is_dir():
            raise UserError(f"{path}: the folder does not exist")


def _whole(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise UserError(f"{name} must be a whole number of at least 1, got {value!r}")
    return value


def _secret(secret: str | None) -> str | None:
    """A noise secret given to `grade` or `tournament`, judged as a secret file's is (None:
    the journal's own)."""
    from referee.contest.noise_secret import checked

    if secret is None:
        return None
    if not isinstance(secret, str):
        raise UserError(f"secret must be a string, got {type(secret).__name__}")
    return checked(secret, "secret")


@dataclass(frozen=True)
class Leaderboard:
    """A grade's leaderboard rows and the notes a published leaderboard carries (teams
    refused, matches played without a kernel sandbox); its `matches`, of which `ran` were
    played by this call (the others came from the journal)."""

    rows: tuple[LeaderboardRow, ...]
    notes: tuple[str, ...]
    matches: int
    ran: int


def grade(
    levels: Levels,
    teams: Teams,
    seeds: int = 3,
    workers: int = 2,
    db: str | Path = "results.sqlite",
    out: str | Path | None = None,
    secret: str | None = None,
    scheduler: str | None = None,
    quiet: bool = True,
    unsandboxed: bool = False,
    cluster_keys: str | Path | None = None,
    insecure_cluster: bool = False,
    audit: float = 0.05,
) -> list[LeaderboardRow]:
    """Grade every team alone (slot 0) on every level for seeds 1..`seeds`, as `laserarena
    grade` does, and return the leaderboard (per level, best mean score first).

    Every finished match is committed to the journal `db` at once; a second call with the same
    arguments resumes and runs only what is missing. `out` also writes leaderboard CSV, .json
    and .md; `secret` overrides the journal's noise secret (at least 128 bits: a weak one is
    refused, docs/integrity.md); `scheduler` grades on a Dask cluster (`tls://HOST:PORT` with
    the `cluster_keys` folder, or `tcp://` with `insecure_cluster=True`, which the results then
    note), re-simulating an `audit` share of its matches here (docs/cluster.md); `quiet=False`
    shows the progress bar on a terminal. A team that cannot be read is left out with a
    warning. Without a kernel sandbox grading is refused (SandboxError) unless
    `unsandboxed=True`, which the journal and the leaderboard then record."""
    board = leaderboard(
        levels,
        teams,
        seeds,
        workers,
        db,
        out,
        secret,
        scheduler,
        quiet,
        unsandboxed,
        cluster_keys,
        insecure_cluster,
        audit,
    )
    warn(board.notes)
    return list(board.rows)


def leaderboard(
    levels: Levels,
    teams: Teams,
    seeds: int = 3,
    workers: int = 2,
    db: str | Path = "results.sqlite",
    out: str | Path | None = None,
    secret: str | None = None,
    scheduler: str | None = None,
    quiet: bool = True,
    unsandboxed: bool = False,
    cluster_keys: str | Path | None = None,
    insecure_cluster: bool = False,
    audit: float = 0.05,
) -> Leaderboard:
    """`grade`, returning its notes beside the rows instead of printing them."""
    from referee.contest import grading as g
    from referee.contest.runner import sandbox_missing
    from referee.contest.tournaments import names as tournament_names
    from referee.version import __version__

    found = contest_levels(levels)
    db, board = Path(db), Path(out) if out is not None else None
    _whole("seeds", seeds)
    given = _secret(secret)  # before anything is written: a class team's source beside the journal
    where = _cluster(scheduler, cluster_keys, insecure_cluster, audit)
    sandbox_missing(unsandboxed)  # fail closed before any match (a cluster's are audited here)
    resolved, refused = _contest_teams(teams, db)  # a bad spec is refused here, in one line, before any match
    _outputs(db, board)
    names = dict(zip((t.spec for t in resolved), tournament_names(resolved)))  # the journal keeps specs
    with g.Journal(db) as journal:
        jobs = g.make_jobs(found, [(t.spec, t.code_hash) for t in resolved], seeds, journal.secret(given), __version__)
        with journal.keeping([j.key() for j in jobs], "match"):
            ran = g.grade_jobs(
                jobs, journal, workers=workers, cluster=where, quiet=quiet, teams=resolved, unsandboxed=unsandboxed
            )
        rows = [dict(r, team=names.get(r["team"], r["team"])) for r in g.leaderboard_rows(journal, jobs)]
        notes = _notes(journal, refused)
    if board is not None:
        g.write_leaderboard(rows, board, notes)
    return Leaderboard(tuple(LeaderboardRow(**r) for r in rows), notes, len(jobs), ran)


def tournament(
    levels: Levels,
    teams: Teams,
    rounds: int = 1,
    workers: int = 2,
    db: str | Path = "tournament.sqlite",
    out: str | Path | None = None,
    secret: str | None = None,
    scheduler: str | None = None,
    quiet: bool = True,
    unsandboxed: bool = False,
    cluster_keys: str | Path | None = None,
    insecure_cluster: bool = False,
    audit: float = 0.05,
) -> TournamentResult:
    """Rated heats of the teams racing each other on every level, as `laserarena tournament`
    does; return the standings and every heat.

    Every finished heat is committed to the journal `db` at once (a second call resumes).
    `out` also writes the report folder (index.html, standings, heats.csv, replays, viewer
    pages); `secret`, `scheduler`, `quiet`, `unsandboxed`, `cluster_keys`, `insecure_cluster`
    and `audit` as in `grade`; the result's
    `notes` (also in the report) name the teams refused and any heat played unsandboxed."""
    from referee.contest import report
    from referee.contest import tournaments as t
    from referee.contest.journal import Journal
    from referee.contest.runner import sandbox_missing
    from referee.media.viewer import write_viewer
    from referee.version import __version__

    found = contest_levels(levels)
    db, folder = Path(db), Path(out) if out is not None else None
    _whole("rounds", rounds)
    given = _secret(secret)  # before anything is written: a class team's source beside the journal
    where = _cluster(scheduler, cluster_keys, insecure_cluster, audit)
    sandbox_missing(unsandboxed)  # fail closed before any heat (a cluster's are audited here)
    resolved, refused = _contest_teams(teams, db)  # a bad spec is refused here, in one line, before any heat
    entrants = t.entrants(resolved)
    _outputs(db, folder)
    if folder is not None and folder.exists() and not folder.is_dir():
        raise UserError(f"out {folder}: not a folder")
    with Journal(db) as journal:
        start = time.perf_counter()
        heats = t.plan(found, entrants, rounds, journal.secret(given), __version__)
        planned = time.perf_counter()
        read = [e.team for e in entrants]  # their files read once, when resolved
        with journal.keeping([h.key() for h in heats], "heat", heats=True):
            ran = t.play_heats(
                heats, found, journal, workers=workers, cluster=where, quiet=quiet, teams=read, unsandboxed=unsandboxed
            )
        played = time.perf_counter()
        outcome = t.outcome(heats, entrants, journal)
        rated = time.perf_counter()
        notes = _notes(journal, refused) + ((outcome.unrated,) if outcome.unrated else ())
    if folder is not None:
        report.write(outcome, folder, f"Tournament: {', '.join(lv.name for lv, _ in found)}", notes)
        for heat in outcome.heats:
            write_viewer(folder / report.replay_file(heat), folder / report.viewer_file(heat))
    standings = []
    for s in outcome.standings:
        rating, mu, sigma = report.rating_figures(s.rating, float)
        per_level = tuple(LevelFigure(level, *figures) for level, figures in s.levels.items())
        standings.append(StandingRow(s.rank, s.team, rating, mu, sigma, s.heats, s.mean_score, per_level, s.faults))
    rows = tuple(
        HeatRow(**dict(zip(report.HEAT_COLUMNS, row), filler=bool(row[-1]))) for row in report.heat_rows(outcome)
    )
    return TournamentResult(
        tuple(standings),
        rows,
        ran,
        sum(h.wall for h in outcome.heats),
        (planned - start) + (rated - played),
        time.perf_counter() - rated,
        notes,
    )
