"""A team as a folder holding a Python package (`--team DIR[:Class]`): relative imports and
its own data files work in the sandbox and in-process; a FILE.py team importing a sibling
gets a load fault that says what to do."""

from __future__ import annotations

import json

import pytest
from helpers import MINI_LEVEL, run_cli

INIT = "from .brain import Reader\n"
BRAIN = '''
from importlib import resources
from pathlib import Path

from robots.api import Command, Controller

from . import tuning


class Reader(Controller):
    """Drives at the speed its data file holds, read both ways a package may read its data."""

    def setup(self, brief):
        a = float(resources.files(__package__).joinpath("data/speed.txt").read_text())
        b = float((Path(__file__).parent / "data" / "speed.txt").read_text())
        assert a == b
        self.speed = tuning.scale * a

    def step(self, obs):
        return Command(self.speed, self.speed)
'''


def _package(root):
    pkg = root / "mybot"
    (pkg / "data").mkdir(parents=True)
    (pkg / "__init__.py").write_text(INIT)
    (pkg / "brain.py").write_text(BRAIN)
    (pkg / "tuning.py").write_text("scale = 2.0\n")
    (pkg / "data" / "speed.txt").write_text("0.05\n")
    for p in [root, pkg, pkg / "data", *pkg.rglob("*")]:
        p.chmod(0o755 if p.is_dir() else 0o644)
    (root / "level.yaml").write_text(MINI_LEVEL)


@pytest.mark.parametrize("spec,extra", [("mybot", []), ("mybot:Reader", ["--in-process"])])
def test_package_team_reads_its_modules_and_data(shared_dir, spec, extra):
    _package(shared_dir)
    out = run_cli("run", "level.yaml", "--team", spec, "--ideal", "--json", "r.json", *extra, cwd=shared_dir)
    assert out.returncode == 0, out.stderr
    robot = json.loads((shared_dir / "r.json").read_text())["robots"][0]
    assert robot["faults"] == [] and robot["team"] == spec
    # 2.0 x 0.05 = 0.1 m/s on both wheels, ideal drive: straight along +x from (0.5, 0.5, 0)
    x, y, heading = robot["final_pose"]
    assert y == pytest.approx(0.5, abs=1e-6) and heading == pytest.approx(0.0, abs=1e-6)
    assert 0.5 + 0.1 * 2 < x <= 0.5 + 0.1 * 4 + 1e-9


def test_file_team_importing_a_sibling_is_told_to_make_a_package(shared_dir):
    _package(shared_dir)
    (shared_dir / "helper.py").write_text("SPEED = 0.1\n")
    (shared_dir / "bot.py").write_text(
        "from helper import SPEED\nfrom robots.api import Command, Controller\n"
        "class Bot(Controller):\n    def step(self, obs):\n"
        "        return Command(SPEED, SPEED)\n"
    )
    for p in shared_dir.glob("*.py"):
        p.chmod(0o644)
    out = run_cli("run", "level.yaml", "--team", "bot.py", cwd=shared_dir)
    assert out.returncode == 2
    assert "No module named 'helper'" in out.stderr and "--team DIR" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "line, said, hint, not_said",
    [
        ("from robots.toolkit.steering import wrap", "cannot import name 'wrap'", "docs/toolkit.md", "--team DIR"),
        ("import robots.toolkit.nosuch", "No module named 'robots.toolkit.nosuch'", "docs/toolkit.md", "--team DIR"),
        ("import scipy", "No module named 'scipy'", "robots, numpy, msgspec and its own modules", "docs/toolkit.md"),
        ("import json.nosuch", "No module named 'json.nosuch'", "", "docs/"),
    ],
)
def test_a_failed_import_is_told_what_to_do_about_that_import(shared_dir, line, said, hint, not_said):
    # the advice follows what failed: a name robots lacks, a package outside the sandbox's
    # view, a module of the standard library (nothing to advise)
    (shared_dir / "bot.py").write_text(
        f"{line}\nfrom robots.api import Command, Controller\nclass Bot(Controller): pass\n"
    )
    (shared_dir / "bot.py").chmod(0o644)
    out = run_cli("run", "bac-line", "--team", "bot.py", cwd=shared_dir)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert said in out.stderr and hint in out.stderr and not_said not in out.stderr, out.stderr
