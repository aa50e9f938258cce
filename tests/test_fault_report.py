"""A team can act on its faults: the console shows each fault's message with the team's file
and line where it raised and, with --logs, where the failed slot's log is kept (without it
nothing is written); the result JSON has the traceback's tail; `--in-process` prints the whole
traceback. `grade`'s leaderboard and the tournament's standings tell each team's faults by
kind, first message and line; limits and a class that is no controller are told in the
words of the docs."""

from __future__ import annotations

import json

import pytest
from helpers import MINI_LEVEL, run_cli, secret_file

BOOM = """from robots.api import Command, Controller


def deep(n):
    return 1 / n


class Boom(Controller):
    def step(self, obs):
        if obs.tick == 3:
            deep(0)
        return Command(0.0, 0.0)
"""


def run_team(shared_dir, name: str, source: str, extra: list[str]) -> tuple:
    """`laserarena run` of the mini level with a team file `name` holding `source`: the run's
    output and its robot's first fault, as the result records it."""
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / name).write_text(source)
    (shared_dir / name).chmod(0o644)
    out = run_cli("run", "level.yaml", "--team", name, "--json", "r.json", *extra, cwd=shared_dir)
    assert out.returncode == 0, out.stderr
    return out, json.loads((shared_dir / "r.json").read_text())["robots"][0]["faults"][0]


@pytest.mark.parametrize("extra", [[], ["--in-process"]])
def test_fault_message_log_and_traceback(shared_dir, extra):
    out, fault = run_team(shared_dir, "boom.py", BOOM, extra)
    # the mini level's control period is 0.05 s: tick 3 is at 0.15 s
    assert (fault["kind"], fault["tick"], fault["time"]) == ("exception", 3, pytest.approx(0.15))
    assert fault["message"] == "in step: ZeroDivisionError: division by zero"
    tb = fault["traceback"].splitlines()
    assert tb[0] == "Traceback (most recent call last):" and tb[-1] == "ZeroDivisionError: division by zero"
    assert tb[1].endswith('boom.py", line 11, in step') and tb[3].endswith('boom.py", line 5, in deep')
    # the last frame in the team's own file: `return 1 / n`, line 5
    assert "slot 0 exception at 0.15 s: in step: ZeroDivisionError: division by zero (boom.py:5)" in out.stdout
    assert not (shared_dir / "laserarena-logs").exists()  # no folder nobody asked for
    if extra:  # in-process: the team's output went to the referee's own stderr, the whole traceback too
        assert "slot 0 log:" not in out.stdout and "--logs DIR" not in out.stdout
        assert "Traceback (most recent call last):" in out.stderr
        assert "in_process.py" in out.stderr  # the referee's frame that called the team's: all of it
        assert f'{shared_dir / "boom.py"}", line 11, in step' in out.stderr
        assert f'{shared_dir / "boom.py"}", line 5, in deep' in out.stderr
    else:
        assert "slot 0 log:" not in out.stdout and "--logs DIR keeps each controller's output" in out.stdout
        kept = run_cli("run", "level.yaml", "--team", "boom.py", "--logs", "logs", cwd=shared_dir)
        assert "slot 0 log: logs/slot0.log" in kept.stdout
        assert (shared_dir / "logs" / "slot0.log").read_text().rstrip().endswith("ZeroDivisionError: division by zero")


