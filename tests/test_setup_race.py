"""A controller that ends before the referee writes its brief (its module fails as it loads,
faster than the referee gets to it) is still judged by what it said first: its load fault, not
a bare crash. The race is forced: the brief is written only once the process has ended."""

import select
import time

import pytest

import levels
from levels.loader import load_level
from levels.match import ControllerLimits
from referee.match.views import brief_for
from referee.sandbox.fault import FaultKind
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve

LIMITS = ControllerLimits(setup_time=10, step_time=0.05, step_deadline=0.25, overage_bank=1.0, max_skips=3)


def ended(bot: ProcessBot, within: float = 20.0) -> bool:
    """Whether the controller's input lost its reader (the process ended) within `within` s."""
    poller = select.poll()
    poller.register(bot.channel.stdin.fileno(), 0)  # a pipe's writer hears POLLERR once no one reads
    stop = time.monotonic() + within
    while time.monotonic() < stop:
        if any(events & select.POLLERR for _, events in poller.poll(100)):
            return True
    return False


@pytest.mark.parametrize("forked", [False, True], ids=["spawned", "forked"])
def test_a_load_fault_said_before_the_brief_is_the_fault(tmp_path, forked):
    team = tmp_path / "quits.py"
    team.write_text("import sys\nsys.exit('not today')\n")
    team.chmod(0o644)
    tmp_path.chmod(0o755)
    bot = ProcessBot(resolve(str(team)), LIMITS, slot=0, sandboxed=True, forked=forked)
    try:
        bot.launch()
        assert ended(bot), "the controller did not end within 20 s"
        fault = bot.setup(brief_for(load_level(levels.path("asabe")), 0))
    finally:
        bot.close()
    assert fault is not None and fault.kind == FaultKind.LOAD
    assert "SystemExit" in fault.message and "not today" in fault.message, fault.message
