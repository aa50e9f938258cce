"""A replay's localization errors over time: each reported estimate against the true pose.

The truth at an estimate's time is the recorded frame at that time, interpolated linearly
between the two frames around it when the control period is not a multiple of the frame
period (replays record true poses at `record_rate`, estimates at control ticks), but never
across a move to a new trial's pose: an estimate up to the move is compared with the frame
before it, one after with the frame after. Used by `laserarena plot` and by the viewer's HUD;
it grows as a live replay grows.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from arena.angles import wrap
from referee.match.estimates import tick_quality
from referee.records.replay_format import Replay


def truth_at(
    frames: list, times: list[float], slot: int, t: float, moves: Sequence[float] = ()
) -> tuple[float, float, float] | None:
    """Robot `slot`'s true pose at time `t` from the frames (whose times are `times`), or None
    past the last frame; `moves` are the times at which the robots were carried to new poses."""
    i = bisect.bisect_left(times, t - 1e-9)
    if i >= len(frames):
        return None
    if abs(times[i] - t) <= 1e-9 or i == 0:
        return tuple(frames[i][1][slot])
    (t0, p0), (t1, p1) = frames[i - 1], frames[i]
    for move in moves:
        if t0 - 1e-9 <= move <= t1 + 1e-9:  # carried between (or at) the two frames: no motion joins them
            return tuple((p0 if t <= move + 1e-9 else p1)[slot])
    a, b = p0[slot], p1[slot]
    w = (t - t0) / (t1 - t0)
    dh = wrap(b[2] - a[2])
    return (a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), wrap(a[2] + w * dh))


def pose_error(estimate, truth) -> tuple[float, float]:
    """Position error (m) and absolute heading error (rad, 0..pi) of an estimate."""
    return (math.hypot(estimate[0] - truth[0], estimate[1] - truth[1]), abs(wrap(estimate[2] - truth[2])))


@dataclass
class ErrorTrack:
    """One robot's estimate errors so far: times (s), position (m), heading (rad), and the
    running sum of their tick qualities on the level's scales (docs/rules.md)."""

    slot: int
    position_scale: float = 0.01
    heading_scale: float = 0.05
    times: list[float] = field(default_factory=list)
    position: list[float] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    done: int = 0  # estimate records taken in
    frame_times: list[float] = field(default_factory=list)
    qualities: list[float] = field(default_factory=list)  # running sum of tick qualities

    def quality_sum_until(self, t: float) -> float:
        """The sum of the tick qualities of the estimates reported up to time `t`."""
        n = self.until(t)
        return self.qualities[n - 1] if n else 0.0

    def extend(self, rep: Replay) -> None:
        """Take in the robot's estimate records whose truth is already recorded."""
        self.frame_times.extend(f[0] for f in rep.frames[len(self.frame_times) :])
        moves = rep.moves
        for rec in rep.estimates[self.done :]:
            if rec["r"] == self.slot:
                truth = truth_at(rep.frames, self.frame_times, self.slot, rec["t"], moves)
                if truth is None:
                    break  # its frame is not recorded yet (live play): next time
                d, h = pose_error(rec["e"], truth)
                self.times.append(rec["t"])
                self.position.append(d)
                self.heading.append(h)
                q = tick_quality(d, h, self.position_scale, self.heading_scale)
                self.qualities.append((self.qualities[-1] if self.qualities else 0.0) + q)
            self.done += 1

    def until(self, t: float) -> int:
        """How many estimates were reported up to time `t`."""
        return bisect.bisect_right(self.times, t + 1e-9)


def tracks(rep: Replay) -> list[ErrorTrack]:
    """Every robot's error track over the whole replay (its qualities on the default scales)."""
    out = [ErrorTrack(slot) for slot in range(len(rep.frames[0][1]))]
    for track in out:
        track.extend(rep)
    return out
