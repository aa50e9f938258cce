"""Lights and a sampled turret (Osentoski): active lights, and a photoresistor on each robot's
turret that takes `samples_per_turn` brightness samples per turn; a full turn of samples is one
`scan` event.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.angles import TWO_PI, wrap_angle
from arena.sensing.crossings import Trajectory, find_phase_marks
from arena.sensing.events import Detection
from arena.sensing.occlusion import Occlusion


def brightness(delta: np.ndarray, distance: np.ndarray, visible_: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Osentoski's turret photoresistor on the 0 (bright) .. 255 (dark) scale, before noise.

    Each visible light adds a Gaussian beam profile (FWHM `beam_width`) around its bearing,
    saturating within `saturation_range`; lights add up, and the sum saturates at full brightness.
    `delta` and `distance` are (samples, lights)."""
    sigma = p["beam_width"] / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    near = np.minimum(1.0, (p["saturation_range"] / distance) ** 2)
    light = np.where(visible_, near * np.exp(-0.5 * (delta / sigma) ** 2), 0.0)
    return 255.0 * (1.0 - np.minimum(1.0, light.sum(axis=1)))


class Turrets:
    """Every robot's turret and the turns of samples it has begun (spin sign `direction` per
    robot, `streams` each robot's light stream, the lights where `occlusion` has them)."""

    def __init__(
        self, p: Mapping[str, float], direction: np.ndarray, streams: list[np.random.Generator], occlusion: Occlusion
    ):
        self.params, self.direction, self.streams, self.occlusion = p, direction, streams, occlusion
        self.scans: dict[tuple[int, int], np.ndarray] = {}  # (robot, turn) -> light samples

    def moved(self) -> None:
        """The robots were carried to new poses: a turn begun before is no scan of where they stand."""
        self.scans.clear()

    def scan(self, traj: Trajectory, lasers: Trajectory) -> list[list[Detection]]:
        """Samples at relative angles 2 pi k / N, taken where the turret stands (`lasers`); a
        full turn of samples is one `scan` event at the time of its last sample, per robot."""
        out: list[list[Detection]] = [[] for _ in range(len(self.direction))]
        p = self.params
        per_turn = int(p["samples_per_turn"])
        robot, step, s, t, mark = find_phase_marks(traj, per_turn, self.direction)
        if not len(robot):
            return out
        x, y, h = lasers.pose_at(step, s, robot)
        k = mark % per_turn
        beam = h + TWO_PI * k / per_turn
        if p["servo_jitter"] > 0:
            beam = beam + np.concatenate([self.streams[r].normal(0.0, p["servo_jitter"], 1) for r in robot])
        bx, by = self.occlusion.bx, self.occlusion.by
        m, nl = len(robot), len(bx)
        rep = np.repeat(np.arange(m), nl)
        lights = np.tile(np.arange(nl), m)
        blocked = self.occlusion.blocked(traj, robot[rep], step[rep], s[rep], x[rep], y[rep], lights).reshape(m, nl)
        dx, dy = bx[None, :] - x[:, None], by[None, :] - y[:, None]
        delta = wrap_angle(beam[:, None] - np.arctan2(dy, dx))
        value = brightness(delta, np.hypot(dx, dy), ~blocked, p)
        for i in range(m):
            r, turn = int(robot[i]), int(mark[i] // per_turn)
            v = value[i]
            if p["brightness_noise"] > 0:
                v = v + self.streams[r].normal(0.0, p["brightness_noise"])
            scan = self.scans.setdefault((r, turn), np.full(per_turn, -1.0))
            scan[k[i]] = max(0.0, min(255.0, v))
            if (scan >= 0).all():  # a full turn (the very first may lack its sample at t = 0)
                del self.scans[(r, turn)]
                samples = tuple(int(round(u)) for u in scan)
                out[r].append(Detection(r, float(t[i]), "scan", samples=samples, source=r))
        return out
