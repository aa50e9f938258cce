"""Ctrl-C at a terminal: SIGINT to the whole foreground process group (the command, its pool
workers, their controllers and sandboxes, as a terminal sends it). `run`, `grade` and
`tournament` then exit 130 with at most one line on stderr and no traceback, leave no process
of theirs running, and a grade or tournament keeps every finished match in its journal and
resumes from it (docs/cli.md)."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest
from helpers import alive, descendants, secret_file

from referee.errors import EXIT_INTERRUPTED

TEAM = """
import sys, time
from robots.api import Command, Controller

class Slow(Controller):
    def setup(self, brief):
        print("ready", flush=True)

    def step(self, obs):
        time.sleep(0.02)  # every match runs long enough to be interrupted
        return Command(0.02, 0.03)
"""


def _start(folder, *args):
    """The command in a process group of its own, as a shell starts a foreground job."""
    return subprocess.Popen(
        [sys.executable, "-m", "referee", *args],
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def _rows(db, table):
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as c:
            return sorted(c.execute(f"SELECT * FROM {table}"))
    except sqlite3.OperationalError:  # not made yet, or being written
        return []


def _interrupt_when(proc, ready, bound=120.0, times=1):
    """Wait (bounded) until `ready()` holds, noting every process below the command; then send
    SIGINT to its process group, `times` times (an impatient user). Return what ran below it
    and the command's stderr."""
    below: dict[int, str] = {}
    deadline = time.monotonic() + bound
    while time.monotonic() < deadline and proc.poll() is None and not ready():
        below.update(descendants(proc.pid))
        time.sleep(0.05)
    below.update(descendants(proc.pid))
    assert proc.poll() is None, f"the command ended before the interrupt: {proc.stderr.read()}"
    assert ready(), "the command never got going"
    for i in range(times):
        if i:
            time.sleep(0.05)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=60)
        raise AssertionError("the command did not end within 60 s of Ctrl-C") from None
    return below, err


def _quiet_exit(proc, err, below):
    # 130, or ended by the SIGINT itself once its one line is out (about 1 run in 10 of the
    # loading case; the shell reports both as 130, and the rest below is checked alike)
    assert proc.returncode in (EXIT_INTERRUPTED, -signal.SIGINT), err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 1, err
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(alive(p, s) for p, s in below.items()):
        time.sleep(0.05)
    left = [p for p, s in below.items() if alive(p, s)]
    for p in left:  # never leave them to the next test
        os.kill(p, signal.SIGKILL)
    assert not left, f"still running after Ctrl-C: {left}"


@pytest.fixture
def slow(shared_dir):
    (shared_dir / "slow.py").write_text(TEAM)
    (shared_dir / "slow.py").chmod(0o644)
    return shared_dir


def _mapped(proc, name):
    """Whether the process has loaded a shared library whose path holds `name`."""
    try:
        with open(f"/proc/{proc.pid}/maps") as f:
            return name in f.read()
    except OSError:
        return False


def test_while_the_command_is_still_loading(tmp_path):
    proc = _start(tmp_path, "run", "bac-line", "--quiet")
    # numpy is among the first modules a command loads: its library mapped means our code runs
    below, err = _interrupt_when(proc, lambda: _mapped(proc, "numpy"), bound=60)
    _quiet_exit(proc, err, below)


def test_run_pressed_twice(slow):
    logs = slow / "logs"
    proc = _start(slow, "run", "asabe-race", "--team", "slow.py", "--team", "ref:bac", "--logs", "logs")
    below, err = _interrupt_when(proc, lambda: "ready" in _text(logs / "slot0.log"), times=2)
    assert len(below) >= 2  # the controllers' sandboxes at least
    _quiet_exit(proc, err, below)


def _text(path):
    try:
        return path.read_text()
    except OSError:
        return ""


GRADE = [
    "grade",
    "bac-line",
    "--team",
    "slow.py",
    "--seeds",
    "4",
    "--workers",
    "2",
    "--secret-file",
    secret_file("s"),
    "--quiet",
]


def test_grade_keeps_finished_matches_and_resumes(slow):
    args = [*GRADE, "--db", "g.sqlite", "--out", "lb.csv"]
    proc = _start(slow, *args)
    below, err = _interrupt_when(proc, lambda: bool(_rows(slow / "g.sqlite", "matches")), times=2)
    assert len(below) >= 3  # two workers and their controllers
    _quiet_exit(proc, err, below)
    kept = _rows(slow / "g.sqlite", "matches")
    assert 1 <= len(kept) < 4
    rerun = subprocess.run(
        [sys.executable, "-m", "referee", *args], cwd=slow, capture_output=True, text=True, timeout=300
    )
    assert rerun.returncode == 0, rerun.stderr
    after = _rows(slow / "g.sqlite", "matches")
    assert len(after) == 4 and set(kept) <= set(after)  # the finished rows untouched, not run again
    with open(slow / "lb.csv") as f:
        assert f.read().splitlines()[1].split(",")[2] == "4"  # 4 matches on the leaderboard


