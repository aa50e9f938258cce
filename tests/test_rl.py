"""The Gymnasium and PettingZoo envs: API conformance, the referee's own physics and scoring,
and observations that match the geometry. Needs the `rl` extra (installed by `make test`)."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

gymnasium = pytest.importorskip("gymnasium", reason="the rl extra is not installed: pip install '.[rl]'")
pytest.importorskip("pettingzoo", reason="the rl extra is not installed: pip install '.[rl]'")

from helpers import exact_starts, variant  # noqa: E402

import levels  # noqa: E402
from levels.loader import parse_level  # noqa: E402
from referee.match.loop import play_match  # noqa: E402
from referee.match.views import brief_for  # noqa: E402
from referee.sandbox.teams import resolve  # noqa: E402
from robots.api import Observation  # noqa: E402
from robots.controllers.dead_reckoning import DeadReckoning  # noqa: E402
from robots.toolkit.features import AGE_MAX, GOAL, HEADER, PER_BEACON  # noqa: E402


def shortened(name: str, seconds: float):
    d = yaml.safe_load(levels.path(name).read_text())
    d["time_limit"] = seconds
    return parse_level(yaml.safe_dump(d).encode(), f"{name}-{seconds:g}.yaml")


def test_gym_make_by_module_name_and_check_env():
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make("referee.gym:LaserArena-v0", level="asabe")
    assert env.action_space.shape == (2,) and env.observation_space.shape == (HEADER + PER_BEACON * 4,)
    check_env(env.unwrapped, skip_render_check=False)
    env.close()
    with_estimate = gymnasium.make(
        "referee.gym:LaserArena-v0", level=shortened("vannoy", 5), report_estimate=True, render_mode="rgb_array"
    )
    check_env(with_estimate.unwrapped)
    with_estimate.reset(seed=4)
    assert with_estimate.render().shape == (360, 480, 3)
    with_estimate.close()


def drive_like_dead_reckoning(env, level):
    """Step the env with the commands ref:dead-reckoning would give (it reads no sensor)."""
    ctrl = DeadReckoning()
    ctrl.setup(brief_for(level, 0))
    top = level.robots[0].model.max_wheel_speed
    env.reset(seed=level.seed)
    tick, total = 0, 0.0
    while True:
        cmd = ctrl.step(Observation(tick, tick * level.control_period, ()))
        _, reward, terminated, truncated, info = env.step(np.array([cmd.left / top, cmd.right / top]))
        total += reward
        tick += 1
        if terminated or truncated:
            return total, info


def test_env_runs_the_referees_physics_and_its_return_is_the_score():
    from referee.gym import LaserArenaEnv

    level = variant("bac-line", **exact_starts("bac-line"))  # set down exactly where the blind driver believes
    ref = play_match(level, [resolve("ref:dead-reckoning")], isolate=False)["robots"][0]
    env = LaserArenaEnv(level=level)
    total, info = drive_like_dead_reckoning(env, level)
    env.close()
    got = info["result"]["robots"][0]
    assert got["final_pose"] == pytest.approx(ref["final_pose"], abs=1e-9)
    assert got["task"]["reached"] == ref["task"]["reached"] == 10
    assert got["task"]["finished"] == pytest.approx(ref["task"]["finished"], abs=1e-9)
    # every waypoint reached: the shaping telescopes to nothing; the agent gave no estimates, so
    # it earns no localization points and no time bonus (which is scaled by localization quality)
    s = got["score"]
    assert s["task"] == ref["score"]["task"] and s["localization"] == s["time"] == 0
    assert total == pytest.approx(s["total"], abs=1e-6)


def test_bearings_in_the_observation_match_the_geometry():
    """Standing still with ideal sensors on bac-static, each beacon's encoded bearing is the
    angle from the robot's heading to the beacon, computed here from the level's coordinates."""
    from referee.gym import LaserArenaEnv

    level = variant("bac-static", **exact_starts("bac-static"))  # standing exactly at its nominal start
    env = LaserArenaEnv(level=level, ideal=True)
    env.reset(seed=1)
    for _ in range(5):
        obs, *_ = env.step(np.zeros(2))
    env.close()
    start = level.robots[0].start
    period = 2 * math.pi / level.robots[0].laser.angular_velocity
    seen = 0
    for k, b in enumerate(level.beacons.items):
        c, s, age, flag = obs[HEADER + PER_BEACON * k : HEADER + PER_BEACON * (k + 1)]
        if not flag:
            assert age == AGE_MAX
            continue
        seen += 1
        want = math.atan2(b.y - start.y, b.x - start.x) - start.heading
        assert math.remainder(math.atan2(s, c) - want, 2 * math.pi) == pytest.approx(0, abs=2e-3), b.id
        assert 0 <= age <= period + 1e-6
    assert seen >= 3
    assert obs[0] == pytest.approx(1.0 / level.time_limit, rel=1e-6)  # 5 ticks of 0.2 s


def test_goal_block_points_at_the_next_waypoint_from_the_robots_own_estimate():
    """With `goal=True` the observation gains a block: the next waypoint in the robot's frame,
    from the toolkit's tracker (never the true pose). Standing at bac-line's exact start with
    ideal sensors, the estimate settles on the truth, so the block matches the geometry computed
    here from the level; the rest of the vector is the default observation, number for number."""
    from referee.gym import LaserArenaEnv

    level = variant("bac-line", **exact_starts("bac-line"))
    plain, goal = LaserArenaEnv(level=level, ideal=True), LaserArenaEnv(level=level, ideal=True, goal=True)
    assert goal.observation_space.shape[0] == plain.observation_space.shape[0] + GOAL
    a, _ = plain.reset(seed=1)
    b, _ = goal.reset(seed=1)
    for _ in range(5):
        a, *_ = plain.step(np.zeros(2))
        b, *_ = goal.step(np.zeros(2))
    plain.close()
    goal.close()
    n = len(a)
    assert np.array_equal(a, b[:n])
    c, s, distance, passed, known = b[n:]
    start, first = level.robots[0].start, level.robots[0].path[0]
    want = math.atan2(first[1] - start.y, first[0] - start.x) - start.heading
    assert known == 1 and passed == 0
    assert math.remainder(math.atan2(s, c) - want, 2 * math.pi) == pytest.approx(0, abs=0.02)
    f = level.field
    diagonal = math.hypot(f.size[0], f.size[1])
    assert distance * diagonal == pytest.approx(math.dist((start.x, start.y), first), abs=0.005)


def test_no_reward_for_the_start():
    """asabe's path begins where the robot starts: the referee counts that waypoint reached at
    once, but the agent did nothing for it, so standing still pays nothing, and the return of a
    robot that stands still for the whole match is 0 while its task progress shows the waypoint."""
    from referee.gym import LaserArenaEnv

    env = LaserArenaEnv(level=shortened("asabe", 2), ideal=True)
    env.reset(seed=1)
    start, first = env.session.sim.report(0).start, env.session.level.robots[0].path[0]
    assert math.dist(start, first) <= env.session.level.task.radius
    rewards, done = [], False
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
        rewards.append(reward)
        done = terminated or truncated
    env.close()
    assert rewards[0] == 0 and sum(rewards) == 0
    assert info["progress"] == pytest.approx(1 / len(env.session.level.robots[0].path))
    assert info["result"]["robots"][0]["task"]["reached"] == 1


def test_pettingzoo_factories_pass_the_parallel_and_aec_api_tests():
    """`parallel_env()` and `env()` (AEC, through PettingZoo's parallel_to_aec), as PettingZoo's
    own environments expose them, pass PettingZoo's API tests; every robot is an agent."""
    from pettingzoo.test import api_test, parallel_api_test

    from referee.gym import parallel

    level = shortened("asabe-race", 4)
    env = parallel.parallel_env(level=level)
    parallel_api_test(env, num_cycles=40)
    assert env.possible_agents == ["robot_0", "robot_1", "robot_2", "robot_3"]
    obs, _ = env.reset(seed=2)
    steps = 0
    while env.agents:
        _, rewards, terminated, truncated, infos = env.step({a: np.ones(2) for a in env.agents})
        steps += 1
    assert steps == 20 and all(truncated.values())  # 4 s of 0.2 s periods, nobody finished a lap
    assert len(infos["robot_0"]["result"]["robots"]) == 4
    env.close()
    aec = parallel.env(level=level, goal=True)
    api_test(aec, num_cycles=40)
    aec.reset(seed=2)
    assert aec.observation_space("robot_0").shape == (env.observation_space("robot_0").shape[0] + GOAL,)
    turns = 0
    for _agent in aec.agent_iter(max_iter=200):  # bounded: 4 agents x 20 periods
        *_, terminated, truncated, _ = aec.last()
        aec.step(None if terminated or truncated else np.ones(2))
        turns += 1
    assert 80 <= turns < 200 and not aec.agents
    aec.close()


def test_random_policy_example_runs():
    script = Path(__file__).resolve().parent.parent / "examples" / "random_policy.py"
    proc = subprocess.run(
        [sys.executable, str(script), "--level", "bac-line", "--episodes", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "mean return" in proc.stdout


def test_env_replays_load_and_plot(tmp_path):
    """An episode's replay, even one left before its end, is a whole replay: it loads and plots."""
    from referee.gym import LaserArenaEnv
    from referee.media.plot import error_figure
    from referee.records.replay_reader import load

    path = tmp_path / "episode.replay"
    env = LaserArenaEnv(level="bac-line", replay=path, report_estimate=True)
    env.reset(seed=3)
    for _ in range(10):
        env.step(np.array([0.5, 0.5, 0.0, 0.0, 0.0]))
    env.reset(seed=4)  # leaves the first episode after 2 s
    rep = load(path)
    assert rep.duration == pytest.approx(2.0) and rep.result["seed"] == 3
    fig = error_figure(path)
    assert len(fig.robots[0].times) == 10  # one estimate per step
    env.close()
    assert load(path).result["seed"] == 4 and not list(tmp_path.glob(".laserarena-*"))
