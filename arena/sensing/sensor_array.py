"""Sensor arrays (Bac et al. 2011): beacon-side detection, each pulse labelled with its array.
An array's phototransistors fall off with incidence (its response, and the chance that a sweep
fires, in closed form); Bac's merged measurements (compiled, from a counter-based hash);
its false pulses carry a uniformly drawn array's label; and under shared crosstalk each
array's one line makes one flank at a time, for every controller.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from arena.compiled import compiled
from arena.sensing.events import Detection, event_order
from arena.sensing.optics import spot_width
from arena.sensing.readout import counter_clock

_erf = np.vectorize(math.erf, otypes=[float])  # the error function, elementwise
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)  # SplitMix64's constants
_MIX = np.uint64(0xD1B54A32D192ED03)
_MUL1, _MUL2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_LOW11 = np.uint64(0x7FF)


def array_response(inc: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """A nominal sensor array's response at this incidence, relative to head-on:
    2^-(incidence / acceptance)^2 (1 without an acceptance)."""
    acc = p.get("acceptance", math.inf)
    return np.exp2(-((inc / acc) ** 2)) if math.isfinite(acc) else np.ones(np.shape(inc))


def array_fire_chance(
    distance: np.ndarray, speed: np.ndarray, inc: np.ndarray, gain: float, p: Mapping[str, float]
) -> np.ndarray:
    """The chance that one sweep of a sensor array of this `gain` fires, at this range, beam
    speed across it (|beam rate| x range) and incidence: what `optics` asks of the response S x f
    (f the sweep's light factor, log-normal with std `light_noise` of its log), in closed form.

    The light must reach the threshold at all, S f min(1, a / w) >= eta, and stay above it for
    `rise_time`, (w + a - 2 eta w / (S f)) / v >= rise: so f >= need / S with need = eta w /
    min(w, a) or 2 eta w / (w + a - v rise), the larger (never, if v rise >= w + a), and the
    chance is Phi(ln(S / need) / light_noise); with no light noise, 1 or 0."""
    w = spot_width(distance, p)
    a = p.get("aperture", 0.0) * np.cos(inc)
    eta, sigma = p.get("trigger_fraction", 0.0), p.get("light_noise", 0.0)
    s = gain * array_response(inc, p)
    room = w + a - speed * p.get("rise_time", 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(room > 0, np.maximum(eta * w / np.minimum(w, a), 2 * eta * w / room), np.inf)
        margin = np.log(s / need)
    if not sigma > 0:
        return (margin >= 0).astype(float)
    return 0.5 * (1.0 + _erf(margin / (sigma * math.sqrt(2.0))))


def false_pulses(
    r: int, times: np.ndarray, g: np.random.Generator, ids: list[str], p: Mapping[str, float]
) -> list[Detection]:
    """Robot `r`'s spurious pulses at `times` (sorted), in event order, each with the label of
    an array drawn uniformly (from `g`, the robot's stream) and read by the event clock."""
    labels = g.integers(len(ids), size=len(times))
    events = [
        Detection(r, t, "hit", ids[b], None, source=-1)
        for t, b in zip(counter_clock(times, p).tolist(), labels.tolist())
    ]
    events.sort(key=event_order)  # one clock tick may hold two
    return events


def table_false_pulses(
    times: np.ndarray, g: np.random.Generator, ids: list[str], p: Mapping[str, float]
) -> list[tuple]:
    """Shared crosstalk's false pulses at `times` (sorted) for the whole table, as one robot
    alone would see them, each on an array drawn uniformly: (robot -1, time, label, no angle,
    no beam)."""
    clocked = counter_clock(times, p).tolist()
    labels = g.integers(len(ids), size=len(times)).tolist()
    return [(-1, t, ids[b], None, None) for t, b in zip(clocked, labels)]


class SharedLines:
    """Each array's one output line under shared crosstalk, and when it is next free to make a
    flank; it carries across batches."""

    def __init__(self, arrays: int):
        self.low_until = [-math.inf] * arrays

    def flanks(self, times: list[float], beacon: list[int], low: list[float]) -> list[bool]:
        """Which of a batch's pulses (every robot's, `low` s long each) make a flank on their
        array's one line. Bac: "all 20 phototransistors in the array were placed in parallel",
        pulled up to 5 V, "producing an analog pulse ... when any of the 20 phototransistors in
        the array was triggered"; the comparator feeds a latch that "the negative flank" sets.
        So a sweep that reaches an array while another laser still holds its line low makes no
        flank of its own: it is lost, and the earlier pulse's time stands. How long the line
        stays low is ours: the optics' time above threshold plus the phototransistor's rise
        time to let go (`rise_time`). State carries across batches: a pulse at a period's end
        can hide one at the next period's start."""
        kept = [False] * len(times)
        for i in sorted(range(len(times)), key=times.__getitem__):  # stable: ties keep robot order
            b = beacon[i]
            if times[i] >= self.low_until[b]:
                kept[i] = True
                self.low_until[b] = times[i] + low[i]
        return kept


@compiled()
def revolution_hash(key: np.uint64, robot: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """64 random bits per (match key, robot, revolution): SplitMix64's finaliser, a counter-based
    hash, so a revolution's draw does not depend on which control period its pulses fall in."""
    n = robot.shape[0]
    out = np.empty(n, np.uint64)
    for i in range(n):
        z = key + np.uint64(robot[i]) * _GOLDEN + np.uint64(np.int64(turn[i])) * _MIX
        z = (z ^ (z >> _S30)) * _MUL1
        z = (z ^ (z >> _S27)) * _MUL2
        out[i] = z ^ (z >> _S31)
    return out


@compiled()
def merge(
    times: np.ndarray,
    robot: np.ndarray,
    beacon: np.ndarray,
    turn: np.ndarray,
    n_beacons: int,
    rate: float,
    key: np.uint64,
) -> tuple[np.ndarray, bool]:
    """Bac's hardware error: "occasionally the measured duration of any pulse was added to the
    next pulse duration. If, for example, pulse T_1 and T_2 read 15 and 20 ms, respectively,
    T_2 was occasionally processed as 35 ms" ("about 3.4% of all incoming measurements").

    A measurement is one laser revolution; with probability `rate` (the high 53 bits of
    `revolution_hash`) one of its pulses (array drawn uniformly: the low 11 bits) loses its own
    edge and is reported at the time of the pulse before it, so the duration before it reads 0
    and the one after it reads the sum of both. `times` are sorted by (robot, time); a pulse
    whose predecessor fell in an earlier control period is left alone (its time was already
    delivered). Returns the new times and whether any merged."""
    h = revolution_hash(key, robot, turn)
    out = times.copy()
    changed = False
    for i in range(1, times.shape[0]):
        if np.float64(h[i] >> _S11) * 2.0**-53 >= rate:
            continue
        if np.int64(h[i] & _LOW11) % n_beacons != beacon[i] or robot[i] != robot[i - 1]:
            continue
        out[i] = times[i - 1]
        changed = True
    return out, changed
