"""Ratings from heats: openskill's Plackett-Luce model for free-for-all races, updated one heat
at a time in the order the heats were scheduled (so the same heats always give the same
ratings), and per-level mean scores with bootstrap intervals over heats.

A team's rating is the conservative ordinal mu - 3 sigma: a team seen in few heats is not
ranked high on luck. A filler (the level's default controller filling an empty slot) takes
part in each heat's update at the model's initial rating, as a fixed yardstick, and is never
rated itself. A one-robot level's seed (every team's match on it, ranked together) is rated
as a strict order whose tied teams then share their mean update: openskill's own formula for
ties can rate a team that placed lower above one that placed higher.
"""

from __future__ import annotations

import hashlib
from collections.abc import Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from openskill.models import PlackettLuce, PlackettLuceRating

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


def rate(teams: int, heats: list[list[Placing]], seeds: Collection[int] = ()) -> list[list[Rating]]:
    """Every team's rating after each heat, in heat order: `history[h][t]` is team t's rating
    once heats 0..h are counted (the initial rating where a team has not played yet). The
    heats whose index is in `seeds` are a one-robot level's seeds: their ties are shared."""
    from openskill.models import PlackettLuce

    model = PlackettLuce()
    current = [model.rating() for _ in range(teams)]
    history = []
    for h, heat in enumerate(heats):
        rated = [p for p in heat if p.team is not None]
        if len(heat) > 1 and rated:
            players = [current[p.team] if p.team is not None else model.rating() for p in heat]
            if h in seeds:
                updated = _ties_shared(model, players, [p.rank for p in heat])
            else:
                updated = [new for (new,) in model.rate([[r] for r in players], ranks=[p.rank for p in heat])]
            for p, new in zip(heat, updated):
                if p.team is not None:
                    current[p.team] = new
        history.append([Rating(r.mu, r.sigma) for r in current])
    return history


def _ties_shared(model: PlackettLuce, players: list[PlackettLuceRating], places: list[int]) -> list[PlackettLuceRating]:
    """The players' ratings after a heat they finished in `places` (1 best, ties shared): the
    update of a strict order (tied players in the order given), then each group of tied players
    given its mean change of mu and its mean ratio of sigma, so that they stay alike."""
    order = sorted(range(len(players)), key=lambda i: places[i])
    strict = model.rate([[players[i]] for i in order], ranks=list(range(1, len(order) + 1)))
    after = dict(zip(order, (new for (new,) in strict)))
    out = []
    for i, old in enumerate(players):
        tied = [j for j in range(len(players)) if places[j] == places[i]]
        mu = sum(after[j].mu - players[j].mu for j in tied) / len(tied)
        ratio = sum(after[j].sigma / players[j].sigma for j in tied) / len(tied)
        out.append(model.rating(mu=old.mu + mu, sigma=old.sigma * ratio))
    return out


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
