"""Ctrl-C at a terminal: SIGINT to the whole foreground process group (the command, its pool
workers, their controllers and sandboxes, as a terminal sends it). `run`, `grade` and
`tournament` then exit 130 with at most one line on stderr and no traceback, leave no process
of theirs running, and a grade or tournament keeps every finished match in its journal, says
how many, and resumes from it, saying how many it resumed and how many it ran (docs/cli.md)."""

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
    assert (
        err
        == f"laserarena: interrupted; {_kept(len(kept), 'match')} in the journal g.sqlite; the same command resumes\n"
    )
    rerun = subprocess.run(  # not --quiet: it says what it resumed and what it ran
        [sys.executable, "-m", "referee", *[a for a in args if a != "--quiet"]],
        cwd=slow,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert rerun.returncode == 0, rerun.stderr
    after = _rows(slow / "g.sqlite", "matches")
    assert len(after) == 4 and set(kept) <= set(after)  # the finished rows untouched, not run again
    assert f"4 matches in the journal g.sqlite ({len(kept)} resumed, {4 - len(kept)} run now);" in rerun.stderr
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
    assert (
        err
        == f"laserarena: interrupted; {_kept(len(kept), 'heat')} in the journal t.sqlite; the same command resumes\n"
    )
    rerun = subprocess.run(
        [sys.executable, "-m", "referee", *args], cwd=slow, capture_output=True, text=True, timeout=300
    )
    assert rerun.returncode == 0, rerun.stderr
    after = _rows(slow / "t.sqlite", "heats")
    assert len(after) == 4 and set(kept) <= set(after)
    assert len((slow / "site" / "heats.csv").read_text().splitlines()) == 1 + 4 * 4


def _kept(n: int, noun: str) -> str:
    """`1 finished match kept`, `3 finished heats kept`."""
    return f"{n} finished {noun}{'' if n == 1 else 'es' if noun == 'match' else 's'} kept"


def _race():
    from helpers import edited

    return edited("asabe-race", {"time_limit": 10})


INTERRUPTED_INSIDE = """
import os, signal, sys, time, weakref
from referee.cli.main import handle_interrupts

handle_interrupts()


def interrupt_here():
    os.kill(os.getpid(), signal.SIGINT)
    end = time.monotonic() + 0.05
    while time.monotonic() < end:
        pass  # the handler runs here


{setup}
try:
    {trigger}
    end = time.monotonic() + 20
    while time.monotonic() < end:
        time.sleep(0.01)
    sys.exit(0)  # the interrupt was lost
except KeyboardInterrupt:
    os.kill(os.getpid(), signal.SIGINT)  # a second Ctrl-C during the clean-up: ignored
    time.sleep(0.05)
    sys.exit(130)
"""


def _interrupted_inside(setup: str, trigger: str) -> subprocess.CompletedProcess:
    """A script that sends itself Ctrl-C from inside the code `setup` defines, run by `trigger`
    (the command's handlers in place): exit 130 if the interrupt reached it, 0 if it was lost."""
    script = INTERRUPTED_INSIDE.format(setup=setup, trigger=trigger)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)


def test_an_interrupt_inside_a_finalizer_is_not_lost():
    """Python drops what a `__del__` raises (numba's LLVM objects run finalizers while compiled
    code loads): a Ctrl-C that lands there is taken again a moment later, not lost."""
    setup = "class Finalized:\n    def __del__(self):\n        interrupt_here()\n"
    out = _interrupted_inside(setup, "Finalized()  # dropped at once: its __del__ runs now")
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    assert "Exception ignored" not in out.stderr


def test_an_interrupt_that_python_drops_in_a_weakref_callback_is_raised_again():
    """Python drops what a weakref callback raises, after printing it (importlib's module
    locks have such callbacks, run while modules load): a Ctrl-C raised there is raised again
    a moment later, in the main thread's code, not lost; and a second one is still ignored."""
    setup = "class Held:\n    pass\n\n\nheld = Held()\nref = weakref.ref(held, lambda ref: interrupt_here())\n"
    out = _interrupted_inside(setup, "del held  # the callback runs now")
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    assert "Exception ignored" not in out.stderr and "Traceback" not in out.stderr, out.stderr


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
    from referee.interrupts import fragile

    def frame_of(filename: str, name: str = "f"):
        namespace: dict = {}
        exec(compile(f"import sys\ndef {name}():\n    return sys._getframe()\n", filename, "exec"), namespace)
        return namespace[name]()

    import llvmlite
    import numba
    import pymunk

    for package in (numba, llvmlite, pymunk):
        assert fragile(frame_of(os.path.join(os.path.dirname(package.__file__), "core.py")))
    assert fragile(frame_of(os.path.join(os.sep, "anywhere", "mod.py"), "__del__"))
    assert not fragile(frame_of(os.path.join(os.sep, "site-packages", "referee", "match", "loop.py")))
    assert not fragile(frame_of(os.path.join(os.sep, "home", "numba", "project", "mod.py")))  # a folder of that name


