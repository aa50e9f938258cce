"""A robot's score and its breakdown (docs/rules.md).

total = task + time + localization - penalties, where
  task          100 x completion (waypoints reached, or the way to the goal; 0 for localize)
  time          20 x (1 - finish time / time limit) if the task was finished, else 0
  localization  25 x q (100 x q for a localize task), q = fraction of ticks with an estimate
                / (1 + RMS position error / 10 mm)
  penalties     the sum of the robot's fouls' penalties (docs/rules.md lists them)
"""

from __future__ import annotations

from referee.match.estimates import EstimateStats
from referee.match.rules import Foul
from referee.match.tasks import TaskTracker
from referee.records.results import Score

TASK_POINTS, TIME_POINTS, LOCALIZATION_POINTS, LOCALIZE_TASK_POINTS = 100.0, 20.0, 25.0, 100.0
RMS_SCALE = 0.010  # m: an RMS error of 10 mm halves the localization points


def localization_quality(stats: EstimateStats) -> float:
    """0..1: how often, and how well, the controller said where it was."""
    summary = stats.summary()
    if not summary["estimates"]:
        return 0.0
    return quality(stats.fraction, summary["position_rms"])


def quality(fraction: float, position_rms: float) -> float:
    """The localization quality q of a fraction of ticks with an estimate and their RMS error (m)."""
    return fraction / (1.0 + position_rms / RMS_SCALE)


def score(tracker: TaskTracker, slot: int, stats: EstimateStats, fouls: list[Foul], time_limit: float) -> Score:
    """The score breakdown of one robot."""
    localize = tracker.kind == "localize"
    task = 0.0 if localize else TASK_POINTS * tracker.progress(slot)
    finished = tracker.finished[slot]
    time = TIME_POINTS * (1.0 - finished / time_limit) if finished is not None and not localize else 0.0
    loc = (LOCALIZE_TASK_POINTS if localize else LOCALIZATION_POINTS) * localization_quality(stats)
    penalties = sum(f.penalty for f in fouls)
    return Score(task=task, time=time, localization=loc, penalties=penalties, total=task + time + loc - penalties)
