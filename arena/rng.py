"""One seeded random tree per match: an independent, reproducible stream per robot and subsystem.

Streams are named (`tree.stream("robot", 2, "laser")`), not drawn in sequence, so adding a
new consumer never shifts the numbers an existing one sees.
"""

from __future__ import annotations

import zlib

import numpy as np


class RandomTree:
    """The root of a match's randomness, built from the match seed and, in graded matches,
    a secret noise key (hex, 256 bits) that no controller can read: with a key, the public
    seed alone does not reproduce a single number."""

    def __init__(self, seed: int, noise_key: str | None = None):
        self.seed = seed
        self.entropy = seed if noise_key is None else [seed, int(noise_key, 16)]

    def stream(self, *path: str | int) -> np.random.Generator:
        """The generator for one named branch of the tree; same seed, key and path, same numbers."""
        key = tuple(zlib.crc32(str(p).encode()) for p in path)
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.entropy, spawn_key=key)))
