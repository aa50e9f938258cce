"""A tournament: rated teams race each other in heats on one or more levels, resumably.

Every heat is one match with a team (or a filler) in each robot slot, its lineup from the
schedule (referee.contest.schedule), its seed its number on that level, and its noise from
the run's secret as in grading. A finished heat is committed to the journal at once, keyed
by its level, lineup (specs and code hashes in slot order), seed, software and noise, so a
killed tournament resumes where it stopped and the standings come out the same whatever ran
the heats. Standings are computed from the journal, in heat order, after the last heat.

On a level of one robot a heat is one team alone, which ranks nobody: there every team plays
each round on the round's seed, and the matches on one seed are ranked together as one heat
of all the teams (Outcome.unrated says why, where even that ranks no team above another).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from levels.model import Level
from referee.contest.audit import AuditFailed
from referee.contest.cluster import Cluster
from referee.contest.dispatch import run_jobs
from referee.contest.journal import Journal
from referee.contest.noise_secret import noise_key, secret_id
from referee.contest.ratings import Placing, Rating, bootstrap, ranks, rate
from referee.contest.runner import MatchJob, file_part, replay_folder, write_replay
from referee.contest.schedule import schedule
from referee.errors import UserError
from referee.records.faults import summary
from referee.sandbox.teams import Team, resolve
from referee.terminal import Progress, safe


@dataclass(frozen=True)
class Heat:
    """One heat: its number in playing order (from 1), round, level, seed and, in slot order,
    each slot's team index (None for a filler), spec and code hash."""

    number: int
    round: int
    level: str
    level_hash: str
    seed: int
    teams: tuple[int | None, ...]
    specs: tuple[str, ...]
    code_hashes: tuple[str, ...]
    software: str
    secret_id: str
    noise_key: str
    ideal: bool = False

    def key(self) -> tuple:
        """The journal key: everything the heat's result depends on."""
        lineup = json.dumps([list(p) for p in zip(self.specs, self.code_hashes)])
        return (self.level_hash, lineup, self.seed, self.software, int(self.ideal), self.secret_id)

    def replay_name(self) -> str:
        """A unique, readable replay file name for the journal's folder."""
        tag = hashlib.sha256(json.dumps(self.key()).encode()).hexdigest()[:12]
        return f"{file_part(self.level[:60])}__seed{self.seed}__{tag}.replay"


@dataclass(frozen=True)
class Entrant:
    """A rated team: its name in the standings and its resolved code."""

    name: str
    team: Team


def names(teams: list[Team]) -> list[str]:
    """Each team's name in tables: its label (never a machine's absolute path), or its spec
    where two labels coincide."""
    labels = [t.label for t in teams]
    return [t.label if labels.count(t.label) == 1 else t.spec for t in teams]


def entrants(teams: list[Team]) -> list[Entrant]:
    """Name each team (`names`); UserError if a team is given twice."""
    specs = [t.spec for t in teams]
    twice = sorted({s for s in specs if specs.count(s) > 1})
    if twice:
        raise UserError(f"--team {safe(twice[0])}: given twice; each team plays once per heat")
    return [Entrant(name, t) for name, t in zip(names(teams), teams)]


def plan(levels: list[tuple[Level, Path]], teams: list[Entrant], rounds: int, secret: str, software: str) -> list[Heat]:
    """Every heat, in playing order: round by round, each level's heats of that round."""
    sid = secret_id(secret)
    per_level = []
    for level, _ in levels:
        filler = resolve(level.default_controller)
        lineups = schedule(len(teams), len(level.robots), rounds)
        per_level.append((level, filler, lineups))
    heats: list[Heat] = []
    for r in range(1, rounds + 1):
        for level, filler, lineups in per_level:
            alone = len(level.robots) == 1  # compared on the same seeds: the round's (module doc)
            for number, lineup in enumerate(lineups, start=1):
                if lineup.round != r:
                    continue
                seed = lineup.round if alone else number
                slot_teams = [teams[e.team].team if e.team is not None else filler for e in lineup.entries]
                heats.append(
                    Heat(
                        len(heats) + 1,
                        r,
                        level.name,
                        level.hash,
                        seed,
                        tuple(e.team for e in lineup.entries),
                        tuple(t.spec for t in slot_teams),
                        tuple(t.code_hash for t in slot_teams),
                        software,
                        sid,
                        noise_key(secret, level.hash, seed),
                    )
                )
    return heats


