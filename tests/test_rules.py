"""Scoring and fouls with scripted controllers whose outcome is known in advance."""

import math
import textwrap

import pytest
from helpers import MINI_LEVEL, edited

from levels.loader import parse_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve


def level(text):
    return parse_level(text.encode(), "rules.yaml")


def team(tmp_path, body, name="t.py"):
    p = tmp_path / name
    p.write_text("from robots.api import *\nimport math\n\n" + textwrap.dedent(body))
    return resolve(str(p))


def play(text, *teams):
    """A match with a perfect drive (ideal), so the fouls land where straight-line kinematics says."""
    return play_match(level(text), list(teams), isolate=False, ideal=True)


STRAIGHT = """
    class Straight(Controller):
        def step(self, obs):
            return Command(0.1, 0.1, estimate=None)
"""


KNOWING = """
    class Knowing(Controller):
        # drives straight at 0.1 m/s from (0.5, 0.5) facing east and reports where straight-line
        # kinematics puts it: the wheels ramp up at 0.5 m/s^2, so 0.2 s at first, then steady
        def step(self, obs):
            t = obs.time
            x = 0.5 + (0.25 * t * t if t < 0.2 else 0.1 * t - 0.01)
            return Command(0.1, 0.1, estimate=(x, 0.5, 0.0))
"""


def test_waypoints_score_time_and_cross_track(tmp_path):
    # a robot driving dead straight along y = 0.5 through waypoints on y = 0.5 and y = 0.52
    text = MINI_LEVEL.replace("time_limit: 4", "time_limit: 20").replace(
        "path: [[1.0, 0.5], [1.5, 0.5]]", "path: [[1.0, 0.52], [1.5, 0.5]]"
    )
    blind = play(text, team(tmp_path, STRAIGHT))["robots"][0]
    r = play(text, team(tmp_path, KNOWING, "knowing.py"))["robots"][0]
    assert r["task"]["reached"] == blind["task"]["reached"] == 2
    finished = r["task"]["finished"]
    assert blind["task"]["finished"] == finished
    # it drives 1 m at 0.1 m/s after a 0.2 s ramp, reaching the last point 5 cm short of it
    assert finished == pytest.approx((0.95 + 0.1 * 0.2 / 2) / 0.1, abs=0.05)
    sc, quality = r["score"], r["localization"]["quality"]
    assert quality > 0.9  # its kinematics are the ideal drive's, to a fraction of a millimetre
    assert sc["task"] == 100 and sc["time"] == pytest.approx(20 * (1 - finished / 20) * quality)
    assert sc["localization"] == pytest.approx(25 * quality) and sc["penalties"] == 0
    assert sc["total"] == pytest.approx(sc["task"] + sc["time"] + sc["localization"])
    # the same finish without a word of where it was: no localization points, and no time bonus
    assert blind["score"]["time"] == blind["score"]["localization"] == 0 and blind["score"]["total"] == 100
    # cross-track from the polyline (0.5,0.5)->(1.0,0.52)->(1.5,0.5) for a robot on y = 0.5:
    # 0 at the ends, 2 cm at x = 1.0 (distance to a line of slope 0.04 is 0.02 cos(atan 0.04) at most)
    ct = r["task"]["cross_track"]  # in m, as every length of a result
    assert ct["max"] == pytest.approx(0.02 / math.hypot(1, 0.04), abs=0.0003)
    assert 0.005 < ct["mean"] < 0.012 and ct["std"] > 0