def test_a_clean_run_keeps_no_logs(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    out = run_cli("run", "level.yaml", "--team", "ref:idle", cwd=shared_dir)
    assert out.returncode == 0 and not (shared_dir / "laserarena-logs").exists()


ESCAPES = """from robots.api import Command, Controller


class Loud(Controller):
    def step(self, obs):
        raise ValueError("\\x1b[2J\\x1b[31mred\\u202e\\x07")
"""


@pytest.mark.parametrize("extra", [[], ["--in-process"]])
def test_a_fault_message_is_recorded_terminal_safe(shared_dir, extra):
    # a team's exception text with a screen clear, a colour, a bidirectional override and a bell
    out, fault = run_team(shared_dir, "loud.py", ESCAPES, extra)
    assert fault["message"] == "in step: ValueError: \\x1b[2J\\x1b[31mred\\u202e\\x07"
    assert "\x1b" not in out.stdout and "\u202e" not in out.stdout


@pytest.mark.parametrize("forked", [True, False])  # from the template, or spawned as `python -m`
def test_a_traceback_starts_at_the_teams_own_frame(tmp_path, forked):
    """Forked from the template or spawned on its own (where the runner runs as `__main__`),
    the traceback a fault keeps holds the team's frames only: none of the runner's."""
    from helpers import variant

    from referee.match.loop import Match
    from referee.sandbox.process import ProcessBot
    from referee.sandbox.teams import resolve

    (tmp_path / "boom.py").write_text(BOOM)
    (tmp_path / "boom.py").chmod(0o644)
    tmp_path.chmod(0o755)
    level = variant("bac-line", time_limit=2)
    match = Match(level, [resolve(str(tmp_path / "boom.py"))], seed=1)
    match.fleet.bots = [ProcessBot(team, level.limits, slot=0, forked=forked) for team in match.teams]
    fault = match.run().robots[0].faults[0]
    lines = fault.traceback.splitlines()
    assert lines[0] == "Traceback (most recent call last):" and lines[1].endswith('boom.py", line 11, in step')
    assert "_host" not in fault.traceback


def line_of(source: str, code: str) -> int:
    """The line number of `code` in `source`: where a traceback must point."""
    return [line.strip() for line in source.splitlines()].index(code) + 1


BOOM_LINE = line_of(BOOM, "return 1 / n")
MATHS = "def boom():\n    return {}['pose']\n"
MATHS_LINE = line_of(MATHS, "return {}['pose']")
BOT = """from robots.api import Command, Controller

from .maths import boom


class Bot(Controller):
    def step(self, obs):
        if obs.tick == 2:
            boom()
        return Command(0.0, 0.0)
"""


def _teams(shared_dir) -> None:
    """A file team that divides by zero and a package team whose module raises KeyError 'pose'."""
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / "boom.py").write_text(BOOM)
    pkg = shared_dir / "mybot"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from .bot import Bot\n")
    (pkg / "bot.py").write_text(BOT)
    (pkg / "maths.py").write_text(MATHS)
    for p in [shared_dir / "boom.py", pkg, *pkg.iterdir()]:
        p.chmod(0o755 if p.is_dir() else 0o644)


def test_grade_and_tournament_name_each_teams_faults_and_lines(shared_dir):
    _teams(shared_dir)
    boom = f"1 exception: in step: ZeroDivisionError: division by zero (boom.py:{BOOM_LINE})"
    pose = f"1 exception: in step: KeyError: 'pose' (mybot/maths.py:{MATHS_LINE})"
    graded = run_cli(
        "grade", "level.yaml", "--team", "boom.py", "--team", "mybot", "--team", "ref:idle", "--seeds", "1",
        "--workers", "1", "--db", "g.sqlite", "--out", "lb.csv", "--secret-file", secret_file("faults"),
        cwd=shared_dir,
    )  # fmt: skip
    assert graded.returncode == 0, graded.stderr
    rows = {r["team"]: r for r in json.loads((shared_dir / "lb.json").read_text())}
    assert (rows["boom.py"]["faults"], rows["boom.py"]["fault_summary"]) == (1, boom)
    assert (rows["mybot"]["faults"], rows["mybot"]["fault_summary"]) == (1, pose)
    assert (rows["ref:idle"]["faults"], rows["ref:idle"]["fault_summary"]) == (0, "")
    board = {line.split(" | ")[1]: line.split(" | ")[-1] for line in graded.stdout.splitlines()[2:] if line}
    assert board["boom.py"] == boom + " |" and board["ref:idle"] == "0 |"  # what grade prints: the faults column
    assert board["mybot"] == pose + " |"
    csv = (shared_dir / "lb.csv").read_text()
    assert csv.splitlines()[0].endswith(",faults,fault_summary") and f",1,{boom}\n" in csv

    played = run_cli(
        "tournament", "level.yaml", "--team", "boom.py", "--team", "mybot", "--team", "ref:idle", "--workers", "1",
        "--db", "t.sqlite", "--out", "site", "--secret-file", secret_file("faults"), cwd=shared_dir,
    )  # fmt: skip
    assert played.returncode == 0, played.stderr
    heats = {
        s["team"]: s["heats"] for s in json.loads((shared_dir / "site" / "standings.json").read_text())["standings"]
    }
    told = {
        s["team"]: s["faults"] for s in json.loads((shared_dir / "site" / "standings.json").read_text())["standings"]
    }
    assert told == {"boom.py": boom.replace("1 ", f"{heats['boom.py']} ", 1),
                    "mybot": pose.replace("1 ", f"{heats['mybot']} ", 1), "ref:idle": ""}  # fmt: skip
    assert f"faults of boom.py: {told['boom.py']}" in played.stdout.splitlines()
    assert f"faults of mybot: {told['mybot']}" in played.stdout.splitlines()
    assert "faults of ref:idle" not in played.stdout
    assert told["boom.py"] in (shared_dir / "site" / "standings.csv").read_text()
    assert told["boom.py"] in (shared_dir / "site" / "index.html").read_text()