def play_heats(
    heats: list[Heat],
    levels: list[tuple[Level, Path]],
    journal: Journal,
    workers: int = 1,
    cluster: Cluster | None = None,
    quiet: bool = False,
    teams: Sequence[Team] = (),
    unsandboxed: bool = False,
) -> int:
    """Run every heat not yet in `journal` (replays in the journal's folder/replays), on
    `workers` local processes or on `cluster`; return how many ran now. Workers return each
    heat's result and replay; only this process writes. `teams`: the heats' teams as resolved
    when they were planned (any other is resolved here, once, and checked against the hash its
    heats were planned with); `unsandboxed`: the organizer allows heats without a kernel
    sandbox (the journal then records it, as it records an insecure cluster). A worker that
    fails its audit: its heats of this run are removed again, and AuditFailed goes on up."""
    replay_dir = replay_folder(journal.path)
    done = journal.heats_done()
    todo = [h for h in heats if h.key() not in done]
    if not todo:
        return 0
    texts: dict[str, bytes] = {}
    for level, path in levels:
        data = path.read_bytes()
        if "sha256:" + hashlib.sha256(data).hexdigest() != level.hash:
            raise UserError(f"{path}: the level changed since the tournament began; run it again")
        texts[level.hash] = data
    shipped = {t.spec: t for t in teams}
    for spec, code in sorted({(s, c) for h in todo for s, c in zip(h.specs, h.code_hashes)}):
        if spec not in shipped:
            shipped[spec] = resolve(spec)
        if shipped[spec].code_hash != code:
            raise UserError(f"{safe(spec)}: the team's code changed since the tournament began; run it again")
    by_key = {h.key(): h for h in todo}
    jobs = [
        (
            k,
            MatchJob(
                h.level,
                texts[h.level_hash],
                h.level_hash,
                tuple(shipped[s] for s in h.specs),
                h.seed,
                h.noise_key,
                h.ideal,
                h.software,
                unsandboxed,
            ),
        )
        for k, h in by_key.items()
    ]
    progress = Progress(len(heats), "heat", quiet, already=len(heats) - len(todo))
    if cluster is not None and cluster.insecure:
        journal.note_insecure_cluster(cluster.address)
    results = run_jobs(jobs, workers, cluster)
    try:  # the command line turns SIGTERM into KeyboardInterrupt, as Ctrl-C
        for key, played in results:
            heat = by_key[key]
            replay = write_replay(replay_dir, heat.replay_name(), played.replay)
            if played.unsandboxed:
                journal.note_unsandboxed(played.unsandboxed)
            journal.record_heat(heat.level, key, played.result, str(replay), played.wall)
            progress.tick(f"heat {heat.number} {heat.level} seed {heat.seed}")
    except AuditFailed as failed:
        journal.forget(failed.discard, heats=True)
        for key in failed.discard:
            (replay_dir / by_key[key].replay_name()).unlink(missing_ok=True)
        raise
    finally:
        progress.close()
        results.close()  # a pool's workers end here, even on an interrupt
    return len(todo)


@dataclass(frozen=True)
class HeatResult:
    """A played heat: the heat, each slot's placing (slot order), its replay file and wall time.
    A heat of one robot is placed among all the matches on its level and seed."""

    heat: Heat
    placings: tuple[Placing, ...]
    replay: str
    wall: float


@dataclass(frozen=True)
class Standing:
    """A team's line in the standings: rank, name, rating (None where none can be formed),
    heats played, mean score over them, per level (name -> (heats, mean, low, high) with the
    95 % bootstrap interval), and its faults told by kind (referee.records.faults.summary; ""
    for none)."""

    rank: int
    team: str
    rating: Rating | None
    heats: int
    mean_score: float
    levels: dict[str, tuple[int, float, float, float]]
    faults: str = ""


