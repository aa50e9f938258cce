"""Who plays whom, from which start: a tournament's heats on one level.

Each round splits the teams into groups of at most as many teams as the level has robot
slots, choosing the split that keeps every pair's meetings as even as possible; a group with
fewer teams than slots is filled with the level's default controller (marked as a filler,
never rated). Each group then plays one heat per slot, its lineup rotated one slot each time
(a cyclic Latin square), so over a round every entry starts from every slot exactly once and
no team wins by its start position. A level of one slot has nothing to group or rotate:
every team plays alone each round, in team order (and on the round's seed, so that the
teams are compared on the same seeds: referee.contest.tournaments).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

SPLIT_TRIES = 16  # random splits tried per round (seeded), each improved by swaps: the most even is kept


@dataclass(frozen=True)
class Entry:
    """A robot slot's controller in a heat: a rated team (its index in the team list) or a
    filler (the level's default controller, index None)."""

    team: int | None

    @property
    def filler(self) -> bool:
        return self.team is None


@dataclass(frozen=True)
class Lineup:
    """One heat's entries in slot order, with its round (from 1)."""

    round: int
    entries: tuple[Entry, ...]


def _sizes(teams: int, slots: int) -> list[int]:
    """Group sizes: as few groups as slots allow, their sizes as even as possible."""
    groups = -(-teams // slots)
    return [teams // groups + (1 if i < teams % groups else 0) for i in range(groups)]


def _cost(groups: list[list[int]], met: np.ndarray) -> tuple[int, int, int]:
    """How uneven the pairs' meeting counts are once `groups` have played: (max - min, max, sum
    of squares); the total is fixed by the group sizes, so a smaller sum of squares is more even."""
    after = met.copy()
    for group in groups:
        for a, b in itertools.combinations(group, 2):
            after[a, b] += 1
            after[b, a] += 1
    pairs = after[np.triu_indices(len(met), 1)]
    return int(pairs.max() - pairs.min()), int(pairs.max()), int((pairs**2).sum())


def _split(teams: int, slots: int, met: np.ndarray, rng: np.random.Generator) -> list[list[int]]:
    """The grouping for one round that least unbalances the pairs' meeting counts: random
    splits (seeded), each improved by swapping two teams between groups while that helps."""
    sizes = _sizes(teams, slots)
    if len(sizes) == 1:
        return [list(range(teams))]
    best: tuple[tuple[int, int, int], list[list[int]]] | None = None
    for _ in range(SPLIT_TRIES):
        order = [int(t) for t in rng.permutation(teams)]
        groups = [order[sum(sizes[:g]) : sum(sizes[: g + 1])] for g in range(len(sizes))]
        cost = _cost(groups, met)
        improved = True
        while improved:
            improved = False
            for g, h in itertools.combinations(range(len(groups)), 2):
                for i, j in itertools.product(range(len(groups[g])), range(len(groups[h]))):
                    groups[g][i], groups[h][j] = groups[h][j], groups[g][i]
                    c = _cost(groups, met)
                    if c < cost:
                        cost, improved = c, True
                    else:
                        groups[g][i], groups[h][j] = groups[h][j], groups[g][i]
        if best is None or cost < best[0]:
            best = (cost, [sorted(g) for g in groups])
    assert best is not None
    return best[1]


def schedule(teams: int, slots: int, rounds: int, seed: int = 0) -> list[Lineup]:
    """Every heat of `rounds` rounds for `teams` rated teams on a level of `slots` slots, in
    the order they are played (and rated). Deterministic for the same arguments."""
    if teams < 1 or slots < 1 or rounds < 1:
        raise ValueError("a schedule needs at least one team, one slot and one round")
    if slots == 1:
        return [Lineup(r, (Entry(t),)) for r in range(1, rounds + 1) for t in range(teams)]
    rng = np.random.default_rng(seed)
    met = np.zeros((teams, teams), dtype=np.int64)
    heats = []
    for r in range(1, rounds + 1):
        for group in _split(teams, slots, met, rng):
            for a, b in itertools.combinations(group, 2):
                met[a, b] += 1
                met[b, a] += 1
            entries = [Entry(t) for t in group] + [Entry(None)] * (slots - len(group))
            for shift in range(slots):  # entry i starts from slot (i + shift) mod slots
                placed: list[Entry] = [Entry(None)] * slots
                for i, e in enumerate(entries):
                    placed[(i + shift) % slots] = e
                heats.append(Lineup(r, tuple(placed)))
    return heats
