"""One seeded random tree per match: an independent, reproducible stream per robot and subsystem.

Streams are named (`tree.stream("robot", 2, "laser")`), not drawn in sequence, so adding a
new consumer never shifts the numbers an existing one sees.
"""

from __future__ import annotations

import zlib

import numpy as np


class RandomTree:
    """The root of a match's randomness, built from the match seed."""

    def __init__(self, seed: int):
        self.seed = seed

    def stream(self, *path: str | int) -> np.random.Generator:
        """The generator for one named branch of the tree; same seed and path, same numbers."""
        key = tuple(zlib.crc32(str(p).encode()) for p in path)
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.seed, spawn_key=key)))
