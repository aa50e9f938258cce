"""The compiled kernels, compiled ahead of a user's first match: `python -m referee.match.warm`,
run once after installation (the Makefile's install does), so that the first match after an
install starts as fast as later ones (docs/decisions/0040-kernels-compiled-at-install.md).

numba compiles a kernel for the argument types of its first call and keeps it in its cache,
and the kernel's table, run without numba, beside it (arena.compiled); a few seconds of a
match on every built-in level, with its noise and ideal, in this process, replays written,
call every kernel a match calls with the types a match gives it.
"""

from __future__ import annotations

import dataclasses
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import levels
from arena import drive
from levels.loader import load_level
from referee.match import paths
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

SECONDS = 3.0  # of each match: enough for every level's lasers to sweep every beacon


def warm(seconds: float = SECONDS) -> float:
    """Run a short match of every built-in level, noisy and ideal, each slot its level's
    default controller in this process, its replay written (and dropped); the CPU seconds it took."""
    began = time.process_time()
    with tempfile.TemporaryDirectory() as folder:
        for name in levels.names():
            level = load_level(levels.path(name))
            level = dataclasses.replace(level, time_limit=min(level.time_limit, seconds))
            teams = [resolve(level.default_controller)] * len(level.robots)
            for ideal in (False, True):
                play_match(level, teams, ideal=ideal, isolate=False, replay=Path(folder) / "warm.replay")
    drive.advance(np.zeros(drive.ROW), 0.0)  # a step in Python calls the drive's equations themselves
    paths.first_near(np.zeros(1), np.zeros(1), 0, 0.0, 0.0, 0.0)  # a one-step period's columns: contiguous
    return time.process_time() - began


def main() -> int:
    took = warm()
    print(f"laserarena: compiled kernels ready ({took:.1f} s of CPU)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
