"""The Python API: `from referee import run_match` with spec strings and Controller classes,
isolated (the class's source shipped into the sandbox) and in-process."""

from __future__ import annotations

import subprocess
import sys

import pytest
from helpers import MINI_LEVEL

SCRIPT = """
import linecache, math, sys
import numpy as np
from referee import run_match
from robots.api import Command, Controller

SPEED = 0.1

def speed():
    return SPEED * math.cos(0.0)

class Straight(Controller):
    def step(self, obs):
        return Command(np.float64(speed()), speed())

level = sys.argv[1]
a = run_match(level, teams=[Straight], ideal=True)
b = run_match(level, teams=[Straight], ideal=True, isolate=False)
# a notebook cell: its source known to linecache only, its globals those of __main__
cell = "class Cell(Controller):\\n    def step(self, obs):\\n        return Command(speed(), speed())\\n"
linecache.cache["<ipython-input-1>"] = (len(cell), None, cell.splitlines(True), "<ipython-input-1>")
exec(compile(cell, "<ipython-input-1>", "exec"), globals())
c = run_match(level, teams=[Cell], ideal=True)
for r in (a, b, c):
    print(r.robots[0].team, len(r.robots[0].faults), *r.robots[0].final_pose, r.robots[0].score.total)
"""


def test_import_referee_loads_nothing_else():
    code = (
        "import sys, referee; print('referee.api' in sys.modules, 'pymunk' in sys.modules, callable(referee.run_match))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.split() == ["False", "False", "True"], out.stderr


def test_classes_from_a_script_and_a_cell_run_isolated(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / "match.py").write_text(SCRIPT)
    out = subprocess.run(
        [sys.executable, "match.py", "level.yaml"], capture_output=True, text=True, cwd=shared_dir, timeout=300
    )
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.splitlines()]
    assert [r[0] for r in rows] == ["Straight", "Straight", "Cell"]
    for _team, faults, x, y, heading, _ in rows:
        assert faults == "0"  # the script's top-level match calls were NOT shipped and re-run
        # both wheels at 0.1 m/s with ideal drive: a straight line along +x from (0.5, 0.5, 0),
        # at most 0.1 m/s x the 4 s of the match
        assert float(y) == pytest.approx(0.5, abs=1e-6) and float(heading) == pytest.approx(0.0, abs=1e-6)
        assert 0.5 + 0.1 * 2 < float(x) <= 0.5 + 0.1 * 4 + 1e-9
    assert rows[0] == rows[1] == [rows[0][0]] + rows[2][1:]  # isolated == in-process == the cell


def test_bad_teams_and_seed_are_one_line_errors():
    from referee import run_match
    from referee.errors import TeamError, UserError

    with pytest.raises(UserError, match="Controller class"):
        run_match("bac-line", teams=[int])
    with pytest.raises(UserError, match="seed"):
        run_match("bac-line", seed=-3)
    with pytest.raises(TeamError, match="nothing.py"):
        run_match("bac-line", teams=["nothing.py"])