WORKER_STOPPED_IN_NUMBA = """
import os, signal, sys, time
import numba
from referee.contest import runner

LOAD = '''
def load():
    os.kill(os.getpid(), signal.SIGTERM)
    end = time.monotonic() + 0.05
    while time.monotonic() < end:
        pass  # the handler runs here, in what Python takes for numba's code
    return True
'''
runner._playing = True
runner.STOP.install()
namespace = {"os": os, "signal": signal, "time": time}
exec(compile(LOAD, os.path.join(os.path.dirname(numba.__file__), "core", "caching.py"), "exec"), namespace)
finished = False
try:
    finished = namespace["load"]()
    end = time.monotonic() + 20
    while time.monotonic() < end:
        time.sleep(0.01)
    sys.exit(2)  # never stopped
except runner._Stopped:
    sys.exit(0 if finished else 1)
"""


def test_a_grading_workers_stop_waits_while_numba_runs():
    """A pool worker told to stop (SIGTERM) inside numba's machinery (loading a match's
    kernels) takes the stop a moment later, once out of it: raised there, llvmlite's ctypes
    callbacks would drop it and the worker would play on."""
    out = subprocess.run([sys.executable, "-c", WORKER_STOPPED_IN_NUMBA], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr  # 1: stopped inside numba's code; 2: not at all


EARLY = """
import os, signal, sys, time
import referee.cli.entry


class Interrupting:
    # Ctrl-C while the command's own modules are still loading, before its handler is in place
    def find_spec(self, name, path, target=None):
        if name == "referee.cli.main":
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
        return None


sys.meta_path.insert(0, Interrupting())
sys.argv = ["laserarena", "levels"]
referee.cli.entry.run()
"""


def test_an_interrupt_before_the_commands_handler_is_in_place_is_one_line_and_130():
    out = subprocess.run([sys.executable, "-c", EARLY], capture_output=True, text=True, timeout=60)
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    assert out.stderr == "laserarena: interrupted\n"


def test_an_interrupt_inside_a_steady_section_is_taken_once_it_ends():
    """A section that must not be cut short (a process started and not yet recorded for the
    clean-up) finishes; the Ctrl-C that came meanwhile is taken right after it."""
    setup = (
        "from referee.interrupts import steady\n\n\n"
        "def section():\n"
        "    with steady():\n"
        "        interrupt_here()\n"
        "        print('the section finished', flush=True)\n"
    )
    out = _interrupted_inside(setup, "section()")
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    assert out.stdout == "the section finished\n"


TEMPLATE_STARTED = """
import os, signal, subprocess, sys, time
from referee.cli.main import handle_interrupts
from referee.sandbox import forkserver

handle_interrupts()
assert forkserver.unavailable() is None, forkserver.unavailable()  # probed before Popen is watched
real = subprocess.Popen


class Popen(real):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        print(self.pid, flush=True)
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C the moment the template's process exists
        end = time.monotonic() + 0.05
        while time.monotonic() < end:
            pass


subprocess.Popen = Popen
try:
    forkserver.start()
    time.sleep(5)
    sys.exit(0)  # the interrupt was lost
except KeyboardInterrupt:
    print("recorded for the clean-up:", [s.proc.pid for s in forkserver._all], flush=True)
    sys.exit(130)  # the exit handlers end the template
"""


def test_an_interrupt_as_the_template_starts_leaves_nothing_running():
    """The command's first process, the controllers' template, now starts while numba loads,
    when a Ctrl-C is likely: one that lands as it starts must not leave it unrecorded, which
    would leave a half-made bwrap sandbox running after the command."""
    out = subprocess.run([sys.executable, "-c", TEMPLATE_STARTED], capture_output=True, text=True, timeout=60)
    assert out.returncode == EXIT_INTERRUPTED, out.stderr
    pid, recorded = out.stdout.splitlines()
    assert recorded == f"recorded for the clean-up: [{pid}]"
    deadline = time.monotonic() + 10
    while os.path.exists(f"/proc/{pid}") and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not os.path.exists(f"/proc/{pid}")


WORKER_STOP_LOST = """
import os, signal, sys, time, weakref
from referee.contest import runner

runner.STOP_GRACE = 1.0
runner._playing = True
runner.STOP.install()


class Held:
    pass


def playing(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(0.01)


held = Held()
weakref.finalize(held, os.kill, os.getpid(), signal.SIGTERM)  # the handler runs in the callback, whose
try:  # exception Python prints and drops
    del held
    playing(0.5)  # the match plays on
except runner._Stopped:
    if sys.argv[1] == "dropped":
        sys.exit(0)  # taken again once out of the callback
    playing(30)  # a clean-up that hangs
sys.exit(2)
"""


@pytest.mark.parametrize("case, code", [("dropped", 0), ("hanging", 143)])
def test_a_grading_workers_stop_is_never_lost(case, code):
    """A stop raised where Python drops it (a weakref callback) is taken again a moment later;
    a worker whose clean-up hangs leaves STOP_GRACE after its stop. Else a worker whose parent
    has gone would play on, then wait for work for ever."""
    out = subprocess.run([sys.executable, "-c", WORKER_STOP_LOST, case], capture_output=True, text=True, timeout=60)
    assert "_Stopped" not in out.stderr  # no traceback of the dropped stop
    assert out.returncode == code, out.stderr