def test_a_waypoint_is_worth_its_legs_distance_from_the_path(tmp_path):
    """With `task.accuracy` a waypoint earns 1 / (1 + e / accuracy) of its share, e the RMS
    distance from the ideal path on the leg that led to it. The robot drives dead straight on
    y = 0.5; the path steps up to y = 0.51 at the first waypoint and stays there, so on the last
    leg (from where it reached x = 1.0 - sqrt(0.02^2 - 0.01^2) to where it reaches x = 1.5 - the
    same) it is exactly 1 cm off the path: that waypoint earns 1 / (1 + 0.01 / 0.01) = half."""
    text = edited(
        MINI_LEVEL,
        {
            "time_limit": 20,
            "task.radius": 0.02,
            "task.accuracy": 0.01,
            "task.path": [[0.6, 0.51], [1.0, 0.51], [1.5, 0.51]],
        },
    )
    r = play(text, team(tmp_path, STRAIGHT))["robots"][0]
    worth = r["task"]["worth"]
    assert r["task"]["reached"] == 3 and len(worth) == 3
    assert worth[2] == pytest.approx(0.5, abs=1e-9)
    # the second leg begins on the rising segment, nearer the path than 1 cm: a little more
    assert 0.5 < worth[1] < 0.52
    # the first leg rises 1 cm over 10 cm from the start; at most 1 cm off at its end: more than half
    assert 0.5 < worth[0] < 1
    assert r["score"]["task"] == pytest.approx(100 * sum(worth) / 3, abs=1e-6)
    # without an accuracy every waypoint counts whole
    whole = play(edited(text, {"task.accuracy": None}), team(tmp_path, STRAIGHT))["robots"][0]
    assert "worth" not in whole["task"] and whole["score"]["task"] == 100


def goto_level(goal_x: float, time_limit: int) -> str:
    """The mini table as a goto task: the goal at (`goal_x`, 0.5), radius 5 cm, on the robot's line."""
    return MINI_LEVEL.replace(
        "kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]",
        f"kind: goto\n  radius: 0.05\n  goal: [{goal_x}, 0.5]",
    ).replace("time_limit: 4", f"time_limit: {time_limit}")


def stopping_at(tmp_path, seconds: float):
    """A team that drives straight on at 0.1 m/s and stops at `seconds`."""
    body = f"""
        class StopAt(Controller):
            def step(self, obs):
                return Command(0.1, 0.1) if obs.time < {seconds} - 1e-9 else Command(0.0, 0.0)
    """
    return team(tmp_path, body, f"stop_{seconds:g}.py")


def test_a_goto_robot_arrives_by_stopping_and_passing_through_earns_nothing(tmp_path):
    # at 0.1 m/s from x = 0.5 (the wheels ramp at 0.5 m/s^2: 0.2 s, 1 cm each way), told to stop
    # at t = 9.7 s: x = 0.5 + 0.97 - 0.01 + 0.01 = 1.47, 3 cm short of the goal's centre; the
    # wheels are still (under 1 % of 0.17 m/s) from t = 9.9 s, so it arrives a second later
    r = play(goto_level(1.5, 16), stopping_at(tmp_path, 9.7))
    task = r["robots"][0]["task"]
    assert task["final_distance"] == pytest.approx(0.03, abs=1e-4)
    assert task["finished"] == pytest.approx(10.9, abs=1e-6) and r["end_reason"] == "task_complete"
    assert r["robots"][0]["score"]["task"] == pytest.approx(100 / (1 + task["final_distance"] / 0.05))
    passer = team(tmp_path, STRAIGHT, "passer.py")  # through the goal at t = 10.1 s, never standing
    r = play(goto_level(1.5, 13), passer)["robots"][0]
    assert r["task"]["finished"] is None and r["score"]["task"] == 0
    assert r["task"]["final_distance"] == pytest.approx(0.5 + 0.1 * 13 - 0.01 - 1.5, abs=1e-3)


def test_pushing_against_a_wall_within_the_radius_is_not_standing(tmp_path):
    # it meets the east wall at x = 2 - 0.105 / 2 by t = 15 s and goes on pushing, wheels
    # turning, 1.25 cm from the goal; told to stop at t = 17 s, its wheels are still at 17.2 s
    task = play(goto_level(1.96, 20), stopping_at(tmp_path, 17.0))["robots"][0]["task"]
    assert task["finished"] == pytest.approx(18.2, abs=1e-6)
    assert task["final_distance"] == pytest.approx(1.96 - (2 - 0.105 / 2), abs=1e-3)


