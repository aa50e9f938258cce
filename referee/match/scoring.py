"""A robot's score and its breakdown (docs/rules.md).

total = task + time + localization - penalties, where
  task          100 x completion (waypoints reached, or the way to the goal; 0 for localize)
  time          20 x (1 - finish time / time limit) x Q if the task was finished, else 0
  localization  25 x Q (100 x Q for a localize task), Q the localization quality: the mean
                over the control ticks of 1 / (1 + sqrt((d / position_scale)^2 + (h / heading_scale)^2)),
                0 for a tick without an estimate (referee.match.estimates)
  penalties     the sum of the robot's fouls' penalties (docs/rules.md lists them)
The time bonus is scaled by Q so that a fast finish cannot buy back not knowing where one is
(docs/decisions/0030).
"""

from __future__ import annotations

from referee.match.estimates import EstimateStats
from referee.match.rules import Foul
from referee.match.tasks import TaskTracker
from referee.records.results import Score

TASK_POINTS, TIME_POINTS, LOCALIZATION_POINTS, LOCALIZE_TASK_POINTS = 100.0, 20.0, 25.0, 100.0


def score(tracker: TaskTracker, slot: int, stats: EstimateStats, fouls: list[Foul], time_limit: float) -> Score:
    """The score breakdown of one robot."""
    localize = tracker.kind == "localize"
    quality = stats.quality
    task = 0.0 if localize else TASK_POINTS * tracker.progress(slot)
    finished = tracker.finished[slot]
    time = TIME_POINTS * (1.0 - finished / time_limit) * quality if finished is not None and not localize else 0.0
    loc = (LOCALIZE_TASK_POINTS if localize else LOCALIZATION_POINTS) * quality
    penalties = sum(f.penalty for f in fouls)
    return Score(task=task, time=time, localization=loc, penalties=penalties, total=task + time + loc - penalties)
