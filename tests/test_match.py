"""The match loop: faults stop one robot and not the match; estimates are scored against truth."""

import hashlib
import textwrap

import pytest
from helpers import MINI_LEVEL, edited

from levels.loader import parse_level
from referee.errors import TeamError
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots._host.loading import load_class
from robots.api import StartInfo

TWO = edited(
    MINI_LEVEL,
    {
        "robots": [
            {"model": "boe-bot", "start": [0.5, 0.25, 0], "start_known": True, "path": [[1.0, 0.25], [1.5, 0.25]]},
            {"model": "boe-bot", "start": [0.5, 0.75, 0], "start_known": True, "path": [[1.0, 0.75], [1.5, 0.75]]},
        ],
        "task.path": None,
        "time_limit": 12,
    },
)


def level(text=MINI_LEVEL):
    return parse_level(text.encode(), "test.yaml")


def team_file(tmp_path, body, name="team.py"):
    p = tmp_path / name
    p.write_text("from robots.api import *\nimport math\n\n" + textwrap.dedent(body))
    return str(p)


@pytest.mark.parametrize("isolate", [True, False], ids=["isolated", "in-process"])
def test_exception_in_step_stops_that_robot_only(tmp_path, isolate):
    bad = team_file(
        tmp_path,
        """
        class Bad(Controller):
            def step(self, obs):
                if obs.tick == 3:
                    raise RuntimeError("boom\\nsecond line")
                return Command(0.1, 0.1)
    """,
    )
    result = play_match(level(TWO), [resolve(bad), resolve("ref:dead-reckoning")], isolate=isolate)
    r0, r1 = result["robots"]
    (fault,) = r0.faults  # the typed result; the same fields by their JSON names below
    assert (fault.tick, fault.kind, fault.message) == (3, "exception", "in step: RuntimeError: boom second line")
    assert fault.time == pytest.approx(0.15)
    assert r0["stopped"] and not r1["faults"]
    assert r1.task.reached == r1["task"]["reached"] == 2  # the other robot finished its path
    assert result["end_reason"] == "task_complete"
    # the faulted robot stopped where it was (it had driven 3 ticks, then ramped down)
    assert 0.5 < r0["final_pose"][0] < 0.56


@pytest.mark.parametrize("isolate", [True, False], ids=["isolated", "in-process"])
def test_exception_in_setup_and_bad_commands(tmp_path, isolate):
    setup_fails = team_file(
        tmp_path,
        """
        class A(Controller):
            def setup(self, brief):
                raise ValueError("no")
    """,
        "a.py",
    )
    nan = team_file(
        tmp_path,
        """
        class B(Controller):
            def step(self, obs):
                return Command(float("nan"), 0.0)
    """,
        "b.py",
    )
    result = play_match(level(TWO), [resolve(setup_fails), resolve(nan)], isolate=isolate)
    (f0,), (f1,) = result["robots"][0]["faults"], result["robots"][1]["faults"]
    assert (f0["kind"], f0["tick"]) == ("exception", 0) and "ValueError: no" in f0["message"]
    assert (f1["kind"], f1["tick"]) == ("bad_command", 0) and "left" in f1["message"]
    assert result["end_reason"] == "all_stopped"
    for r in result["robots"]:  # nothing moved
        assert r["final_pose"][0] == pytest.approx(0.5)


@pytest.mark.parametrize("isolate", [True, False], ids=["isolated", "in-process"])
def test_wrong_return_type_is_a_bad_command(tmp_path, isolate):
    t = team_file(
        tmp_path,
        """
        class C(Controller):
            def step(self, obs):
                return (0.1, 0.1)
    """,
    )
    result = play_match(level(), [resolve(t)], isolate=isolate)
    assert result["robots"][0]["faults"][0]["kind"] == "bad_command"
    assert result["robots"][0]["faults"][0]["message"] == "step() returned tuple, not Command"


