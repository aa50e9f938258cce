"""`make baselines`: does the score measure the laser? Each built-in level's default reference
beside the strongest controllers we know that never use it, over many seeds with a secret.

How it works, in detail: docs/internals.md, `benchmarks/baselines.py`.
"""

from __future__ import annotations

import argparse
import json
import math
import secrets
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import levels
from referee.terminal import markdown_text

WHO = ("reference", "blind", "sensorless", "spiral", "walls", "bounce", "fraction")
NO_LASER = ("blind", "sensorless", "spiral", "walls", "bounce")  # what the reference must beat by twice


@dataclass(frozen=True)
class Outcome:
    """What one controller did in one match (robot slot 0)."""

    level: str
    who: str
    seed: int
    score: float
    quality: float
    position_rms: float  # m; inf without an estimate
    reached: bool  # the task done (a localize task has none: False)


def play(level_name: str, who: str, seed: int, secret: str) -> Outcome:
    """One match of `who` in slot 0 of a built-in level, its noise drawn from `secret`."""
    import no_laser

    from levels.loader import load_level
    from referee.contest.noise_secret import noise_key
    from referee.match.loop import play_match
    from referee.sandbox.teams import Team, resolve
    from robots._host.loading import load_class
    from robots.controllers.dead_reckoning import DeadReckoning
    from robots.controllers.sensorless import Sensorless

    level = load_level(levels.path(level_name))
    start = level.robots[0].start
    nominal = (start.x, start.y, start.heading)  # as the public level file writes it
    reference = resolve(level.default_controller)
    if who == "reference":
        team = reference
    elif who == "blind":
        team = Team("blind", "ref:dead-reckoning", "sha256:blind", factory=lambda: DeadReckoning(nominal))
    elif who == "sensorless":
        team = Team("sensorless", "ref:sensorless", "sha256:sensorless", factory=lambda: Sensorless(nominal))
    elif who == "fraction":
        inner = load_class(level.default_controller)
        team = Team("fraction", "fraction", "sha256:fraction", factory=lambda: no_laser.Fraction(inner()))
    else:
        team = Team(who, who, f"sha256:{who}", factory=no_laser.STRATEGIES[who])
    others = [resolve(level.default_controller) for _ in level.robots[1:]]
    key = noise_key(secret, level.hash, seed)
    r = play_match(level, [team, *others], seed=seed, isolate=False, noise_key=key)["robots"][0]
    loc = r["localization"]
    return Outcome(
        level_name,
        who,
        seed,
        r["score"]["total"],
        loc["quality"],
        loc["position_rms"] if loc["position_rms"] is not None else math.inf,
        r["task"]["finished"] is not None,
    )


def _play(job: tuple[str, str, int, str]) -> Outcome:
    return play(*job)


def summary(outcomes: list[Outcome], level: str) -> dict:
    """One level's figures: per controller the median score, its range and the median RMS; the
    reference's wins over blind driving and over twice the sensorless score, seed by seed."""
    by = {w: sorted((o for o in outcomes if o.level == level and o.who == w), key=lambda o: o.seed) for w in WHO}
    ref, blind, still = by["reference"], by["blind"], by["sensorless"]
    out: dict = {"level": level, "seeds": len(ref)}
    for w in WHO:
        scores = [o.score for o in by[w]]
        out[w] = {
            "score_median": statistics.median(scores),
            "score_min": min(scores),
            "score_max": max(scores),
            "rms_mm_median": 1000 * statistics.median(o.position_rms for o in by[w]),
            "rms_mm_worst": 1000 * max(o.position_rms for o in by[w]),
            "reached": sum(o.reached for o in by[w]),
        }
    out["beats_blind"] = sum(r.score > b.score and r.position_rms < b.position_rms for r, b in zip(ref, blind))
    out["twice_sensorless"] = sum(r.score >= 2 * s.score for r, s in zip(ref, still))
    best = max(NO_LASER, key=lambda w: out[w]["score_median"])
    out["best_no_laser"] = best
    out["best_share"] = out[best]["score_median"] / out["reference"]["score_median"]
    return out


def _mm(v: float) -> str:
    return "none" if math.isinf(v) else f"{v:.1f}" if v < 100 else f"{v:.0f}"


