"""A team can act on its faults: the console shows each fault's message and, with --logs, where
the failed slot's log is kept (without it nothing is written); the result JSON has the
traceback's tail."""

from __future__ import annotations

import json

import pytest
from helpers import MINI_LEVEL, run_cli

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
    assert "slot 0 exception at 0.15 s: in step: ZeroDivisionError: division by zero" in out.stdout
    assert not (shared_dir / "laserarena-logs").exists()  # no folder nobody asked for
    if extra:  # in-process: the team's output went to the referee's own stderr
        assert "slot 0 log:" not in out.stdout and "--logs DIR" not in out.stdout
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
