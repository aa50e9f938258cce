"""Each robot's standard normal draws from a stream of its own, drawn ahead in blocks, so that a
compiled pass takes as many as it needs without coming back to Python between its stages.

A Generator's normals do not depend on how many are drawn at a time (its ziggurat keeps no
value over from one call to the next), so a pass that takes them in order from the block gets
the very numbers it would get by drawing them one batch at a time, and `loc + scale * z` is
the value `normal(loc, scale)` gives.
"""

from __future__ import annotations

import numpy as np

# no block: what a kernel takes where a robot draws none (its block has no rows, its positions none)
NO_DRAWS = (np.zeros((0, 0)), np.zeros(0, np.int64))


class Normals:
    """Standard normal draws per robot (`streams`, one Generator each), kept ahead in a block a
    row per robot, with each robot's position in its row (`at`): a kernel reads row r from
    `at[r]` on and moves `at[r]` past what it took. A row holds `ahead` times a batch's need,
    and a look refills every row that has used half of it (a Generator call per robot): after a
    look each row holds at least half, so the next comes `ahead / 2 - 1` batches later at the soonest."""

    def __init__(self, streams: list[np.random.Generator], ahead: int = 16, at: np.ndarray | None = None):
        self.streams, self.ahead = streams, ahead
        self.values = np.zeros((len(streams), 0))
        self.at = np.zeros(len(streams), np.int64) if at is None else at  # `at`: kept where the caller says
        self.left = 0  # what every row still holds for sure: at the last look, less the needs handed out since

    def ready(self, need: int) -> tuple[np.ndarray, np.ndarray]:
        """The block and the positions, with at least `need` draws left in every robot's row
        (what is left is moved to the row's start and the rest drawn anew). A batch takes no
        more than its need, so rows are looked at only when the needs handed out since the
        last look may have used up what they held then."""
        if self.left >= need:
            self.left -= need
            return self.values, self.at
        return self.refill(need)

    def refill(self, need: int) -> tuple[np.ndarray, np.ndarray]:
        """`ready`, looking at every row now: for a caller that reads the positions itself and
        knows when a row runs short (sweep.sense_period says so), and so calls nothing here otherwise."""
        values, at = self._refilled(need)
        self.left = values.shape[1] - max(at.tolist(), default=0) - need
        return values, at

    def _refilled(self, need: int) -> tuple[np.ndarray, np.ndarray]:
        """`ready`'s look at every row: each with less than half its width (and at least `need`) left refilled."""
        width = self.values.shape[1]
        if width < self.ahead * need:
            wider = np.zeros((len(self.streams), self.ahead * need))
            for r, at in enumerate(self.at.tolist()):
                left = width - at
                wider[r, :left] = self.values[r, at:]
                self.streams[r].standard_normal(out=wider[r, left:])
            self.values, width = wider, self.ahead * need
            self.at[:] = 0
            return self.values, self.at
        low = max(width // 2, need)
        for r, at in enumerate(self.at.tolist()):
            if width - at < low:
                left = width - at
                self.values[r, :left] = self.values[r, at:]
                self.streams[r].standard_normal(out=self.values[r, left:])
                self.at[r] = 0
        return self.values, self.at
