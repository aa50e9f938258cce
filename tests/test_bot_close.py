"""Ending a controller process: `close` may run any number of times, and it never signals a
process it has already reaped (its number may by then name an unrelated process group)."""

import os

import pytest

import levels
from arena.level import ControllerLimits
from arena.loader import load_level
from referee.match.loop import brief_for
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve

FAST = ControllerLimits(setup_time=10, step_time=0.05, step_deadline=0.25, overage_bank=1.0, max_skips=3)


@pytest.mark.parametrize("sandboxed", [False, True])
def test_close_twice_never_signals_a_reaped_process(monkeypatch, sandboxed):
    bot = ProcessBot(resolve("ref:dead-reckoning"), FAST, slot=0, sandboxed=sandboxed, forked=False)
    assert bot.setup(brief_for(load_level(levels.path("asabe-race")), 0)) is None
    proc = bot.proc
    assert proc is not None and proc.pid is not None
    signalled = []
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
