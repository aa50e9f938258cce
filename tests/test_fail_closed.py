"""Contests fail closed: where no kernel sandbox can be made, `grade` and `tournament` refuse
to play unless the organizer says --unsandboxed, which the journal, the leaderboard and the
report then carry; and the noise secret is never taken from a command line."""

import json
import os
import sqlite3
import subprocess
import sys

import pytest
from helpers import edited, run_cli, strong_secret

from referee import api
from referee.errors import SandboxError
from referee.sandbox import kernel, launch

NO_SANDBOX = "bubblewrap (bwrap) is not installed (as this test pretends)"


def pretend_no_sandbox(monkeypatch) -> None:
    """No kernel sandbox here; and controllers run as the referee's own user, as where root
    cannot become `nobody` (the checkout may be closed to other users: a 0700 /root)."""
    monkeypatch.setattr(kernel, "unavailable", lambda: NO_SANDBOX)
    monkeypatch.setattr(launch, "drop_to", lambda: None)


def cli_without_sandbox(*args: str, cwd) -> subprocess.CompletedProcess:
    """`laserarena ARGS` where bwrap is out of reach (not on the PATH): no sandbox can be made."""
    env = {**os.environ, "PATH": str(cwd)}
    return subprocess.run(
        [sys.executable, "-m", "referee", *args], capture_output=True, text=True, timeout=300, cwd=cwd, env=env
    )


@pytest.mark.parametrize("command", ["grade", "tournament"])
def test_a_contest_without_a_sandbox_is_refused_in_one_line(tmp_path, command):
    proc = cli_without_sandbox(command, "bac-line", "--team", "ref:idle", "--db", "j.sqlite", cwd=tmp_path)
    assert proc.returncode != 0 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "no kernel sandbox" in proc.stderr and "bwrap" in proc.stderr and "--unsandboxed" in proc.stderr
    assert not (tmp_path / "j.sqlite").exists()  # refused before anything was made


def test_a_grade_without_a_sandbox_runs_with_the_flag_and_says_so(tmp_path, monkeypatch, capsys):
    pretend_no_sandbox(monkeypatch)
    level = tmp_path / "short.yaml"
    level.write_text(edited("bac-line", {"time_limit": 2}))
    options = dict(seeds=1, workers=1, db=tmp_path / "r.sqlite", out=tmp_path / "lb.csv", secret=strong_secret("s"))
    with pytest.raises(SandboxError, match="no kernel sandbox"):
        api.grade(level, ["ref:idle"], **options)
    rows = api.grade(level, ["ref:idle"], unsandboxed=True, **options)
    assert [r.matches for r in rows] == [1]
    with sqlite3.connect(tmp_path / "r.sqlite") as db:
        assert db.execute("SELECT value FROM meta WHERE key='unsandboxed'").fetchone() == (NO_SANDBOX,)
    assert f"played without a kernel sandbox (--unsandboxed): {NO_SANDBOX}" in (tmp_path / "lb.md").read_text()
    assert "played without a kernel sandbox" in capsys.readouterr().err


def test_a_tournament_without_a_sandbox_runs_with_the_flag_and_says_so(tmp_path, monkeypatch):
    pretend_no_sandbox(monkeypatch)
    level = tmp_path / "short.yaml"
    level.write_text(edited("bac-line", {"time_limit": 2}))
    options = dict(rounds=1, workers=1, db=tmp_path / "t.sqlite", out=tmp_path / "site", secret=strong_secret("s"))
    with pytest.raises(SandboxError, match="no kernel sandbox"):
        api.tournament(level, ["ref:idle", "ref:bac"], **options)
    done = api.tournament(level, ["ref:idle", "ref:bac"], unsandboxed=True, **options)
    note = f"played without a kernel sandbox (--unsandboxed): {NO_SANDBOX}"
    assert done.notes == (note,)
    assert note in (tmp_path / "site" / "index.html").read_text()
    assert json.loads((tmp_path / "site" / "standings.json").read_text())["notes"] == [note]


@pytest.mark.parametrize("command", ["grade", "tournament"])
@pytest.mark.parametrize("given", [["--secret", "s"], ["--secret=s"]])
def test_a_secret_on_the_command_line_is_refused(tmp_path, command, given):
    proc = run_cli(command, "bac-line", "--team", "ref:idle", "--db", "j.sqlite", *given, cwd=tmp_path)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "use --secret-file FILE" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "j.sqlite").exists()
