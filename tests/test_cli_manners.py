"""The command line's manners: `-` for stdout, a closed pipe and bad arguments end quietly in
one line with the documented exit codes (docs/cli.md), team labels relative to here."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest
from helpers import MINI_LEVEL, run_cli

from referee.errors import EXIT_BAD_INPUT, EXIT_PIPE


def test_closed_pipe_ends_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "referee", "levels"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the first line (`| head -0`)
    _, err = proc.communicate(timeout=60)
    assert err == b"" and proc.returncode == EXIT_PIPE


def test_levels_columns_align():
    import levels
    from levels.loader import load_level

    out = run_cli("levels")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    found = [load_level(levels.path(name)) for name in levels.names()]
    assert [line.split()[0] for line in lines] == [lv.name for lv in found]
    for column in (" robot", " default "):  # each line's first: a description comes after them
        assert len({line.index(column) for line in lines}) == 1, out.stdout
    assert len({line.index(lv.description) for line, lv in zip(lines, found)}) == 1, out.stdout


def test_json_to_stdout_table_to_stderr(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    out = run_cli("run", "level.yaml", "--json", "-", "--team", "ref:idle", cwd=shared_dir)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["level"]["name"] == "mini" and result["robots"][0]["team"] == "ref:idle"
    assert out.stderr.startswith("mini  seed 3") and "ref:idle" in out.stderr


@pytest.mark.parametrize(
    "args,words",
    [
        (["run", "bac-line", "--seed", "-3"], "--seed -3"),
        (["run", "bac-line", "--seed", "three"], "--seed: invalid int value"),
        (["run", "bac-line", "--json", "no/such/folder/r.json"], "the folder does not exist"),
        (["render", "x.replay", "--out", "x.avi"], "not .avi"),
        (["render", "x.replay", "--out", "no/such/folder/x.mp4"], "the folder does not exist"),
        (["grade", "bac-line", "--team", "ref:idle", "--out", "no/such/folder/board.csv"], "the folder does not exist"),
        (["grade", "bac-line", "--team", "ref:idle", "--workers", "0"], "--workers: must be at least 1, got 0"),
        (["grade", "bac-line", "--team", "ref:idle", "--seeds", "-1"], "--seeds: must be at least 1, got -1"),
        (["tournament", "bac-line", "--team", "ref:idle", "--rounds", "0"], "--rounds: must be at least 1, got 0"),
        (["tournament", "bac-line", "--team", "ref:idle", "--workers", "two"], "--workers: not a whole number: 'two'"),
        (["render", "nosuch.replay", "--out", "x.mp4"], "laserarena: nosuch.replay: No such file or directory"),
        (["render", "nosuch.replay", "--html", "x.html"], "laserarena: nosuch.replay: No such file or directory"),
        (["verify", "nosuch.replay"], "laserarena: nosuch.replay: No such file or directory"),
        (["plot", "nosuch.replay"], "laserarena: nosuch.replay: No such file or directory"),
        (
            [
                "grade",
                "bac-line",
                "--team",
                "ref:idle",
                "--seeds",
                "1",
                "--scheduler",
                "tcp://127.0.0.1:1",
                "--insecure-cluster",
                "--db",
                "g.sqlite",
            ],
            "cannot reach the Dask scheduler",
        ),
    ],
)
def test_argument_errors_are_one_line_exit_2(tmp_path, args, words):
    out = run_cli(*args, cwd=tmp_path)
    assert out.returncode == EXIT_BAD_INPUT
    assert len(out.stderr.strip().splitlines()) == 1 and words in out.stderr, out.stderr


def test_team_label_is_relative_to_here(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / "bots").mkdir(mode=0o755)
    (shared_dir / "bots" / "bot.py").write_text(
        "from robots.api import Command, Controller\n"
        "class Bot(Controller):\n    def step(self, obs):\n"
        "        return Command(0.0, 0.0)\n"
    )
    (shared_dir / "bots" / "bot.py").chmod(0o644)
    out = run_cli("run", "level.yaml", "--team", str(shared_dir / "bots" / "bot.py"), "--json", "-", cwd=shared_dir)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["robots"][0]["team"] == "bots/bot.py"


def test_a_level_whose_own_controller_cannot_load_is_exit_2(shared_dir):
    # no --team: the level's default controller plays; if it cannot even load, nothing ran
    (shared_dir / "broken.py").write_text("raise RuntimeError('this controller is broken at import')\n")
    (shared_dir / "broken.py").chmod(0o644)
    (shared_dir / "lv.yaml").write_text(
        MINI_LEVEL.replace("default_controller: ref:dead-reckoning", "default_controller: broken.py")
    )
    out = run_cli("run", "lv.yaml", "--quiet", cwd=shared_dir)
    assert out.returncode == EXIT_BAD_INPUT, out.stderr
    assert out.stderr.count("\n") == 1 and "broken at import" in out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize("command", ["grade", "tournament"])
def test_contest_help_says_what_the_command_does_and_what_its_levels_are(command):
    out = run_cli(command, "--help")
    assert out.returncode == 0
    usage, description = out.stdout.split("\n\n")[:2]
    assert "docs/contests.md" in description and "resumable" in description
    assert "level names or level files" in out.stdout


@pytest.mark.parametrize("given, threads", [(None, 1), ("2", 2)])
def test_the_command_runs_numpy_with_one_blas_thread_unless_the_user_says(given, threads):
    """No spare OpenBLAS thread spinning beside the referee (the user's own number wins)."""
    probe = (
        "import contextlib, io, os\n"
        "from referee.cli.main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    assert main(['levels']) == 0\n"
        "import numpy\n"
        "numpy.ones((400, 400)) @ numpy.ones((400, 400))  # a product large enough to be threaded\n"
        "print(len(os.listdir('/proc/self/task')))\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    if given:
        env["OPENBLAS_NUM_THREADS"] = given
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout) == threads


def _entry(body: str, **popen) -> subprocess.CompletedProcess:
    """Run the console script's `run()` in a process of its own, `referee.cli.main.main`
    replaced by `body` (the command), with a module-level witness whose finalizer says when
    the interpreter tears the modules down."""
    probe = (
        "import atexit, sys\n"
        "import referee.cli.main, referee.cli.entry\n"
        "class Witness:\n"
        "    def __del__(self):\n"
        "        sys.stderr.write('torn down\\n')\n"
        "keep = Witness()\n"
        f"def command(argv=None):\n{textwrap.indent(body, '    ')}\n"
        "referee.cli.main.main = command\n"
        "referee.cli.entry.run()\n"
    )
    return subprocess.run([sys.executable, "-c", probe], timeout=60, **popen)


def test_the_process_ends_with_the_commands_code_after_its_exit_handlers_without_teardown():
    body = "atexit.register(lambda: print('the command closed its work'))\nprint('out')\nreturn 3"
    proc = _entry(body, capture_output=True, text=True)
    assert proc.returncode == 3
    assert proc.stdout == "out\nthe command closed its work\n"  # flushed after every handler
    assert "torn down" not in proc.stderr


def test_a_command_that_raises_gets_pythons_own_way_out():
    proc = _entry("raise RuntimeError('a bug')", capture_output=True, text=True)
    assert proc.returncode == 1
    assert "Traceback" in proc.stderr and "RuntimeError: a bug" in proc.stderr
    assert "torn down" in proc.stderr


def test_a_reader_gone_before_the_last_output_is_a_closed_pipe():
    """What the command printed is still buffered when it returns (a pipe's block buffering);
    the reader is gone."""
    reader, writer = os.pipe()
    os.close(reader)
    buffered = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    body = "print('a line the reader will never see')\nreturn 0"
    proc = _entry(body, stdout=writer, stderr=subprocess.PIPE, env=buffered)
    os.close(writer)
    assert proc.stderr == b"" and proc.returncode == EXIT_PIPE


LOADED = """
import sys
from referee.cli.main import main

try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(sorted(m for m in ("numpy", "numba", "pymunk", "referee.cli.commands") if m in sys.modules))
"""


@pytest.mark.parametrize("args", [["run", "--help"], ["run"], ["grade", "--bogus"]])
def test_help_and_argument_errors_load_no_command(args):
    # parsing answers before the commands' modules load (numpy and numba take a fifth of a second)
    out = subprocess.run([sys.executable, "-c", LOADED, *args], capture_output=True, text=True, timeout=60)
    assert out.stdout.splitlines()[-1] == "[]", out.stdout + out.stderr


def test_a_run_loads_no_toolkit_in_the_referee():
    # the starter kit, and through it the team's toolkit, load for `laserarena new` alone (16 ms of a run's start)
    probe = "import sys, referee.cli.commands, referee.match.loop; print([m for m in sys.modules if m.startswith('robots.toolkit')])"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.splitlines()[-1] == "[]", out.stdout + out.stderr
