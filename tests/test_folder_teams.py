"""A folder is a team (`--team DIR[:Class]`): the one `laserarena new` makes runs as it is, by a
relative or an absolute path, in `run`, `grade` and `tournament`; a folder without
`__init__.py` ships its Python files side by side, its controller file `controller.py` or its
one other file besides tests. A folder that is no team, and a name that is nothing, are
refused in one line that says what makes a folder a team and lists every form a team takes."""

from __future__ import annotations

import json

import pytest
from helpers import MINI_LEVEL, run_cli, secret_file

from referee.sandbox.teams import resolve

FORMS = (  # every form a team takes, as docs/api.md and the README name them
    "ref:NAME",
    "FILE.py[:Class]",
    "DIR[:Class]",
    "module:Class",
    "installed controller",
    "__init__.py",
    "controller.py",
)

CONTROLLER = """from robots.api import Command, Controller

from tuning import SPEED


class Cruise(Controller):
    def step(self, obs):
        return Command(SPEED, SPEED)
"""


def _opened(*paths) -> None:
    """Readable by the `nobody` a root referee runs controllers as."""
    for p in paths:
        p.chmod(0o755 if p.is_dir() else 0o644)


def _result(proc, path) -> dict:
    assert proc.returncode == 0, proc.stderr
    return json.loads(path.read_text())["robots"][0]


def test_the_new_kit_runs_as_a_folder_by_a_relative_and_an_absolute_path(shared_dir):
    assert run_cli("new", "myteam", cwd=shared_dir).returncode == 0
    kit = shared_dir / "myteam"
    for spec, where in (("myteam", shared_dir), (str(kit) + "/", shared_dir), (".", kit)):
        out = run_cli("run", "bac-line", "--ideal", "--team", spec, "--json", str(shared_dir / "r.json"), cwd=where)
        robot = _result(out, shared_dir / "r.json")
        assert robot["team"] == "myteam" and robot["faults"] == [], (spec, robot["faults"])
        assert robot["task"]["reached"] >= 5 and robot["score"]["total"] > 0  # the starter follows the line
        assert "myteam" in out.stdout.splitlines()[2]  # the score table's row names the folder


def test_a_folder_ships_its_python_files_side_by_side_and_nothing_else(shared_dir):
    team = shared_dir / "cruise"
    team.mkdir()
    (team / "controller.py").write_text(CONTROLLER)
    (team / "tuning.py").write_text("SPEED = 0.1\n")
    (team / "test_controller.py").write_text("raise SystemExit('a test is never imported')\n")
    (team / "result.json").write_text("{}")  # what a run inside the folder leaves: not code
    (team / "logs").mkdir()
    (team / "logs" / "slot0.log").write_text("old output\n")
    _opened(team, *team.rglob("*"))
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    shipped = resolve(str(team))
    assert [name for name, _ in shipped.files] == ["controller.py", "test_controller.py", "tuning.py"]
    assert shipped.entry == "controller.py"
    for extra in ([], ["--in-process"]):  # `import tuning` finds its sibling in the sandbox and at home
        out = run_cli("run", "level.yaml", "--team", "cruise", "--json", "r.json", *extra, cwd=shared_dir)
        robot = _result(out, shared_dir / "r.json")
        assert robot["faults"] == [] and robot["final_pose"][0] > 0.5 + 0.2, (extra, robot)  # it drove east


def test_a_folder_of_one_module_and_its_tests_runs_that_module(shared_dir):
    team = shared_dir / "solo"
    team.mkdir()
    (team / "bot.py").write_text(CONTROLLER.replace("from tuning import SPEED", "SPEED = 0.1"))
    (team / "test_bot.py").write_text("import bot\n")
    (team / "conftest.py").write_text("")
    _opened(team, *team.iterdir())
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    out = run_cli("run", "level.yaml", "--team", "solo:Cruise", "--json", "r.json", cwd=shared_dir)
    robot = _result(out, shared_dir / "r.json")
    assert robot["team"] == "solo:Cruise" and robot["faults"] == [] and robot["final_pose"][0] > 0.5 + 0.2


@pytest.mark.parametrize(
    "files, found",
    [
        ({}, "(.py files: none)"),
        ({"a.py": "", "b.py": ""}, "(.py files: 2: a.py, b.py)"),
        ({"README.md": "", "test_a.py": ""}, "(.py files: 1: test_a.py)"),
    ],
)
def test_a_folder_that_is_no_team_is_refused_saying_what_makes_one(shared_dir, files, found):
    team = shared_dir / "notateam"
    team.mkdir()
    for name, text in files.items():
        (team / name).write_text(text)
    out = run_cli("run", "bac-line", "--team", "notateam", cwd=shared_dir)
    assert out.returncode == 2 and out.stdout == "" and out.stderr.count("\n") == 1, out.stderr
    assert out.stderr.startswith("laserarena: team notateam: the folder notateam is not a team " + found)
    assert all(form in out.stderr for form in FORMS), out.stderr


@pytest.mark.parametrize("spec", ["nothere", "no/such/folder", "no.such.module:Bot", "missing.py"])
def test_every_refusal_of_a_team_lists_every_form(shared_dir, spec):
    out = run_cli("run", "bac-line", "--team", spec, cwd=shared_dir)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "Traceback" not in out.stderr, out.stderr
    assert out.stderr.startswith(f"laserarena: team {spec}: ")
    assert all(form in out.stderr for form in FORMS), out.stderr


def test_grade_and_tournament_take_a_folder_team(shared_dir):
    assert run_cli("new", "myteam", cwd=shared_dir).returncode == 0
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    graded = run_cli(
        "grade", "level.yaml", "--team", "myteam", "--seeds", "1", "--workers", "1", "--db", "g.sqlite",
        "--out", "lb.csv", "--secret-file", secret_file("folders"), cwd=shared_dir,
    )  # fmt: skip
    assert graded.returncode == 0, graded.stderr
    (row,) = json.loads((shared_dir / "lb.json").read_text())
    assert row["team"] == "myteam" and row["matches"] == 1 and row["faults"] == 0
    played = run_cli(
        "tournament", "level.yaml", "--team", "myteam", "--team", "ref:idle", "--workers", "1", "--db", "t.sqlite",
        "--out", "site", "--secret-file", secret_file("folders"), cwd=shared_dir,
    )  # fmt: skip
    assert played.returncode == 0, played.stderr
    standings = json.loads((shared_dir / "site" / "standings.json").read_text())["standings"]
    assert sorted(s["team"] for s in standings) == ["myteam", "ref:idle"]
    assert all(s["faults"] == "" for s in standings)


def test_a_level_may_name_a_folder_as_its_default_controller(shared_dir):
    assert run_cli("new", "house", cwd=shared_dir).returncode == 0
    (shared_dir / "empty").mkdir()
    for default, ok in (("house", True), ("empty", False)):
        (shared_dir / "level.yaml").write_text(MINI_LEVEL.replace("ref:dead-reckoning", default))
        out = run_cli("check", "level.yaml", cwd=shared_dir)
        assert (out.returncode == 0) is ok, out.stderr
        if not ok:
            assert "is not a team (.py files: none)" in out.stderr and "controller.py" in out.stderr
