"""A root referee run from a folder other users cannot enter (a container's /root, a 0700
clone) still starts its controllers: what they need is handed into their sandboxes."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from helpers import edited

import robots
from hostile.hostile_kit import HONEST, laserarena, team_file


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


def test_run_with_laserarena_installed_under_tmp(tmp_path):
    # a virtual environment under /tmp (a clone there, `python -m venv .venv`), which every
    # sandbox covers with a /tmp of its own: it is bound back, read-only, at its own path
    assert Path(tmp_path).is_relative_to("/tmp")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    (site,) = venv.glob("lib/python3*/site-packages")
    installed = Path(robots.__file__).resolve().parent.parent
    for package in ("arena", "referee", "robots", "levels"):  # the product itself under /tmp
        shutil.copytree(installed / package, site / package)
    (site / "dependencies.pth").write_text(f"{installed}\n")  # numpy, pymunk, ... from where they are
    team = team_file(
        tmp_path,
        f"""
class Looker(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        seen = [n for p in ({str(site)!r}, {str(installed)!r}) if os.path.isdir(p) for n in os.listdir(p)]
        raise RuntimeError(("contained: " if not seen and os.getuid() != 0 else "LEAK: ") + repr(seen[:5]))
""",
    )
    (tmp_path / "race.yaml").write_text(edited("asabe-race", {"time_limit": 6}))
    done = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "referee", "run", "race.yaml", "--seed", "2", "--team", team]
        + [arg for _ in range(3) for arg in ("--team", HONEST)]
        + ["--json", "result.json", "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )
    assert done.returncode == 0 and done.stderr == "", done.stderr  # no "no kernel sandbox" line
    robots_ = json.loads((tmp_path / "result.json").read_text())["robots"]
    assert [f["message"] for f in robots_[0]["faults"]] == ["in step: RuntimeError: contained: []"]
    assert all(not r["faults"] and not r["stopped"] for r in robots_[1:]), robots_[1:]
