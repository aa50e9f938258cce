"""A child's end is seen as it comes (referee.sandbox.exits): by its pidfd, or by polls where
the system has none; the child is left unreaped either way."""

import os
import subprocess

import pytest

from referee.sandbox import exits
from referee.sandbox.process import exit_status


@pytest.fixture(params=["pidfd", "polls"])
def how(request, monkeypatch):
    if request.param == "polls":
        monkeypatch.delattr(os, "pidfd_open")
    return request.param


def test_an_end_is_seen_as_it_comes_and_not_before(how):
    running = subprocess.Popen(["sleep", "30"])
    try:
        assert exits.ended(running, 0.05) is False
        assert exits.ended(running, 0.0) is False
        assert running.poll() is None
    finally:
        running.kill()
    assert exits.ended(running, 30.0) is True  # killed: seen without waiting out the 30 s
    assert os.waitid(os.P_PID, running.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None  # not reaped
    assert running.wait(timeout=30) == -9
    assert exits.ended(running, 30.0) is True  # reaped already
    quick = subprocess.Popen(["true"])
    assert exits.ended(quick, 30.0) is True and quick.wait(timeout=30) == 0


def test_a_spawned_controller_s_status_comes_unreaped_as_popen_gives_it(how):
    killed = subprocess.Popen(["sleep", "30"])
    assert exit_status(killed, 0.0) is None
    killed.kill()
    assert exit_status(killed, 30.0) == -9
    assert killed.returncode is None  # its pid still names it alone
    assert killed.wait(timeout=30) == -9
    failing = subprocess.Popen(["sh", "-c", "exit 3"])
    assert exit_status(failing, 30.0) == 3 and failing.wait(timeout=30) == 3