def test_localize_scored_on_error(tmp_path):
    localize = MINI_LEVEL.replace("kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]", "kind: localize")
    off = team(
        tmp_path,
        """
        class Off(Controller):
            def step(self, obs):
                return Command(0.0, 0.0, estimate=(0.51, 0.5, 0.0))
    """,
        "off.py",
    )
    r = play(localize, off)["robots"][0]
    # 1 cm off every tick: quality 1 / (1 + 10 mm / 10 mm) = 0.5 -> 50 of 100 points
    assert r["score"]["localization"] == pytest.approx(50.0) and r["score"]["task"] == 0


TWO = (
    MINI_LEVEL.replace("size: [2.0, 1.0]", "size: [3.0, 1.0]")
    .replace(
        """robots:
  - model: boe-bot
    start: [0.5, 0.5, 0]
    start_known: true
""",
        """robots:
  - model: boe-bot
    start: [0.5, 0.5, 0]
    path: [[2.5, 0.5]]
  - model: boe-bot
    start: [2.5, 0.5, 180]
    path: [[0.5, 0.5]]
""",
    )
    .replace("  path: [[1.0, 0.5], [1.5, 0.5]]\n", "")
    .replace("time_limit: 4", "time_limit: 12")
)


LOCALIZE = MINI_LEVEL.replace(
    "kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]", "kind: localize"
).replace("time_limit: 4", "time_limit: 20")


def test_robot_and_wall_collisions_are_fouls_with_impulse(tmp_path):
    head_on = team(tmp_path, STRAIGHT)
    result = play(TWO, head_on, head_on)
    for r in result["robots"]:
        kinds = [f["kind"] for f in r["fouls"]]
        assert "robot_collision" in kinds
        hit = next(f for f in r["fouls"] if f["kind"] == "robot_collision")
        # they meet in the middle, x = 1.5, each 0.1 m/s: about when 0.895 m each is covered
        assert hit["place"][0] == pytest.approx(1.5, abs=0.06)
        assert hit["time"] == pytest.approx((1.0 - 0.105 / 2) / 0.1 + 0.1, abs=0.3)
        assert hit["impulse"] > 0 and hit["penalty"] == 2.0
    wall = play(LOCALIZE, team(tmp_path, STRAIGHT))  # drives on into the east wall at x = 2
    fouls = wall["robots"][0]["fouls"]
    assert [f["kind"] for f in fouls] == ["wall_collision"] and fouls[0]["place"][0] == pytest.approx(2.0, abs=0.01)
    assert wall["robots"][0]["score"]["penalties"] == 1.0


def test_leaving_the_field_speeding_and_faults_are_fouls(tmp_path):
    open_field = (
        LOCALIZE.replace("  size: [2.0, 1.0]", "  size: [2.0, 1.0]\n  walls: false")
        + "rules: {speed_limit: 0.05, penalties: {leave_field: 7}}\n"
    )
    r = play(open_field, team(tmp_path, STRAIGHT))["robots"][0]
    kinds = [f["kind"] for f in r["fouls"]]
    assert kinds == ["speeding", "leave_field"]
    speeding, leave = r["fouls"]
    assert speeding["speed"] > 0.05 and speeding["time"] == pytest.approx(0.05 / 0.5, abs=0.01)
    assert leave["place"][0] == pytest.approx(2.0, abs=0.01) and leave["penalty"] == 7
    crash = team(
        tmp_path,
        """
        class Crash(Controller):
            def step(self, obs):
                raise RuntimeError("no")
    """,
        "crash.py",
    )
    r = play(MINI_LEVEL, crash)["robots"][0]
    assert [f["kind"] for f in r["fouls"]] == ["fault"] and r["score"]["penalties"] == 25.0