def markdown(rows: list[dict], seeds: int, seconds: float, workers: int) -> str:
    lines = [
        "# Baselines: the laser against searching without it",
        "",
        "Made by `make baselines` (`python benchmarks/baselines.py`): every built-in level, seeds 1 to",
        f"{seeds}, its default hardware error, noise drawn from a secret as in grading, in {seconds:.0f} s on",
        f"{workers} worker processes. Do not edit by hand: run it again. In slot 0: the level's default",
        "reference, and the strongest controllers we know that never use the laser:",
        "",
        "- *blind*: `ref:dead-reckoning` from the nominal start written in the level file, driving its task",
        "  open-loop;",
        "- *sensorless*: `ref:sensorless`, which reports that start and stands still (on `bac-static`, whose",
        "  trials are set down around one listed point, this is also the lookup in that pool; no other",
        "  built-in level lists trial poses);",
        "- *spiral*: a square spiral of stops around the announced start, each stop long enough to arrive,",
        "  stops and rings a radius and a half apart (benchmarks/no_laser.py);",
        "- *walls*: straight on until it must have met a wall, then along the walls, pressing on them,",
        "  with a stop at every pitch;",
        "- *bounce*: straight runs, stops and random spins;",
        "- *1/4 events*: the reference fed one event in four it senses (how it degrades, not a",
        "  no-laser strategy).",
        "",
        "Scores are medians with, for the reference, its range and the position RMS of its estimates",
        "(median / worst seed). *best share*: the best no-laser median over the reference's median (the",
        "aim is at most 0.5). *beats blind*: seeds on which the reference scored higher and localized better than",
        "blind driving; *>= 2x sensorless*: seeds on which it scored at least twice the sensorless one;",
        "*task*: seeds on which the reference did the level's task (a localize level has none).",
        "",
        "| level | reference | its score | its RMS mm | task | blind | sensorless | spiral | walls | bounce "
        "| 1/4 events | best share | beats blind | >= 2x sensorless |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ref, n = r["reference"], r["seeds"]
        task = "-" if r["localize"] else f"{ref['reached']} of {n}"
        others = " | ".join(
            f"{r[w]['score_median']:.1f}" for w in ("blind", "sensorless", "spiral", "walls", "bounce", "fraction")
        )
        lines.append(
            f"| {markdown_text(r['level'])} | {markdown_text(r['controller'])} | {ref['score_median']:.1f} ({ref['score_min']:.1f} to "
            f"{ref['score_max']:.1f}) | {_mm(ref['rms_mm_median'])} / {_mm(ref['rms_mm_worst'])} | {task} | {others} | "
            f"{r['best_share']:.2f} ({r['best_no_laser']}) | {r['beats_blind']} of {n} | {r['twice_sensorless']} of {n} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="seeds 1..N (default 20)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--levels", nargs="*", default=None, help="built-in levels (default: all)")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "docs" / "baselines.md"))
    ap.add_argument("--json", metavar="FILE", help="write every match's outcome and the summary as JSON")
    ap.add_argument("--secret-file", metavar="FILE", help="the noise secret (default: a new random one)")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.workers < 1:
        ap.error("--seeds and --workers must be at least 1")
    from referee.contest import noise_secret

    secret = noise_secret.read(args.secret_file) if args.secret_file else secrets.token_hex(32)
    names = args.levels or levels.names()
    jobs = [(name, who, seed, secret) for name in names for seed in range(1, args.seeds + 1) for who in WHO]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        outcomes = list(pool.map(_play, jobs, chunksize=1))
    seconds = time.perf_counter() - start
    from levels.loader import load_level

    rows = []
    for name in names:
        level = load_level(levels.path(name))
        row = summary(outcomes, name) | {
            "controller": level.default_controller,
            "localize": level.task.kind == "localize",
        }
        rows.append(row)
        medians = "  ".join(f"{w} {row[w]['score_median']:6.1f}" for w in WHO)
        print(
            f"{name:17} {medians}  best share {row['best_share']:.2f}  beats blind {row['beats_blind']}/{row['seeds']}  "
            f">= 2x sensorless {row['twice_sensorless']}/{row['seeds']}",
            flush=True,
        )
    Path(args.out).write_text(markdown(rows, args.seeds, seconds, args.workers), encoding="utf-8")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps({"summary": rows, "matches": [asdict(o) for o in outcomes]}, indent=1))
    print(f"{len(jobs)} matches in {seconds:.0f} s; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
