"""Ratings from heats: openskill's Plackett-Luce model for free-for-all races, updated one heat
at a time in the order the heats were scheduled (so the same heats always give the same
ratings), and per-level mean scores with bootstrap intervals over heats.

A team's rating is the conservative ordinal mu - 3 sigma: a team seen in few heats is not
ranked high on luck. A filler (the level's default controller filling an empty slot) takes
part in each heat's update at the model's initial rating, as a fixed yardstick, and is never
rated itself.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

BOOTSTRAP = 2000  # resamples of a team's heats for its per-level interval


@dataclass(frozen=True)
class Placing:
    """One robot of a heat: its team (index in the team list, None for a filler), its score
    and its rank in the heat (1 is best; robots with equal scores share a rank)."""

    team: int | None
    score: float
    rank: int


def ranks(scores: list[float]) -> list[int]:
    """Competition ranks of scores, highest first: 1 + how many scored strictly more."""
    return [1 + sum(other > s for other in scores) for s in scores]


@dataclass(frozen=True)
class Rating:
    """A team's rating: openskill's mu and sigma, and the ordinal mu - 3 sigma it is ranked by."""

    mu: float
    sigma: float

    @property
    def ordinal(self) -> float:
        return self.mu - 3 * self.sigma


def rate(teams: int, heats: list[list[Placing]]) -> list[list[Rating]]:
    """Every team's rating after each heat, in heat order: `history[h][t]` is team t's rating
    once heats 0..h are counted (the initial rating where a team has not played yet)."""
    from openskill.models import PlackettLuce

    model = PlackettLuce()
    current = [model.rating() for _ in range(teams)]
    history = []
    for heat in heats:
        rated = [p for p in heat if p.team is not None]
        if len(heat) > 1 and rated:
            players = [[current[p.team] if p.team is not None else model.rating()] for p in heat]
            updated = model.rate(players, ranks=[p.rank for p in heat])
            for p, (new,) in zip(heat, updated):
                if p.team is not None:
                    current[p.team] = new
        history.append([Rating(r.mu, r.sigma) for r in current])
    return history


def bootstrap(scores: list[float], label: str) -> tuple[float, float, float]:
    """Mean score and its 95 % percentile-bootstrap interval (low, high) over heats, from a
    generator seeded by `label`, so the same scores under the same label give the same figures."""
    values = np.asarray(scores, dtype=float)
    mean = float(values.mean())
    if len(values) < 2:
        return mean, mean, mean
    seed = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "big")
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, len(values), size=(BOOTSTRAP, len(values)))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return mean, float(low), float(high)
