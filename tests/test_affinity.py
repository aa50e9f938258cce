"""A match with one controller process runs its referee thread and that controller on one CPU
(referee/sandbox/affinity.py); matches with more keep every CPU; two referees never share
a claimed CPU. Needs a machine of two CPUs or more, as CI's is."""

import os
import textwrap
import threading

import pytest
from helpers import variant

from referee.match.loop import Match
from referee.match.views import brief_for
from referee.records.replay_reader import load
from referee.sandbox import affinity
from referee.sandbox.exchange import exchange
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve

pytestmark = pytest.mark.alone  # CPU claims: no other test's referee may hold one meanwhile

# a controller that reports, as its estimate, how many CPUs it may run on and the lowest of them
REPORTER = """
from robots.api import Command, Controller
import os

class Reporter(Controller):
    def step(self, obs):
        cpus = os.sched_getaffinity(0)
        return Command(0.05, 0.05, estimate=(float(len(cpus)), float(min(cpus)), 0.0))
"""


def reporter(tmp_path):
    path = tmp_path / "reporter.py"
    path.write_text(textwrap.dedent(REPORTER))
    return resolve(str(path))


def test_the_machine_has_a_choice_of_cpus():
    assert len(os.sched_getaffinity(0)) >= 2  # else there is nothing to pin, and nothing to test


@pytest.mark.parametrize("forked", [True, False])  # from the template (root), or a sandbox spawned for it
def test_a_lone_controller_shares_its_referees_cpu(tmp_path, forked):
    before = os.sched_getaffinity(0)
    level = variant("asabe", "short.yaml", time_limit=3)
    match = Match(level, [reporter(tmp_path)], replay=tmp_path / "m.replay")
    match.fleet.bots = [ProcessBot(match.teams[0], level.limits, slot=0, forked=forked)]
    try:
        sim, fleet = match.simulation, match.fleet
        tick = sim.start(fleet.start([brief_for(level, 0)]))
        assert fleet.cpu is not None
        assert os.sched_getaffinity(0) == {fleet.cpu.cpu}  # the referee thread, pinned
        cpu = fleet.cpu.cpu
        while not tick.ended:
            tick = sim.step(exchange(fleet.bots, tick.observations))
        sim.end()
    finally:
        match.fleet.close()
    assert os.sched_getaffinity(0) == before  # given back at the end
    estimates = [tuple(r["e"][:2]) for r in load(tmp_path / "m.replay").estimates]
    assert len(estimates) >= 10 and set(estimates) == {(1.0, float(cpu))}  # the controller: that CPU alone


def test_several_controllers_keep_every_cpu(tmp_path):
    before = os.sched_getaffinity(0)
    level = variant("asabe-race", "short.yaml", time_limit=2)
    match = Match(level, [reporter(tmp_path)] * 4, replay=tmp_path / "m.replay")
    match.run()
    assert os.sched_getaffinity(0) == before
    estimates = {tuple(r["e"][:2]) for r in load(tmp_path / "m.replay").estimates}
    assert estimates == {(float(len(before)), float(min(before)))}


def test_two_referees_never_claim_one_cpu():
    allowed = os.sched_getaffinity(0)
    claims: list = []
    ready, done = threading.Barrier(len(allowed) + 2), threading.Event()

    def referee():
        mine = affinity.claim()
        claims.append(mine)
        ready.wait(timeout=30)
        done.wait(timeout=30)
        if mine is not None:
            affinity.release(mine)

    threads = [threading.Thread(target=referee) for _ in range(len(allowed) + 1)]
    for t in threads:
        t.start()
    ready.wait(timeout=30)
    try:
        assert sorted(c.cpu for c in claims if c is not None) == sorted(allowed)  # each CPU once
        assert claims.count(None) == 1  # and the referee left over runs unpinned
    finally:
        done.set()
        for t in threads:
            t.join(timeout=30)
    again: list = []

    def claim_and_release():
        again.append(affinity.claim())
        if again[0] is not None:
            affinity.release(again[0])

    t = threading.Thread(target=claim_and_release)
    t.start()
    t.join(timeout=30)
    assert again and again[0] is not None  # released: free to claim again
