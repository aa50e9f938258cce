"""Ending a controller process: `close` may run any number of times, and it never signals a
process it has already reaped (its number may by then name an unrelated process group). The
controllers' template ends at once when its referee closes it. A match tells its controllers
it is over before it writes its result and replay, so they end meanwhile."""

import dataclasses
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import closed_to_others

import levels
from levels.loader import load_level
from levels.match import ControllerLimits
from referee.errors import UserError
from referee.match import loop
from referee.match.simulation import Simulation
from referee.match.views import brief_for
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve

FAST = ControllerLimits(setup_time=10, step_time=0.05, step_deadline=0.25, overage_bank=1.0, max_skips=3)


@pytest.mark.parametrize(
    "sandboxed, forked", [(False, False), (True, False), (True, True)], ids=["plain", "spawned", "forked"]
)
def test_close_twice_never_signals_a_reaped_process(monkeypatch, sandboxed, forked):
    bot = ProcessBot(resolve("ref:dead-reckoning"), FAST, slot=0, sandboxed=sandboxed, forked=forked)
    brief = brief_for(load_level(levels.path("asabe-race")), 0)
    signalled: list[tuple[int, int | None]] = []
    if (
        not sandboxed and os.geteuid() == 0 and closed_to_others(Path(sys.prefix))
    ):  # refused before any process exists: closing signals nothing
        monkeypatch.setattr(os, "killpg", lambda pgid, sig: signalled.append((pgid, None)))
        with pytest.raises(UserError, match="closed to other users"):
            bot.setup(brief)
        bot.close()
        bot.close()
        assert signalled == []
        return
    assert bot.setup(brief) is None
    proc = bot.proc
    assert proc is not None
    if proc.pid is None:  # forked by the template, which ends it: the referee signals no process itself
        monkeypatch.setattr(os, "killpg", lambda pgid, sig: signalled.append((pgid, None)))
        bot.close()
        bot.close()
        assert proc.returncode is not None and signalled == []
        return
    killpg = os.killpg

    def spy(pgid: int, sig: int) -> None:
        signalled.append((pgid, proc.returncode))  # the process's status when it was signalled
        if pgid == proc.pid and proc.returncode is None:
            killpg(pgid, sig)

    monkeypatch.setattr(os, "killpg", spy)
    bot.close()
    bot.close()
    assert proc.returncode is not None  # ended, and reaped
    assert all(code is None for pgid, code in signalled if pgid == proc.pid), signalled
    assert (proc.pid, None) in signalled  # its session was still ended, children and all


def test_the_template_ends_without_its_teardown_once_the_referee_closes_it():
    """The referee waits for its template's end: the template takes no interpreter teardown
    (an exit handler registered before it serves never runs), and ends with 0."""
    ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    code = (
        "import atexit, runpy, sys\n"
        "atexit.register(print, 'torn down')\n"
        "sys.argv = ['robots._host.template', sys.argv[1]]\n"
        "runpy.run_module('robots._host.template', run_name='__main__')\n"
    )
    with subprocess.Popen(
        [sys.executable, "-c", code, str(theirs.fileno())],
        pass_fds=[theirs.fileno()],
        stdout=subprocess.PIPE,
        text=True,
    ) as template:
        theirs.close()
        try:
            ours.settimeout(60)
            said = ours.recv(16)
        finally:
            ours.close()  # the referee's end of the control socket: the template ends
        out, _ = template.communicate(timeout=60)
    assert said == b"r"  # it had imported and was serving
    assert template.returncode == 0
    assert "torn down" not in out


def test_a_view_of_the_last_observation_held_elsewhere_does_not_stop_the_next():
    """The step frame's buffer is reused tick to tick; where a view of it is still alive (a
    finished write's leftover kept by a reference cycle), the next frame takes a new buffer
    rather than failing to resize the held one."""
    from robots.api import Command, Observation

    bot = ProcessBot(resolve("ref:idle"), FAST, slot=0)
    try:
        assert bot.setup(brief_for(load_level(levels.path("asabe-race")), 0)) is None
        assert isinstance(bot.step(Observation(tick=0, time=0.0, events=())), Command)
        held = memoryview(bot.frame)  # as a leftover view of tick 0's frame would
        assert isinstance(bot.step(Observation(tick=1, time=0.05, events=())), Command)
        assert held.obj is not bot.frame  # that buffer is left to its holder
        held.release()
    finally:
        bot.close()


def test_the_controllers_are_told_the_match_is_over_before_its_result_is_written(monkeypatch, tmp_path):
    told_at_end = []
    end = Simulation.end

    def ending(sim):
        told_at_end.extend(bot.told_to_end for bot in match.fleet.bots)
        return end(sim)

    monkeypatch.setattr(Simulation, "end", ending)
    level = dataclasses.replace(load_level(levels.path("asabe-race")), time_limit=1.0)
    match = loop.Match(level, [resolve("ref:dead-reckoning")] * 4, seed=1, replay=tmp_path / "m.replay", limits=FAST)
    result = match.run()
    assert told_at_end == [True] * 4
    assert all(not r["faults"] for r in result.to_dict()["robots"])
