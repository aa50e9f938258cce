"""A controller that burns every core it can (busy child processes, from setup to the end)
must not cost the other controllers their ticks, under tight time limits: the kernel's fair
scheduler wakes a controller that waited for its observation ahead of processes that never
wait (and shares the processors between sessions, each sandbox being one, where autogroups
are on). The others then play exactly the match they play beside a robot that stands still."""

import pytest

from hostile.hostile_kit import FAST, HONEST, assert_others_unharmed, short_race, team_file
from referee.match.loop import run_match
from referee.sandbox.kernel import unavailable
from referee.sandbox.teams import resolve

HOG = """
class Hog(Controller):
    def setup(self, brief):
        for _ in range(6):  # busy processes: all the cores there are, several times over
            if os.fork() == 0:
                print("spinning", file=sys.stderr, flush=True)
                while True:
                    pass

    def step(self, obs):
        return Command(0.0, 0.0)
"""

STILL = """
class Still(Controller):
    def step(self, obs):
        return Command(0.0, 0.0)
"""


def play(tmp_path, body: str, name: str):
    teams = [resolve(team_file(tmp_path, body, name))] + [resolve(HONEST)] * 3
    logs = tmp_path / name.removesuffix(".py")
    logs.mkdir()
    return run_match(short_race(20.0), teams, seed=3, limits=FAST, logs=logs).to_dict(), logs


def test_a_cpu_hog_costs_the_others_nothing(tmp_path):
    if unavailable():
        pytest.fail(f"needs the kernel sandbox: {unavailable()}")
    hogged, logs = play(tmp_path, HOG, "hog.py")
    assert (logs / "slot0.log").read_text().count("spinning") == 6  # the hog did burn
    assert_others_unharmed(hogged)
    calm, _ = play(tmp_path, STILL, "still.py")
    assert hogged["robots"][1:] == calm["robots"][1:]