def test_estimate_errors_scored_against_truth(tmp_path):
    # A robot standing still at (0.5, 0.5, 0) reports a fixed offset estimate on even ticks only.
    t = team_file(
        tmp_path,
        """
        class Offset(Controller):
            def step(self, obs):
                est = (0.53, 0.54, 0.1) if obs.tick % 2 == 0 else None
                return Command(0.0, 0.0, estimate=est)
    """,
    )
    result = play_match(level(), [resolve(t)])
    loc = result["robots"][0]["localization"]
    n = round(4.0 / 0.05)  # control ticks in the 4 s time limit
    assert loc["ticks"] == n and loc["estimates"] == n // 2 and loc["fraction"] == 0.5
    assert loc["position_rms"] == pytest.approx(0.05) and loc["position_max"] == pytest.approx(0.05)
    assert loc["heading_rms"] == pytest.approx(0.1) and loc["heading_max"] == pytest.approx(0.1)
    assert result["end_reason"] == "time_limit" and result["end_time"] == pytest.approx(4.0)


def test_heading_error_wraps_around(tmp_path):
    t = team_file(
        tmp_path,
        """
        class Wrap(Controller):
            def step(self, obs):
                return Command(0.0, 0.0, estimate=(0.5, 0.5, 2 * math.pi - 0.02))
    """,
    )
    loc = play_match(level(), [resolve(t)])["robots"][0]["localization"]
    assert loc["heading_max"] == pytest.approx(0.02)


def test_observations_arrive_every_control_period(tmp_path):
    t = team_file(
        tmp_path,
        """
        SEEN = []
        class Clock(Controller):
            def setup(self, brief):
                SEEN.append(brief)
            def step(self, obs):
                SEEN.append((obs.tick, obs.time))
                return Command(0.0, 0.0)
    """,
    )
    team = resolve(t)
    play_match(level(), [team], isolate=False)  # reads the controller's memory afterwards
    seen = __import__(load_class(team.spec).__module__).SEEN
    brief, ticks = seen[0], seen[1:]
    assert brief.start == StartInfo(0.5, 0.5, 0.0) and brief.control_period == 0.05
    assert [b.id for b in brief.beacons] == ["O", "A", "B"]
    assert ticks == [(k, pytest.approx(k * 0.05)) for k in range(80)]


def test_brief_hides_start_unless_announced(tmp_path):
    t = team_file(
        tmp_path,
        """
        BRIEFS = []
        class Look(Controller):
            def setup(self, brief):
                BRIEFS.append(brief)
            def step(self, obs):
                return Command(0.0, 0.0)
    """,
    )
    team = resolve(t)
    play_match(level(edited(MINI_LEVEL, {"robots.0.start_known": False})), [team], isolate=False)
    brief = __import__(load_class(team.spec).__module__).BRIEFS[0]
    assert brief.start is None
    text = repr(brief)
    assert "0.5, 0.5" not in text  # the true start pose appears nowhere in what the team gets


def test_waypoint_task_ends_match_when_done():
    # a perfect drive (ideal), so blind dead reckoning surely reaches both waypoints
    result = play_match(level(edited(MINI_LEVEL, {"time_limit": 12})), [resolve("ref:dead-reckoning")], ideal=True)
    r = result["robots"][0]
    assert r["task"]["reached"] == 2 and r["score"]["task"] == 100.0
    assert result["end_reason"] == "task_complete"
    assert result["end_time"] == pytest.approx(r["task"]["finished"])
    # the robot drove ~1 m at <= 0.17 m/s: it cannot have finished sooner than that allows
    assert result["end_time"] > (1.5 - 0.05 - 0.5) / 0.17


