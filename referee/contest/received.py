"""A match a Dask worker played, checked against its job before anything of it is kept: the
result against the result schema, the replay read as any replay is (bounded), and both against
the job (level hash, seed, noise mode and key, software, each slot's code hash), the replay's
last record the very result. A result that passes is well formed and about the right match;
whether its numbers are the ones the match gives is the audit's to say (`referee.contest.audit`).
"""

from __future__ import annotations

import math

import msgspec

from referee.contest.courier_link import Returned
from referee.contest.runner import MatchJob, Played
from referee.errors import ReplayError
from referee.records.replay_reader import load
from referee.records.results import MatchResult

ALLOWED_UNSANDBOXED = "the organizer let the cluster's workers play without one"


class BadResult(ValueError):
    """What came back is not a result of its job: the one-line reason."""


def checked(returned: Returned, job: MatchJob) -> Played:
    """`returned` as a Played of `job`, or BadResult. Whether its controllers may have run
    without a sandbox is the organizer's policy (`job.unsandboxed`), never the worker's word."""
    try:
        result = MatchResult.from_json(returned.result)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise BadResult(f"its result does not match the result schema ({e})") from None
    if not math.isfinite(returned.wall) or returned.wall < 0:
        raise BadResult(f"its wall time is {returned.wall}")
    expected = {
        "level hash": (result.level.hash, job.level_hash),
        "seed": (result.seed, job.seed),
        "ideal": (result.ideal, job.ideal),
        "software": (result.software, job.software),
        "robots": (len(result.robots), len(job.teams)),
        "slots": ([r.slot for r in result.robots], list(range(len(job.teams)))),
    }
    _same("result", expected)
    try:
        replay = load("its replay", keep=False, data=returned.replay)
    except ReplayError as e:
        raise BadResult(str(e)) from None
    header = replay.header
    _same(
        "replay",
        {
            "level hash": (header["level"].get("hash", ""), job.level_hash),
            "seed": (header["seed"], job.seed),
            "ideal": (header["ideal"], job.ideal),
            "software": (header.get("software", ""), job.software),
            "noise key": (header.get("noise_key") or "", job.noise_key),
            "code hashes": ([t.get("hash", "") for t in header["teams"]], [t.code_hash for t in job.teams]),
        },
    )
    if replay.result != result:
        raise BadResult("its replay ends with another result than the one it sent")
    return Played(returned.result, returned.replay, returned.wall, ALLOWED_UNSANDBOXED if job.unsandboxed else "")


def _same(what: str, pairs: dict[str, tuple[object, object]]) -> None:
    for name, (got, want) in pairs.items():
        if got != want:
            raise BadResult(f"its {what} has {name} {str(got)[:80]}, the job {str(want)[:80]}")
