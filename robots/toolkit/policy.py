"""A trained policy as plain numpy weights, and the command an action stands for.

The envs (referee.gym) turn an action into a `Command` with `command`, and so does a
controller that plays a policy (robots.controllers.policy): the same action drives the same
wheels in training and in the sandbox. A `Policy` is a small MLP (tanh hidden layers, tanh
output, so actions lie in -1..1) saved as an `.npz` of arrays, readable by numpy alone
(docs/rl.md).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import IO, Any

import numpy as np

from robots.api import Brief, Command

FORMAT = 1  # the .npz layout: w0, b0, w1, b1, ... plus format, goal, samples_per_turn


def _unit(x: float) -> float:
    """`x` clipped to -1..1, as np.clip gives it (NaN stays NaN), without a NumPy call."""
    return -1.0 if x < -1.0 else 1.0 if x > 1.0 else x


def command(action: np.ndarray, brief: Brief) -> Command:
    """The command an env action stands for: wheel speeds as fractions of the top speed (the
    first two components, clipped to -1..1); three more, if given, are the pose estimate the
    referee scores, x and y scaled so that -1..1 spans the field, heading / pi."""
    a = np.asarray(action, dtype=np.float64).tolist()
    top = brief.robot.max_wheel_speed
    left, right = _unit(a[0]) * top, _unit(a[1]) * top
    if len(a) < 5:
        return Command(left, right)
    xmin, ymin, xmax, ymax = brief.field
    u = [_unit(v) for v in a[2:5]]
    estimate = (xmin + (u[0] + 1) / 2 * (xmax - xmin), ymin + (u[1] + 1) / 2 * (ymax - ymin), u[2] * math.pi)
    return Command(left, right, estimate)


class Policy:
    """An MLP from observation to action: `weights` and `biases` per layer (weights of shape
    (inputs, outputs)); `goal` and `samples_per_turn` are the encoder's options it was trained
    with (robots.toolkit.features.ObservationEncoder)."""

    def __init__(
        self,
        weights: list[np.ndarray],
        biases: list[np.ndarray],
        goal: bool = False,
        samples_per_turn: int = 0,
    ):
        if not weights or len(weights) != len(biases):
            raise ValueError("a policy has one bias per weight matrix, and at least one layer")
        for k, (w, b) in enumerate(zip(weights, biases)):
            if w.ndim != 2 or b.shape != (w.shape[1],) or (k and w.shape[0] != weights[k - 1].shape[1]):
                raise ValueError(f"layer {k}: weights {w.shape} and bias {b.shape} do not chain")
        self.weights = [np.asarray(w, dtype=np.float64) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in biases]
        self.goal, self.samples_per_turn = goal, samples_per_turn

    @property
    def inputs(self) -> int:
        """The observation size it takes."""
        return self.weights[0].shape[0]

    @property
    def outputs(self) -> int:
        """The action size it gives: 2 (wheels) or 5 (wheels and a pose estimate)."""
        return self.weights[-1].shape[1]

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The action for one observation."""
        h = np.asarray(observation, dtype=np.float64)
        for w, b in zip(self.weights, self.biases):
            h = np.tanh(h @ w + b)
        return h

    def save(self, file: str | Path | IO[bytes]) -> None:
        """Write it as an .npz (numpy arrays only: loading runs no code)."""
        arrays: dict[str, Any] = {"format": FORMAT, "goal": self.goal, "samples_per_turn": self.samples_per_turn}
        arrays |= {f"w{k}": w for k, w in enumerate(self.weights)} | {f"b{k}": b for k, b in enumerate(self.biases)}
        np.savez(file, **arrays)

    @classmethod
    def load(cls, file: str | Path | IO[bytes]) -> Policy:
        """Read a policy that `save` wrote."""
        with np.load(file, allow_pickle=False) as z:
            if int(z["format"]) != FORMAT:
                raise ValueError(f"policy format {int(z['format'])}: this toolkit reads format {FORMAT}")
            n = sum(1 for k in z.files if k.startswith("w"))
            return cls(
                [z[f"w{k}"] for k in range(n)],
                [z[f"b{k}"] for k in range(n)],
                bool(z["goal"]),
                int(z["samples_per_turn"]),
            )
