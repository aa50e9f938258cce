"""The simulation core (referee/match/simulation.py): a match's world, sensing, task, rules and
score with no processes and no files, stepped by answers and reporting each tick. Checked
against the match that plays the same answers through its controllers, and against the
result's own totals."""

import math
import os
import textwrap

from helpers import exact_starts, variant

from referee.match.loop import play_match
from referee.match.simulation import Simulation
from referee.sandbox.teams import resolve
from robots.api import Command

# a scripted driver: what it answers depends only on the observation's tick and its slot
SCRIPT = """
    from robots.api import Command, Controller

    class Script(Controller):
        def setup(self, brief):
            self.slot = brief.slot

        def step(self, obs):
            k = obs.tick + 7 * self.slot
            left, right = [(0.3, 0.3), (0.3, -0.1), (-0.2, -0.25), (0.25, 0.3)][(k // 10) % 4]
            return Command(left, right, estimate=(0.5 + 0.001 * obs.tick, 0.4, 0.1))
"""


def scripted(slot: int, tick: int) -> Command:
    """SCRIPT's answer, written a second time."""
    k = tick + 7 * slot
    left, right = [(0.3, 0.3), (0.3, -0.1), (-0.2, -0.25), (0.25, 0.3)][(k // 10) % 4]
    return Command(left, right, estimate=(0.5 + 0.001 * tick, 0.4, 0.1))


def level():
    return variant("asabe-race", time_limit=12, rules__speed_limit=0.1, **exact_starts("asabe-race"))


def open_files() -> set[str]:
    return set(os.listdir("/proc/self/fd"))


def children() -> set[str]:
    me = str(os.getpid())
    out = set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[1] == me:
                    out.add(pid)
        except OSError:
            pass
    return out


def test_stepped_by_hand_it_gives_the_matchs_result(tmp_path):
    """The same answers, given to the core tick by tick, give the result the match gives when
    its controllers answer them; the core opens no file and starts no process on the way."""
    (tmp_path / "script.py").write_text(textwrap.dedent(SCRIPT))
    lv = level()
    matched = play_match(lv, [resolve(str(tmp_path / "script.py"))] * 4, seed=3, isolate=False)

    files, kids = open_files(), children()
    sim = Simulation(lv, [r.team for r in matched.robots], seed=3)
    tick = sim.start()
    ticks = [tick]
    while not tick.ended:
        answers = [None if o is None else scripted(s, o.tick) for s, o in enumerate(tick.observations)]
        tick = sim.step(answers)
        ticks.append(tick)
    result = sim.end()
    assert open_files() == files and children() == kids
    assert result == matched

    # what the ticks reported adds up to the result
    for slot, robot in enumerate(result.robots):
        called = [f.to_record() for t in ticks for f in t.fouls[slot]]
        assert called == robot.fouls[: len(called)]  # each foul told once, in order (end may add more)
        earned = math.fsum(t.earned[slot] for t in ticks if t.earned[slot] is not None)
        assert earned / robot.localization.ticks == robot.localization.quality
        assert ticks[-1].progress[slot] == robot.task.reached / robot.task.total  # a race: every waypoint whole
    assert {f.kind for r in result.robots for f in r.fouls} >= {"speeding"}  # the rules did run


def test_an_ended_simulation_takes_no_more_answers():
    sim = Simulation(variant("bac-line", time_limit=0.4), ["a"], seed=1)
    tick = sim.start()
    while not tick.ended:
        tick = sim.step([Command(0.1, 0.1)])
    try:
        sim.step([Command(0.1, 0.1)])
    except RuntimeError as e:
        assert "ended" in str(e)
    else:
        raise AssertionError("an ended simulation took a step")
