"""Nothing a controller starts outlives its slot: not at match end, not on a fault, not when the
referee itself is stopped by SIGINT, SIGTERM or SIGKILL."""

import signal
import subprocess
import sys
import time

import pytest

from hostile.hostile_kit import (
    assert_contained,
    hostile_match,
    sandboxed_processes,
    slot_uids,
    team_file,
    wait_until_gone,
)

DAEMON = """
def daemonize():
    # the textbook daemon: fork, setsid, fork again, the grandchild lives on (in a loop); a
    # sandbox refuses setsid (the slot's processes stay in one session), so it goes on without
    if os.fork() == 0:
        try:
            os.setsid()
        except PermissionError:
            pass
        if os.fork() == 0:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            signal.signal(signal.SIGHUP, signal.SIG_IGN)
            while True:
                time.sleep(0.05)
        os._exit(0)
    os.wait()
"""


def test_a_setsid_daemon_dies_with_its_slot(tmp_path):
    result = hostile_match(
        tmp_path,
        DAEMON
        + """
class Daemon(Controller):
    def setup(self, brief):
        daemonize()
    def step(self, obs):
        if obs.tick == 3:
            raise RuntimeError("contained: the daemon is on its own now")
        return Command(0.05, 0.05)
""",
    )
    assert_contained(result)  # and (the fixture) no process of any slot is left


def test_children_of_a_healthy_controller_end_with_the_match(tmp_path):
    result = hostile_match(
        tmp_path,
        DAEMON
        + """
class Parent(Controller):
    def setup(self, brief):
        daemonize()
        self.child = os.fork()
        if self.child == 0:
            time.sleep(600)
    def step(self, obs):
        return Command(0.05, 0.05, estimate=(0.3, 0.25, 0.0))
""",
        seconds=3,
    )
    assert all(not r["faults"] for r in result["robots"])


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_stopping_the_referee_ends_every_sandbox(tmp_path, sig):
    daemon = team_file(
        tmp_path,
        DAEMON
        + """
class Daemon(Controller):
    def setup(self, brief):
        daemonize()
    def step(self, obs):
        return Command(0.05, 0.05)
""",
    )
    referee = subprocess.Popen(
        [sys.executable, "-m", "referee", "run", "asabe-race", "--team", daemon, "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline, seen, held = time.monotonic() + 60, [], set()
        while seen[-2:] != [True, True] and time.monotonic() < deadline:  # twice: not a passing fork
            held |= slot_uids(referee.pid)  # the uids it holds while it lives
            seen.append(len(sandboxed_processes(held)) >= 5)  # four runners and the daemon
            time.sleep(0.1)
        assert seen[-2:] == [True, True], "the match never got going"
        referee.send_signal(sig)
        referee.wait(timeout=60)
        assert wait_until_gone(held) == []
    finally:
        if referee.poll() is None:
            referee.kill()
            referee.wait()
    if sig != signal.SIGKILL:  # stopped in order: said so in one line
        assert referee.returncode == 130 and referee.stderr.read() == "laserarena: interrupted\n"