@dataclass(frozen=True)
class Outcome:
    """What a tournament produced: the standings, every heat's result in order, each team's
    rating after each heat (`history[h][t]`), and `unrated`: why no rating could be formed
    (None when the ratings rank the teams)."""

    teams: list[Entrant]
    standings: list[Standing]
    heats: list[HeatResult]
    history: list[list[Rating]]
    unrated: str | None = None


def _placed(played: list[tuple[Heat, list[float]]]) -> tuple[list[tuple[Placing, ...]], list[list[Placing]], set[int]]:
    """Each heat's placings (slot order), what it adds to the ratings, and which heats add a
    seed. A heat adds its own placings; a heat of one robot is ranked among the matches on its
    level and seed, and the last of those adds them all, as one heat (the others add nothing)."""
    seeds: dict[tuple[str, int], list[int]] = {}
    for i, (heat, scores) in enumerate(played):
        if len(scores) == 1:
            seeds.setdefault((heat.level_hash, heat.seed), []).append(i)
    rank: dict[int, int] = {}
    for group in seeds.values():
        rank.update(zip(group, ranks([played[i][1][0] for i in group])))
    placings = [
        tuple(Placing(t, s, k) for t, s, k in zip(heat.teams, scores, [rank[i]] if i in rank else ranks(scores)))
        for i, (heat, scores) in enumerate(played)
    ]
    added: list[list[Placing]] = [[] if i in rank else list(p) for i, p in enumerate(placings)]
    for group in seeds.values():
        added[group[-1]] = [placings[j][0] for j in group]
    return placings, added, {group[-1] for group in seeds.values()}


def why_unrated(teams: int, added: list[list[Placing]]) -> str | None:
    """Why no rating can be formed from what the heats add (None if one can): a rating needs a
    heat that places one robot above another."""
    if any(len({p.rank for p in heat}) > 1 for heat in added):
        return None
    if teams == 1 and all(len(heat) < 2 for heat in added):
        return "no rating: one team alone, with no other to compare it with on the same seeds"
    return (
        "no rating: every heat was a tie (on a one-robot level: all teams scored alike on every seed); "
        "ranked by mean score, then name"
    )


def outcome(heats: list[Heat], teams: list[Entrant], journal: Journal) -> Outcome:
    """The standings from the journal's results of `heats` (all of which must have run). Where
    no rating can be formed the teams are ranked by mean score, and `unrated` says why."""
    played, files = [], []
    faults: dict[int, list] = {}  # each team's faults, heat by heat
    for heat in heats:
        found = journal.heat(heat.key())
        if found is None:
            raise UserError(f"{journal.path}: heat {heat.number} has not run; run the tournament again")
        result, replay, wall = found
        robots = sorted(result["robots"], key=lambda r: r["slot"])
        for team, robot in zip(heat.teams, robots):
            if team is not None:
                faults.setdefault(team, []).extend(robot["faults"])
        played.append((heat, [float(r["score"]["total"]) for r in robots]))
        files.append((replay, wall))
    placings, added, seeds = _placed(played)
    results = [HeatResult(heat, placed, *file) for heat, placed, file in zip(heats, placings, files)]
    history = rate(len(teams), added, seeds)
    why = why_unrated(len(teams), added)
    final = history[-1] if history and why is None else []
    rows = []
    for t, entrant in enumerate(teams):
        mine = [(h.heat.level, p.score) for h in results for p in h.placings if p.team == t]
        per_level = {}
        for level in dict.fromkeys(lv for lv, _ in mine):
            scores = [s for lv, s in mine if lv == level]
            mean, low, high = bootstrap(scores, f"{level}\0{entrant.team.spec}")
            per_level[level] = (len(scores), round(mean, 3), round(low, 3), round(high, 3))
        mean_all = round(sum(s for _, s in mine) / len(mine), 3) if mine else 0.0
        rows.append(
            (entrant.name, final[t] if final else None, len(mine), mean_all, per_level, summary(faults.get(t, [])))
        )
    rows.sort(key=lambda r: (-r[1].ordinal if r[1] else -r[3], r[0]))
    standings = [Standing(i + 1, *row) for i, row in enumerate(rows)]
    return Outcome(teams, standings, results, history, why)
