"""A match's result assembled from its end state: each robot's score, task progress,
localization, fouls, faults and warnings, and what was played (docs/results.md)."""

from __future__ import annotations

from levels.model import Level, Pose
from referee.match.drawings import Warnings
from referee.match.estimates import EstimateStats
from referee.match.rules import Foul
from referee.match.scoring import score
from referee.match.tasks import TaskTracker
from referee.records.results import RESULT_FORMAT, RESULT_VERSION, Fault, LevelRef, MatchResult, RobotResult
from referee.version import __version__


def robot_result(
    slot: int,
    team: str,
    pose: Pose,
    tracker: TaskTracker,
    stats: EstimateStats,
    fouls: list[Foul],
    faults: list[Fault],
    stopped: bool,
    warnings: Warnings,
    time_limit: float,
) -> RobotResult:
    """Robot `slot`'s result, `pose` where it ended (its warnings left out when there are none)."""
    return RobotResult(
        slot=slot,
        team=team,
        score=score(tracker, slot, stats, fouls, time_limit),
        task=tracker.summary(slot),
        localization=stats.summary(),
        fouls=[f.to_record() for f in fouls],
        faults=list(faults),
        stopped=stopped,
        final_pose=[pose.x, pose.y, pose.heading],
        **({"warnings": warnings.records()} if warnings.kinds else {}),
    )


def match_result(
    level: Level, seed: int, ideal: bool, end_time: float, end_reason: str, robots: list[RobotResult]
) -> MatchResult:
    """The result of a match of `level` that ended at `end_time` for `end_reason`."""
    return MatchResult(
        format=RESULT_FORMAT,
        version=RESULT_VERSION,
        software=__version__,
        level=LevelRef(name=level.name, hash=level.hash),
        seed=seed,
        ideal=ideal,
        end_time=end_time,
        end_reason=end_reason,
        robots=robots,
    )
