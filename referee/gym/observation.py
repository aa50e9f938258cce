"""A fixed-size vector encoding of what a controller sees, for learning agents (docs/rl.md).

Only what a team's controller could compute itself from its brief and its sensor events:
the clock, the laser's nominal angle, its own last command, and per beacon the latest
bearing and how old it is. Never the true pose.
"""

from __future__ import annotations

import math

import numpy as np

from robots.api import Brief, Observation

AGE_MAX = 5.0  # s: older bearings (and never-seen beacons) read as this old
HEADER = 6  # time, cos/sin of the laser angle, last command (2), index age
PER_BEACON = 4  # cos and sin of the latest bearing, its age, seen (0 / 1)


class ObservationEncoder:
    """Keeps one robot's latest bearings and encodes them as a float32 vector of fixed size.

    Labelled hardware (sensor arrays, flash detectors: the event names its beacon) fills one
    block per beacon of the brief, in the brief's order. Unlabelled returns (reflectors) cannot
    be told apart, so the blocks hold the most recent returns, newest first. A light level adds
    the latest turret scan, brightness / 255. A bearing is the laser angle the hardware latched,
    else the nominal one, angular_velocity x time (phase 0 is straight ahead at t = 0,
    docs/sensors.md)."""

    def __init__(self, brief: Brief, samples_per_turn: int = 0):
        self.brief = brief
        self.ids = [b.id for b in brief.beacons]
        self.samples = samples_per_turn if brief.beacon_kind == "light" else 0
        self.size = HEADER + PER_BEACON * len(self.ids) + self.samples
        low = np.zeros(self.size, dtype=np.float32)
        high = np.ones(self.size, dtype=np.float32)
        low[1:5] = -1.0
        high[5] = AGE_MAX
        for k in range(len(self.ids)):
            i = HEADER + PER_BEACON * k
            low[i : i + 2] = -1.0
            high[i + 2] = AGE_MAX
        self.low, self.high = low, high
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new match."""
        self.hits: list[tuple[float, float] | None] = [None] * len(self.ids)  # (angle, time) per block
        self.index_time: float | None = None
        self.scan = np.zeros(self.samples, dtype=np.float32)
        self.command = (0.0, 0.0)
        self.trial = 0

    def bearing(self, time: float, angle: float | None) -> float:
        """The laser's angle relative to the robot at an event: latched, else nominal."""
        return angle if angle is not None else math.fmod(self.brief.laser.angular_velocity * time, 2 * math.pi)

    def take(self, obs: Observation) -> None:
        """Take in one control tick's events (a new localize trial: the robot was carried
        elsewhere and set down at rest, so what was seen and commanded before is void)."""
        if obs.trial != self.trial:
            self.reset()
            self.trial = obs.trial
        for e in obs.events:
            if e.kind == "index":
                self.index_time = e.time
            elif e.kind == "scan" and self.samples:
                self.scan = np.asarray(e.samples[: self.samples], dtype=np.float32) / 255.0
            elif e.kind == "hit":
                hit = (self.bearing(e.time, e.angle), e.time)
                if e.beacon is not None and e.beacon in self.ids:
                    self.hits[self.ids.index(e.beacon)] = hit
                elif self.hits:  # unlabelled: newest first
                    self.hits = [hit, *self.hits[:-1]]

    def encode(self, time: float) -> np.ndarray:
        """The vector at `time` (the control tick's clock)."""
        v = np.zeros(self.size, dtype=np.float64)
        v[0] = min(1.0, time / self.brief.time_limit)
        a = self.bearing(time, None)
        v[1], v[2] = math.cos(a), math.sin(a)
        top = self.brief.robot.max_wheel_speed
        v[3], v[4] = (max(-1.0, min(1.0, c / top)) for c in self.command)
        v[5] = AGE_MAX if self.index_time is None else min(AGE_MAX, time - self.index_time)
        for k, hit in enumerate(self.hits):
            i = HEADER + PER_BEACON * k
            if hit is None:
                v[i + 2] = AGE_MAX
                continue
            angle, t = hit
            v[i], v[i + 1], v[i + 2], v[i + 3] = math.cos(angle), math.sin(angle), min(AGE_MAX, time - t), 1.0
        if self.samples:
            v[HEADER + PER_BEACON * len(self.ids) :] = self.scan
        return np.clip(v, self.low, self.high).astype(np.float32)
