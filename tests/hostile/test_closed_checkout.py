"""A root referee run from a folder other users cannot enter (a container's /root, a 0700
clone) still starts its controllers: what they need is handed into their sandboxes."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import robots
from hostile.hostile_kit import laserarena, team_file


def test_run_from_a_closed_folder(tmp_path):
    closed = tmp_path / "closed"
    closed.mkdir(mode=0o700)
    site = Path(robots.__file__).resolve().parent.parent
    for package in ("arena", "referee", "robots", "levels"):  # the whole product, closed to all but its owner
        shutil.copytree(site / package, closed / package)
    team = team_file(
        closed,
        """
class Drive(Controller):
    def step(self, obs):
        return Command(0.05, 0.05, estimate=(0.5, 0.35, 0.0))
""",
        "team.py",
    )
    os.chmod(team, 0o600)
    done = laserarena(
        "run",
        "asabe",
        "--seed",
        "2",
        "--team",
        "team.py",
        "--json",
        "result.json",
        "--quiet",
        cwd=closed,
        env={**os.environ, "PYTHONPATH": str(closed)},
    )
    assert done.returncode == 0 and done.stderr == "", done.stderr
    result = json.loads((closed / "result.json").read_text())
    assert result["robots"][0]["faults"] == [] and result["robots"][0]["localization"]["fraction"] == 1.0
    # and such a run takes `robots` from the closed copy, not from the installed package
    where = subprocess.run(
        [sys.executable, "-c", "import robots; print(robots.__file__)"],
        capture_output=True,
        text=True,
        cwd=closed,
        env={**os.environ, "PYTHONPATH": str(closed)},
        timeout=60,
    )
    assert Path(where.stdout.strip()).parent == closed / "robots"