def test_tournament_keeps_finished_heats_and_resumes(slow):
    (slow / "race.yaml").write_text(_race())
    args = [
        "tournament",
        "race.yaml",
        "--team",
        "slow.py",
        "--team",
        "ref:idle",
        "--rounds",
        "1",
        "--workers",
        "2",
        "--secret-file",
        secret_file("s"),
        "--db",
        "t.sqlite",
        "--out",
        "site",
        "--quiet",
    ]
    proc = _start(slow, *args)
    below, err = _interrupt_when(proc, lambda: bool(_rows(slow / "t.sqlite", "heats")))
    _quiet_exit(proc, err, below)
    kept = _rows(slow / "t.sqlite", "heats")
    assert 1 <= len(kept) < 4
    rerun = subprocess.run(
        [sys.executable, "-m", "referee", *args], cwd=slow, capture_output=True, text=True, timeout=300
    )
    assert rerun.returncode == 0, rerun.stderr
    after = _rows(slow / "t.sqlite", "heats")
    assert len(after) == 4 and set(kept) <= set(after)
    assert len((slow / "site" / "heats.csv").read_text().splitlines()) == 1 + 4 * 4


def _race():
    from helpers import edited

    return edited("asabe-race", {"time_limit": 10})


def test_an_interrupt_inside_a_finalizer_is_not_lost():
    """Python drops what a `__del__` raises (numba's LLVM objects run finalizers while compiled
    code loads): a Ctrl-C that lands there is taken again a moment later, not lost."""
    script = (
        "import os, signal, sys, time\n"
        "from referee.cli.main import _interrupt\n"
        "signal.signal(signal.SIGINT, _interrupt)\n"
        "class Finalized:\n"
        "    def __del__(self):\n"
        "        os.kill(os.getpid(), signal.SIGINT)\n"
        "        end = time.monotonic() + 0.05\n"
        "        while time.monotonic() < end:\n"
        "            pass  # the handler runs here, inside __del__\n"
        "try:\n"
        "    Finalized()  # dropped at once: its __del__ runs now\n"
        "    end = time.monotonic() + 20\n"
        "    while time.monotonic() < end:\n"
        "        time.sleep(0.01)\n"
        "    sys.exit(0)\n"
        "except KeyboardInterrupt:\n"
        "    sys.exit(130)\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 130, out.stderr
    assert "Exception ignored" not in out.stderr


CONVERTING_COMMAND = """
import argparse, os, signal, sys, time
import referee.cli.arguments
from referee.cli.main import main

def work(args):
    # as NumPy's C init does when the interrupt lands in the import its PyCapsule_Import makes:
    # the KeyboardInterrupt is lost, an ImportError raised instead
    try:
        if args.interrupt:
            os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    raise ImportError('PyCapsule_Import could not import module "datetime"')

def parser():
    p = argparse.ArgumentParser()
    p.add_argument("--interrupt", action="store_true")
    p.set_defaults(func=work)
    return p

referee.cli.arguments.parser = parser
sys.exit(main(sys.argv[1:]))
"""


def test_an_interrupt_that_c_code_turns_into_another_error_is_still_the_interrupt():
    """Raised inside C code that replaces it with its own error (an extension module's import),
    the interrupt still ends the command quietly with 130; the same error with no interrupt is
    the error it is."""
    out = subprocess.run(
        [sys.executable, "-c", CONVERTING_COMMAND, "--interrupt"], capture_output=True, text=True, timeout=60
    )
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    assert out.stderr.strip() == "laserarena: interrupted"
    plain = subprocess.run([sys.executable, "-c", CONVERTING_COMMAND], capture_output=True, text=True, timeout=60)
    assert plain.returncode == 1 and "ImportError: PyCapsule_Import" in plain.stderr


def test_an_interrupt_is_held_back_inside_numba_llvmlite_and_pymunk_only():
    """Where a raised interrupt would be lost or mangled (numba's C dispatcher turns it into a
    SystemError; cffi drops one raised in a pymunk callback) it waits; elsewhere it is raised."""
    from referee.cli.main import _fragile

    def frame_of(filename: str, name: str = "f"):
        namespace: dict = {}
        exec(compile(f"import sys\ndef {name}():\n    return sys._getframe()\n", filename, "exec"), namespace)
        return namespace[name]()

    import llvmlite
    import numba
    import pymunk

    for package in (numba, llvmlite, pymunk):
        assert _fragile(frame_of(os.path.join(os.path.dirname(package.__file__), "core.py")))
    assert _fragile(frame_of(os.path.join(os.sep, "anywhere", "mod.py"), "__del__"))
    assert not _fragile(frame_of(os.path.join(os.sep, "site-packages", "referee", "match", "loop.py")))
    assert not _fragile(frame_of(os.path.join(os.sep, "home", "numba", "project", "mod.py")))  # a folder of that name
