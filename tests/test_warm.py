"""The install's warm-up (`python -P -m referee.match.warm`, decision 0040) compiles every
kernel a match calls: after it, with its cache alone (a cache folder of the test's own), other
matches of every level, with noise and ideal, their replays written, load every kernel and compile none, so a user's
first match never waits for the compiler."""

import os
import subprocess
import sys

PROBE = """
import dataclasses
import tempfile
from pathlib import Path
import levels
from numba.core import event
from arena.loader import load_level
from referee.match.loop import run_match
from referee.sandbox.teams import resolve

with event.install_recorder("numba:compile") as compiled, tempfile.TemporaryDirectory() as folder:
    for name in levels.names():
        level = load_level(levels.path(name))
        level = dataclasses.replace(level, time_limit=min(level.time_limit, 8.0))
        teams = [resolve(level.default_controller)] * len(level.robots)
        for ideal in (False, True):
            run_match(level, teams, seed=7, ideal=ideal, isolate=False, replay=Path(folder) / "m.replay")
print(sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in compiled.buffer if e.is_start}))
"""


def test_after_the_warm_up_a_match_compiles_nothing(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    warm = subprocess.run([sys.executable, "-P", "-m", "referee.match.warm"], env=env, capture_output=True, text=True)
    assert warm.returncode == 0, warm.stderr
    assert "compiled kernels ready" in warm.stderr
    probe = subprocess.run([sys.executable, "-P", "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert probe.returncode == 0, probe.stderr
    assert probe.stdout.splitlines()[-1] == "[]", probe.stdout  # the kernels it had to compile
