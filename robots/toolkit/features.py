"""The observation vector of LaserArena's learning envs, computed from what a controller sees.

Team-side on purpose: the envs (referee.gym) encode their observations with this code, and a
controller that plays a trained policy (robots.controllers.policy) encodes its own with the same
code, so a policy sees the same numbers in training and in the sandbox. Only what a controller
can know: its brief, its sensor events, its own commands, and (the `goal` part) the toolkit's
own pose estimate; never the true pose. Layout: docs/rl.md.
"""

from __future__ import annotations

import math

import numpy as np

from robots.api import Brief, Observation
from robots.toolkit.steering import next_waypoint
from robots.toolkit.tracker import HitTracker

AGE_MAX = 5.0  # s: older bearings (and never-seen beacons) read as this old
HEADER = 6  # time, cos/sin of the laser angle, last command (2), index age
PER_BEACON = 4  # cos and sin of the latest bearing, its age, seen (0 / 1)
GOAL = 5  # cos and sin of the next waypoint's bearing, its distance, waypoints passed, pose known
UNSEEN = (0.0, 0.0, AGE_MAX, 0.0)  # a beacon block before its first bearing


class ObservationEncoder:
    """Keeps one robot's latest bearings and encodes them as a float32 vector of fixed size.

    Labelled hardware (sensor arrays, flash detectors: the event names its beacon) fills one
    block per beacon of the brief, in the brief's order. Unlabelled returns (reflectors) cannot
    be told apart, so the blocks hold the most recent returns, newest first. A light level adds
    the latest turret scan, brightness / 255. A bearing is the laser angle the hardware latched,
    else the nominal one, angular_velocity x time (phase 0 is straight ahead at t = 0,
    docs/sensors.md). With `goal`, a last block says where the task's next waypoint lies in the
    robot's own frame, by the toolkit's HitTracker (fed these events and the commands given)."""

    def __init__(self, brief: Brief, samples_per_turn: int = 0, goal: bool = False):
        self.brief = brief
        self.ids = [b.id for b in brief.beacons]
        self.block = {beacon: k for k, beacon in reversed(list(enumerate(self.ids)))}  # an id's first block
        self.spin = brief.laser.angular_velocity
        self.samples = samples_per_turn if brief.beacon_kind == "light" else 0
        self.goal = goal
        task = brief.task
        self.path = list(task.path) if task.path else ([task.goal] if task.goal else [])
        self.base = HEADER + PER_BEACON * len(self.ids) + self.samples  # where the goal block starts
        self.size = self.base + (GOAL if goal else 0)
        low = np.zeros(self.size, dtype=np.float32)
        high = np.ones(self.size, dtype=np.float32)
        low[1:5] = -1.0
        high[5] = AGE_MAX
        for k in range(len(self.ids)):
            i = HEADER + PER_BEACON * k
            low[i : i + 2] = -1.0
            high[i + 2] = AGE_MAX
        if goal:
            low[self.base : self.base + 2] = -1.0
        self.low, self.high = low, high
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new match."""
        self._forget()
        self.trial = 0
        self.target = 0  # the next waypoint, by the estimate
        self.tracker = HitTracker(self.brief) if self.goal else None

    def _forget(self) -> None:
        """Forget what was seen and commanded (a new match, or a new localize trial)."""
        self.hits: list[tuple[float, float] | None] = [None] * len(self.ids)  # (angle, time) per block
        self.index_time: float | None = None
        self.scan = np.zeros(self.samples, dtype=np.float32)
        self.command = (0.0, 0.0)

    def bearing(self, time: float, angle: float | None) -> float:
        """The laser's angle relative to the robot at an event: latched, else nominal."""
        return angle if angle is not None else math.fmod(self.spin * time, 2 * math.pi)

    def take(self, obs: Observation) -> None:
        """Take in one control tick's events (a new localize trial: the robot was carried
        elsewhere and set down at rest, so what was seen and commanded before is void)."""
        if obs.trial != self.trial:
            self._forget()
            self.trial = obs.trial
            if self.tracker is not None:
                self.tracker.reset()
        for e in obs.events:
            if e.kind == "index":
                self.index_time = e.time
            elif e.kind == "scan" and self.samples:
                self.scan = np.asarray(e.samples[: self.samples], dtype=np.float32) / 255.0
            elif e.kind == "hit":
                hit = (self.bearing(e.time, e.angle), e.time)
                k = self.block.get(e.beacon) if e.beacon is not None else None
                if k is not None:
                    self.hits[k] = hit
                elif self.hits:  # unlabelled: newest first
                    self.hits = [hit, *self.hits[:-1]]
        if self.tracker is not None:
            self.tracker.feed(obs.events, obs.time)
            pose = self.tracker.pose
            if pose is not None:
                self.target = next_waypoint(self.path, self.target, pose[0], pose[1], self.brief.task.radius / 2)

    def commanded(self, left: float, right: float) -> None:
        """The wheel command (m/s) just given for the coming control period."""
        self.command = (left, right)
        if self.tracker is not None:
            self.tracker.command(left, right)

    def encode(self, time: float) -> np.ndarray:
        """The vector at `time` (the control tick's clock). Built as a list of floats, made
        float32 and clipped in place, with a fraction of the NumPy calls of a vector filled in
        place (it is computed at every env step); the bounds are exact in float32, so clipping
        after the rounding gives the numbers clipping before it would."""
        a = self.bearing(time, None)
        top = self.brief.robot.max_wheel_speed
        left, right = self.command
        v = [
            min(1.0, time / self.brief.time_limit),
            math.cos(a),
            math.sin(a),
            max(-1.0, min(1.0, left / top)),
            max(-1.0, min(1.0, right / top)),
            AGE_MAX if self.index_time is None else min(AGE_MAX, time - self.index_time),
        ]
        for hit in self.hits:
            if hit is None:
                v += UNSEEN
            else:
                angle, t = hit
                v += (math.cos(angle), math.sin(angle), min(AGE_MAX, time - t), 1.0)
        if self.samples:
            v += self.scan.tolist()
        if self.goal:
            v += self._goal()
        out = np.array(v, dtype=np.float32)
        np.maximum(out, self.low, out=out)
        np.minimum(out, self.high, out=out)
        return out

    def _goal(self) -> tuple[float, float, float, float, float]:
        """The goal block: cos and sin of the next waypoint's bearing from the estimated heading,
        its distance / the field's diagonal, the fraction of waypoints passed, pose known (0 / 1).
        The next waypoint is the first the estimate has not yet come within half the task's
        radius of, as the reference controllers count (steering.next_waypoint). A pose not
        known yet reads (0, 0, 1, passed, 0); no waypoint left reads (0, 0, 0, 1, known)."""
        assert self.tracker is not None
        pose = self.tracker.pose
        passed = self.target / len(self.path) if self.path else 1.0
        if pose is None:
            return 0.0, 0.0, 1.0, passed, 0.0
        x, y, heading = pose
        if self.target >= len(self.path):
            return 0.0, 0.0, 0.0, 1.0, 1.0
        tx, ty = self.path[self.target]
        xmin, ymin, xmax, ymax = self.brief.field
        bearing = math.atan2(ty - y, tx - x) - heading
        distance = math.dist((x, y), (tx, ty)) / math.hypot(xmax - xmin, ymax - ymin)
        return math.cos(bearing), math.sin(bearing), distance, self.target / len(self.path), 1.0
