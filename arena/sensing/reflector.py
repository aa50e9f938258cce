"""Reflectors (Vannoy 2001, Ubersetzig 1999): robot-side detection, each return unlabelled and
for the robot whose laser it was, at the exact crossing, within a range and an incidence limit; a head
on a stepped mount (`quantization` steps per turn) reads the step it stands at, and when it got
there. Its false returns carry no label, and a stepped head's angle.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from arena.angles import TWO_PI
from arena.sensing.crossings import Crossings, Trajectory
from arena.sensing.events import Detection, event_order
from arena.sensing.optics import incidence
from arena.sensing.readout import quantize_angle


def visible(c: Crossings, facing: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Which crossings are within the reflector's range and incidence limit."""
    return (c.distance <= p["range"]) & (incidence(c, facing) <= p["max_incidence"])


def step_time(t: np.ndarray, phase: np.ndarray, omega: np.ndarray, steps: float, start: float) -> np.ndarray:
    """When a stepped head (`steps` per turn) reached the step it read each return at: it sees a
    return while it stands at a step, so the time says no more of the angle than the step does.
    `phase` is the laser's phase at `t` and `omega` its rate; no earlier than `start`, the
    period's (a head turning clockwise reaches a step at its far edge)."""
    q = TWO_PI / steps
    rel = np.mod(phase, TWO_PI)
    into = rel - np.floor(rel / q + 1e-9) * q
    back = np.where(omega > 0, into, q - into)
    return np.maximum(t - back / np.abs(omega), start)


def false_returns(
    traj: Trajectory, r: int, times: np.ndarray, omega: np.ndarray, p: Mapping[str, float]
) -> list[Detection]:
    """Robot `r`'s spurious returns at `times` (sorted), in event order: no label, and with a
    stepped head the step's angle and the time it got there."""
    events = []
    steps = p["quantization"]
    for t in times:
        angle = None
        if steps:
            k = min(int(np.searchsorted(traj.t, t)) - 1, len(traj.t) - 2)
            s = (t - traj.t[k]) / (traj.t[k + 1] - traj.t[k])
            phase = np.array([traj.phi[k, r] + s * (traj.phi[k + 1, r] - traj.phi[k, r])])
            angle = float(quantize_angle(phase, steps)[0])
            t = float(step_time(np.array([t]), phase, omega[r : r + 1], steps, float(traj.t[0]))[0])
        events.append(Detection(r, float(t), "hit", None, angle, source=-1))
    if steps:
        events.sort(key=event_order)  # two returns at one step: its time, rounded either way
    return events
