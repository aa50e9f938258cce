"""Each robot's standing at any moment of a replay, for the viewer's HUD: task progress so
far, score so far, and the error of its latest estimate. Grows with a live replay.

Once the replay has its result, task progress comes from the result's own times: when each
waypoint was reached and what it was worth, when a goto robot arrived. Before that (live play,
a replay cut short) it is tracked on the recorded frames from the first frame's true starts:
a waypoint grazed between two frames shows a frame late, each counts whole, and a goto
arrival (a stop, seen at control ticks) does not show. The score so far is the points
docs/rules.md gives for what happened up to that moment: task points, the localization points
the ticks so far have earned, the time bonus once finished, minus the penalties of the fouls
so far. Q is the mean tick quality over the match's ticks, so each tick earns its quality over
the match's tick count (the result's, or the time limit's before it has one). With the result,
the score so far never exceeds the final score and at the end it is the final score.
Mirrored for the browser in referee/media/web/viewer.js.
"""

from __future__ import annotations

import bisect
import math

from levels.model import Level, Pose
from referee.match.scoring import LOCALIZATION_POINTS, LOCALIZE_TASK_POINTS, TASK_POINTS, TIME_POINTS
from referee.match.tasks import TaskTracker
from referee.media.error_series import ErrorTrack
from referee.records.replay_format import Replay


class Standings:
    """Progress per frame and estimate errors of every robot of one replay."""

    def __init__(self, level: Level, rep: Replay):
        self.level, self.rep = level, rep
        self.tracker = TaskTracker(level, tuple(Pose(*p) for p in rep.frames[0][1]) if rep.frames else None)
        self.reached: list[list[int]] = [[] for _ in level.robots]  # per frame, from the frames
        self.finished: list[float | None] = [None] * len(level.robots)
        rules = level.rules
        self.errors = [ErrorTrack(slot, rules.position_scale, rules.heading_scale) for slot in range(len(level.robots))]
        self.frames_done = 0
        self.update()

    def update(self) -> None:
        """Take in the frames and estimates recorded since the last call."""
        for t, poses in self.rep.frames[self.frames_done :]:
            for slot, (x, y, _) in enumerate(poses):
                if t > 0:  # the referee tracks after physics steps, never at the start
                    self.tracker.update(slot, x, y, t)
                self.reached[slot].append(self.tracker.next[slot])
                self.finished[slot] = self.tracker.finished[slot]
        self.frames_done = len(self.rep.frames)
        for track in self.errors:
            track.extend(self.rep)

    def _frame(self, t: float) -> int:
        frames = self.rep.frames
        return int(min(max(round(t * self.rep.header["record_rate"]), 0), len(frames) - 1))

    def _clock(self, t: float) -> float:
        """`t`, or at the replay's last frame the match's end: the last frame may come a step or
        two before it, and there the standing is what the match ended with."""
        result = self.rep.result
        return max(t, result.end_time) if result is not None and t >= self.rep.duration - 1e-9 else t

    def task_at(self, slot: int, t: float) -> tuple[int, float, float | None]:
        """Robot `slot`'s task at time `t`: targets reached, progress (0..1), finish time."""
        result = self.rep.result
        if result is None:
            reached = self.reached[slot][self._frame(t)]
            targets = len(self.tracker.targets(slot))
            return reached, (reached / targets if targets else 0.0), self.finished[slot]
        t = self._clock(t)
        robot = result.robots[slot]
        task = robot.task
        if task.kind == "goto":
            arrived = task.finished is not None and task.finished <= t
            return int(arrived), (robot.score.task / TASK_POINTS if arrived else 0.0), task.finished
        times = task.get("reached_at", [])
        worth = task.get("worth", [1.0] * len(times))
        reached, progress = 0, 0.0
        while reached < len(times) and times[reached] <= t:
            progress += worth[reached]  # added in order, as the browser adds them
            reached += 1
        return reached, (progress / task.get("total", 1) if times else 0.0), task.finished

    def score(self, slot: int, t: float) -> float:
        """Robot `slot`'s score had the match ended at time `t`."""
        localize = self.level.task.kind == "localize"
        t = self._clock(t)
        _, progress, finished = self.task_at(slot, t)
        points = 0.0 if localize else TASK_POINTS * progress
        quality = min(1.0, self.errors[slot].quality_sum_until(t) / self.match_ticks(slot))
        if finished is not None and finished <= t and not localize:
            points += TIME_POINTS * (1.0 - finished / self.level.time_limit) * quality
        points += (LOCALIZE_TASK_POINTS if localize else LOCALIZATION_POINTS) * quality
        return points - sum(f["penalty"] for f in self.rep.fouls if f["r"] == slot and f["time"] <= t)

    def match_ticks(self, slot: int) -> int:
        """The control ticks Q is the mean over: the result's, else the time limit's."""
        result = self.rep.result
        return result.robots[slot].localization.ticks if result else self.level.control_ticks

    def error_now(self, slot: int, t: float) -> tuple[float, float] | None:
        """Position (m) and heading (rad) error of the latest estimate reported by time `t`."""
        track = self.errors[slot]
        i = bisect.bisect_right(track.times, t + 1e-9) - 1
        return (track.position[i], track.heading[i]) if i >= 0 else None

    def line(self, slot: int, team: str, t: float) -> str:
        """The HUD line of one robot."""
        kind = self.level.task.kind
        reached, progress, _ = self.task_at(slot, t)
        if kind == "localize":
            task = "localize"
        elif kind == "goto":
            task = f"arrived, {100 * progress:.0f} %" if reached else "not arrived"
        else:
            task = f"{reached}/{len(self.tracker.targets(slot))} waypoints"
        err = self.error_now(slot, t)
        shown = f"err {1000 * err[0]:.0f} mm {math.degrees(err[1]):.0f} deg" if err else "no estimate"
        return f"{slot} {team}   score {self.score(slot, t):6.1f}   {task}   {shown}"