def test_a_team_that_raises_as_it_loads_is_told_its_line(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    source = "from robots.api import Controller\n\nGAIN = undefined_gain * 2\n"
    (shared_dir / "early.py").write_text(source)
    (shared_dir / "early.py").chmod(0o644)
    for extra in ([], ["--in-process"]):
        out = run_cli("run", "level.yaml", "--team", "early.py", *extra, cwd=shared_dir)
        assert out.returncode == 2 and out.stdout == "", out.stderr
        assert out.stderr.splitlines()[-1] == (
            "laserarena: team early.py: early.py failed to load: NameError: name 'undefined_gain' is not defined "
            f"(early.py:{line_of(source, 'GAIN = undefined_gain * 2')})"
        ), extra


SUBCLASS = "a controller is a class that subclasses Controller: `class MyBot(Controller):`"


@pytest.mark.parametrize(
    "source, spec, told",
    [
        ("X = 1\n", "mine.py", "mine.py defines no class; " + SUBCLASS),
        ("class Bot:\n    pass\n", "mine.py", "no class in mine.py subclasses Controller (found Bot); " + SUBCLASS),
        ("class Bot:\n    pass\n", "mine.py:Bot", "Bot in mine.py does not subclass Controller; " + SUBCLASS),
    ],
)
def test_a_file_with_no_controller_class_is_told_what_a_controller_is(shared_dir, source, spec, told):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / "mine.py").write_text(source)
    (shared_dir / "mine.py").chmod(0o644)
    for extra in ([], ["--in-process"]):
        out = run_cli("run", "level.yaml", "--team", spec, *extra, cwd=shared_dir)
        assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
        assert out.stderr.startswith(f"laserarena: team {spec}: {told}"), (extra, out.stderr)
        assert "laserarena_team" not in out.stderr  # no module name of the loader's own


SLEEPER = """import time

from robots.api import Command, Controller


class Sleeper(Controller):
    def step(self, obs):
        time.sleep({seconds})
        return Command(0.0, 0.0)
"""


@pytest.mark.parametrize(
    "limits, seconds, told",
    [
        (  # a step that never returns: skipped at the deadline, then waited for until the bank ran out
            "{step_deadline: 0.2, overage_bank: 0.3}",
            "3600",
            "in step: step() did not return within step_deadline (0.2 s), nor before the overage_bank (0.3 s a match) "
            "ran out: a step that loops or waits never answers",
        ),
        (  # every step 0.03 s or more over step_time: the 0.1 s bank lasts 4 steps at most
            "{step_time: 0.02, step_deadline: 2, overage_bank: 0.1}",
            "0.05",
            "in step: steps over step_time (0.02 s) used up the overage_bank (0.1 s of excess a match); "
            "make step() faster",
        ),
        (  # 0.03 s a step within step_time, but the match's 4 s x 0.02 = 0.08 s of thinking last 3 steps at most
            "{think_budget: 0.02}",
            "0.03",
            "in step: think budget used up: answers took over the 0.08 s this match allows "
            "(think_budget 0.02 s per simulated second); make step() faster",
        ),
    ],
)
def test_a_broken_time_limit_is_told_by_its_name(shared_dir, limits, seconds, told):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL + f"limits: {limits}\n")
    (shared_dir / "slow.py").write_text(SLEEPER.format(seconds=seconds))
    (shared_dir / "slow.py").chmod(0o644)
    out = run_cli("run", "level.yaml", "--team", "slow.py", "--json", "r.json", cwd=shared_dir)
    assert out.returncode == 0, out.stderr
    faults = json.loads((shared_dir / "r.json").read_text())["robots"][0]["faults"]
    assert faults[-1]["kind"] == "timeout" and faults[-1]["message"] == told, faults
    assert f"timeout at {faults[-1]['time']:.2f} s: {told}" in out.stdout


DEEP = """import json

from robots.api import Command, Controller


def settings(text):
    return json.loads(text, object_hook=dict)


class Deep(Controller):
    def step(self, obs):
        if obs.tick == 2:
            settings('{"gain": }')
        return Command(0.0, 0.0)
"""


@pytest.mark.parametrize("extra", [[], ["--in-process"]])
def test_an_error_deep_in_a_library_still_points_at_the_teams_line(shared_dir, extra):
    # three frames of the json module under the team's: more than the traceback's tail holds
    out, fault = run_team(shared_dir, "deep.py", DEEP, extra)
    line = line_of(DEEP, "return json.loads(text, object_hook=dict)")
    assert fault["message"].startswith("in step: JSONDecodeError: Expecting value")
    assert f"JSONDecodeError: Expecting value: line 1 column 10 (char 9) (deep.py:{line})" in out.stdout
    tb = fault["traceback"].splitlines()
    assert len(tb) <= 12 and tb[1] == f'  File "deep.py", line {line}, in settings' and "  ..." in tb
    assert tb[-1] == "json.decoder.JSONDecodeError: Expecting value: line 1 column 10 (char 9)"