def test_team_specs(tmp_path):
    """Resolving finds and hashes a team's code without running it; loading is the controller's."""
    two = team_file(
        tmp_path,
        """
        class One(Controller):
            def step(self, obs): return Command(0, 0)
        class Two(Controller):
            def step(self, obs): return Command(0, 0)
    """,
    )
    team = resolve(two + ":Two")
    assert team.label == "team.py:Two"  # no machine-dependent path
    assert team.code_hash == "sha256:" + hashlib.sha256(open(two, "rb").read()).hexdigest()
    assert team.files == (("team.py", (tmp_path / "team.py").read_bytes()),) and team.entry == "team.py:Two"
    assert load_class(team.spec).__name__ == "Two"
    with pytest.raises(TeamError, match="no such file"):
        resolve(str(tmp_path / "missing.py"))
    with pytest.raises(TeamError, match="no such folder or module 'no.such.module'; a team is ref:NAME"):
        resolve("no.such.module:X")
    idle = resolve("robots.controllers.idle:Idle")
    assert idle.files == () and idle.entry == "robots.controllers.idle:Idle"  # robots is in every sandbox


def test_loading_problems_are_load_faults_of_their_slot(tmp_path):
    two = team_file(
        tmp_path,
        """
        class One(Controller):
            def step(self, obs): return Command(0, 0)
        class Two(Controller):
            def step(self, obs): return Command(0, 0)
    """,
    )
    broken = team_file(tmp_path, "import no_such_module_here\n", "broken.py")
    for isolate in (True, False):
        for spec, words in (
            (
                two,
                "team.py has 2 Controller classes (One, Two); name the one to run after the team's name, as TEAM:One",
            ),
            (two + ":Three", "team.py has no class Three (its Controller classes: One, Two)"),
            (broken, "broken.py failed to load: ModuleNotFoundError"),
        ):
            result = play_match(level(), [resolve(spec)], isolate=isolate)
            (fault,) = result["robots"][0]["faults"]
            assert fault["kind"] == "load" and words in fault["message"], (isolate, fault)


def test_the_replay_written_while_controllers_compute_is_the_replay_written_at_once(tmp_path):
    """`run()` writes a period's frames and events while the controllers compute; a step-wise
    driver (as the RL environment) writes each at once. The bytes are the same."""
    from helpers import variant

    from referee.match.simulation import Simulation
    from referee.match.views import brief_for, replay_header
    from referee.records.replay_writer import ReplayWriter
    from referee.sandbox.in_process import InProcessBot

    lv = variant("asabe-race", time_limit=8)
    teams = [resolve(s) for s in ("ref:bac", "ref:dead-reckoning", "ref:best", "ref:starter")]
    play_match(lv, teams, seed=5, replay=tmp_path / "run.replay", isolate=False)
    header = replay_header(lv, teams, 5, False, None)
    sim = Simulation(lv, [t.label for t in teams], seed=5, recorder=ReplayWriter(tmp_path / "stepwise.replay", header))
    bots = [InProcessBot(t) for t in teams]
    tick = sim.start([bot.setup(brief_for(lv, s)) for s, bot in enumerate(bots)])
    while not tick.ended:
        assert not sim.deferred.pending  # nothing put off in this driver
        tick = sim.step([None if obs is None else bot.step(obs) for bot, obs in zip(bots, tick.observations)])
    sim.end()
    assert (tmp_path / "run.replay").read_bytes() == (tmp_path / "stepwise.replay").read_bytes()


def test_the_controllers_boot_while_the_simulation_is_made(monkeypatch):
    # a match's controllers are launched before its simulation core is built (a process's
    # first match loads the compiled kernels then); making a Match starts no process
    from referee.match import loop

    launched = []
    made = loop.Simulation.__init__

    def noting(sim, *args, **kwargs):
        launched.append([bot.started is not None for bot in match.fleet.bots])
        made(sim, *args, **kwargs)

    monkeypatch.setattr(loop.Simulation, "__init__", noting)
    lv = parse_level(TWO.encode(), "two.yaml")
    match = loop.Match(lv, [resolve("ref:idle")] * 2, seed=1)
    assert [bot.started for bot in match.fleet.bots] == [None, None]
    match.run()
    assert launched == [[True, True]]
