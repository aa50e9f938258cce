"""The install's warm-up (`python -P -m referee.match.warm`, decision 0040) compiles every
kernel a match calls: after it, with its cache alone (a cache folder of the test's own), other
matches of every level, with noise and ideal, their replays written, load every kernel and compile none, so a user's
first match never waits for the compiler. They load them without readying numba to compile
(decision 0045), and numba still compiles what is new afterwards."""

import os
import subprocess
import sys

PROBE = """
import dataclasses
import tempfile
from pathlib import Path
import levels
import numpy as np
from numba import njit
from numba.core import base, event
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

refreshed = []  # numba readying its target context to compile
ready = base.BaseContext.refresh
base.BaseContext.refresh = lambda context: (refreshed.append(context), ready(context))[1]
with event.install_recorder("numba:compile") as compiled, tempfile.TemporaryDirectory() as folder:
    for name in levels.names():
        level = load_level(levels.path(name))
        level = dataclasses.replace(level, time_limit=min(level.time_limit, 8.0))
        teams = [resolve(level.default_controller)] * len(level.robots)
        for ideal in (False, True):
            play_match(level, teams, seed=7, ideal=ideal, isolate=False, replay=Path(folder) / "m.replay")
print("readied to compile:", len(refreshed))
print("a new function:", njit(lambda a: np.sum(a * 2.0))(np.arange(4.0)), "readied:", len(refreshed) > 0)
print(sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in compiled.buffer if e.is_start}))
"""


def test_after_the_warm_up_a_match_compiles_nothing(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    warm = subprocess.run([sys.executable, "-P", "-m", "referee.match.warm"], env=env, capture_output=True, text=True)
    assert warm.returncode == 0, warm.stderr
    assert "compiled kernels ready" in warm.stderr
    probe = subprocess.run([sys.executable, "-P", "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert probe.returncode == 0, probe.stderr
    lines = probe.stdout.splitlines()
    assert lines[-1] == "[]", probe.stdout  # the kernels it had to compile
    assert lines[-3] == "readied to compile: 0", probe.stdout
    assert lines[-2] == "a new function: 12.0 readied: True", probe.stdout
