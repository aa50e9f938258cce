"""Starts the robot must find, and localize trials: where each robot really stands is drawn per
match from the match's random tree within the level's stated spread (docs/levels.md), the brief
announces only what the rules do, and a trial carries the robot to a new secret pose at rest."""

import math
import statistics

import numpy as np
import pytest
from helpers import MINI_LEVEL, edited, run_cli, simi_on_tiles, variant

import levels
from arena.placement import draw, starts, trial_poses
from arena.rng import RandomTree
from levels.checks import footprint
from levels.loader import load_level, parse_level
from levels.model import Placement, Pose
from referee.match.simulation import Simulation
from referee.match.views import announced_start, brief_for
from referee.records.replay_reader import load
from referee.sandbox.in_process import InProcessBot
from referee.sandbox.teams import Team
from robots.api import Command, StartInfo

KEY = "ab" * 32  # a grader's secret noise key


def test_a_hand_placement_is_uniform_over_its_disc_and_its_angle():
    rng = np.random.default_rng(3)
    nominal, spread = Pose(1.0, 2.0, 0.5), Placement(position=0.02, heading=math.radians(10))
    poses = [draw(nominal, spread, rng) for _ in range(4000)]
    r2 = [(p.x - 1.0) ** 2 + (p.y - 2.0) ** 2 for p in poses]
    turn = [math.remainder(p.heading - 0.5, 2 * math.pi) for p in poses]
    assert max(r2) <= 0.02**2 and max(map(abs, turn)) <= math.radians(10) + 1e-12
    # uniform over a disc of radius R: E[r^2] = R^2 / 2; over +-A: mean 0, variance A^2 / 3
    assert statistics.fmean(r2) == pytest.approx(0.02**2 / 2, rel=0.05)
    assert abs(statistics.fmean(turn)) < 0.01 and statistics.pvariance(turn) == pytest.approx(
        math.radians(10) ** 2 / 3, rel=0.06
    )


def test_a_region_placement_covers_its_rectangle_facing_anywhere():
    rng = np.random.default_rng(4)
    poses = [draw(Pose(0, 0, 0), Placement(heading=math.pi, region=(1.0, 2.0, 3.0, 2.5)), rng) for _ in range(4000)]
    assert all(1.0 <= p.x <= 3.0 and 2.0 <= p.y <= 2.5 for p in poses)
    assert statistics.fmean(p.x for p in poses) == pytest.approx(2.0, abs=0.03)
    quarters = np.histogram([p.heading for p in poses], bins=4, range=(-math.pi, math.pi))[0]
    assert quarters.min() > 0.9 * 1000 and quarters.max() < 1.1 * 1000


def test_starts_are_secret_reproducible_and_the_same_when_ideal():
    level = load_level(levels.path("vannoy"))
    one, again = starts(level, RandomTree(7)), starts(level, RandomTree(7))
    assert one == again
    assert starts(level, RandomTree(8)) != one and starts(level, RandomTree(7, KEY)) != one
    x0, y0, x1, y1 = level.robots[0].placement.region
    assert x0 <= one[0].x <= x1 and y0 <= one[0].y <= y1
    # --ideal takes the hardware's errors away, not the task's uncertainty
    ideal, noisy = (
        Simulation(level, ["i"], seed=7, ideal=True),
        Simulation(level, ["i"], seed=7),
    )
    assert ideal.starts == noisy.starts == one
    assert (ideal.world.pose(0).x, ideal.world.pose(0).y) == pytest.approx((one[0].x, one[0].y))


def test_the_brief_announces_the_nominal_start_and_its_spread_never_the_truth():
    level = load_level(levels.path("asabe"))
    m = Simulation(level, ["i"], seed=2)
    brief = brief_for(level, 0)
    truth = m.starts[0]
    assert brief.start == StartInfo(0.56, 0.35, math.radians(80.5), 0.01, math.pi, None)
    assert not brief.start.heading_known
    assert truth != level.robots[0].start and math.dist((truth.x, truth.y), (0.56, 0.35)) <= 0.01
    assert f"{truth.x!r}" not in repr(brief) and f"{truth.heading!r}" not in repr(brief)
    # a level that announces nothing, or a region
    assert announced_start(load_level(levels.path("osentoski")), 0) is None
    assert brief_for(load_level(levels.path("vannoy")), 0).start.region == pytest.approx(
        (0.3048, 0.3048, 12 * 0.3048, 20 * 0.3048)
    )


def test_draws_keep_clear_of_obstacles_and_each_other():
    # four robots set down anywhere on a small table with a box in the middle
    text = edited(
        "asabe-race",
        {f"robots.{i}.placement": {"region": [[0.1, 0.1], [1.73, 1.12]], "heading": 180} for i in range(4)}
        | {"obstacles": [{"kind": "box", "center": [0.92, 0.61], "size": [0.3, 0.2]}]},
    )
    level = parse_level(text.encode(), "crowded.yaml")
    box = level.obstacles[0].points
    for seed in range(40):
        bodies = [footprint(level.robots[k].model, p) for k, p in enumerate(starts(level, RandomTree(seed)))]
        for i, body in enumerate(bodies):
            assert all(level.field.contains(x, y) for x, y in body)
            assert not any(min(b[0] for b in box) < x < max(b[0] for b in box) and min(b[1] for b in box) < y < max(b[1] for b in box) for x, y in body)  # fmt: skip
            for other in bodies[:i]:  # robots 0.105 m long: centres closer than the footprints' width would overlap
                assert math.dist(np.mean(body, axis=0), np.mean(other, axis=0)) > 0.09


def test_trial_poses_come_from_the_listed_positions_and_headings():
    level = simi_on_tiles()
    spread = level.robots[0].placement
    listed = level.task.trials.positions
    poses = trial_poses(level, RandomTree(5), starts(level, RandomTree(5)))
    assert len(poses) == level.task.trials.count == 10 and poses[0] == starts(level, RandomTree(5))
    used = []
    for (p,) in poses[1:]:
        near = min(listed, key=lambda q: math.dist(q, (p.x, p.y)))
        assert math.dist(near, (p.x, p.y)) <= spread.position + 1e-12
        turn = min(abs(math.remainder(p.heading - h, 2 * math.pi)) for h in level.task.trials.headings)
        assert turn <= spread.heading + 1e-12
        used.append(near)
    assert len(set(used)) == len(used)  # nine different tile positions: shuffled, not repeated


class Idle:
    def setup(self, brief):
        pass

    def step(self, obs):
        return Command(0.0, 0.0)


class Trials:
    """Drives forward all the time and records every observation: the referee stops it at each move."""

    seen: list = []

    def setup(self, brief):
        Trials.seen = [brief]

    def step(self, obs):
        Trials.seen.append(obs)
        return Command(0.1, 0.1)


def test_a_trial_carries_the_robot_to_its_pose_at_rest_and_the_controller_learns_only_that():
    level = variant(
        MINI_LEVEL,
        task={"kind": "localize", "trials": {"count": 4, "positions": [[1.5, 0.5], [0.4, 0.3]], "headings": [90]}},
        time_limit=2,
    )
    m = Simulation(level, ["t"], seed=6)
    bot = InProcessBot(Team("t", "t", "h", factory=Trials))
    period = level.control_period
    moves = {1: 10, 2: 20, 3: 30}  # 40 control ticks cut in four: moved at the start of these periods
    after_move = {}
    step = m.start([bot.setup(brief_for(level, 0))])
    while not step.ended:
        tick = m.world.tick // level.steps_per_control
        step = m.step([bot.step(step.observations[0])])
        if tick in moves.values():
            after_move[tick] = (m.world.pose(0), m.world.bodies[0].velocity.length)
    result = m.end()
    brief, *obs = Trials.seen
    assert brief.task.trials == 4
    assert [o.trial for o in obs] == [max(0, (k - 1) * 4 // 40) for k in range(40)]
    for trial, tick in moves.items():
        first = obs[tick + 1]  # the observation that ends the period of the move
        assert first.trial == trial and obs[tick].trial == trial - 1
        # every event it holds was sensed after the move, at the new pose
        assert all(e.time > tick * period for e in first.events)
        # carried to its drawn pose and set down at rest: the command it was driving by is dropped
        drawn = m.trial_poses[trial][0]
        assert math.remainder(drawn.heading - math.pi / 2, 2 * math.pi) == pytest.approx(0, abs=1e-12)
        pose, speed = after_move[tick]
        assert math.dist((pose.x, pose.y), (drawn.x, drawn.y)) < 1e-9 and speed < 1e-9
    assert not result.robots[0].fouls


def test_verify_reproduces_a_match_with_trials(tmp_path):
    level_file = tmp_path / "simi-short.yaml"
    level_file.write_text(edited("simi", {"time_limit": 3}))
    proc = run_cli("run", str(level_file), "--seed", "4", "--replay", str(tmp_path / "y.replay"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    rep = load(tmp_path / "y.replay")
    assert [(r["n"], r["t"]) for r in rep.trials] == [(k, pytest.approx(0.3 * k)) for k in range(1, 10)]
    proc = run_cli("verify", str(tmp_path / "y.replay"))
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_a_robot_drawn_first_keeps_clear_of_a_later_one_set_down_exactly():
    # robot 0 anywhere in a patch around robot 3's start; robot 3 set down exactly there, after it
    text = edited(
        "asabe-race",
        {"robots.0.placement": {"region": [[1.03, 0.57], [1.43, 0.97]], "heading": 180}, "robots.3.placement": None},
    )
    level = parse_level(text.encode(), "exact-later.yaml")
    for seed in range(40):
        first = starts(level, RandomTree(seed))
        assert first[3] == level.robots[3].start
        body0, body3 = (footprint(level.robots[k].model, first[k]) for k in (0, 3))
        assert math.dist(np.mean(body0, axis=0), np.mean(body3, axis=0)) > 0.09


def test_a_region_trials_heading_says_nothing_of_where_it_stands():
    # trials anywhere in a region, facing one of two headings: the heading is drawn apart from y
    text = edited("osentoski", {"task.trials.headings": [0, 180], "robots.0.placement": None})
    level = parse_level(text.encode(), "headed.yaml")
    (y0, y1) = level.task.trials.region[1], level.task.trials.region[3]
    pairs = set()
    for seed in range(30):
        for (p,) in trial_poses(level, RandomTree(seed), starts(level, RandomTree(seed)))[1:]:
            pairs.add((p.y > (y0 + y1) / 2, round(math.cos(p.heading))))
    assert pairs == {(False, 1), (False, -1), (True, 1), (True, -1)}


def test_simis_trials_come_from_a_region_and_a_heading_spread_never_a_list():
    """The thesis's robot did not know which tile it stood on: the level gives a region and a
    spread of turns, and each trial is drawn uniformly from them (a pool to look poses up in
    would pay a lookup, not a solver)."""
    level = load_level(levels.path("simi"))
    trials, placement = level.task.trials, level.robots[0].placement
    assert trials.positions == () and trials.headings == () and trials.region is not None
    x0, y0, x1, y1 = trials.region
    start = level.robots[0].start
    seen_x, seen_h = [], []
    for seed in range(40):
        tree = RandomTree(seed)
        for (p,) in trial_poses(level, tree, starts(level, tree))[1:]:
            assert x0 - placement.position <= p.x <= x1 + placement.position
            assert y0 - placement.position <= p.y <= y1 + placement.position
            turn = abs(math.remainder(p.heading - start.heading, math.tau))
            assert turn <= trials.heading_spread + placement.heading + 1e-12
            seen_x.append((p.x - x0) / (x1 - x0))
            seen_h.append(math.remainder(p.heading - start.heading, math.tau) / trials.heading_spread)
    # uniform: each fifth of the range holds about a fifth of the 360 draws (binomial sd 7.6)
    for values in (seen_x, seen_h):
        counts = np.histogram(np.clip(values, -1, 1) if values is seen_h else np.clip(values, 0, 1), bins=5)[0]
        assert all(abs(c - 72) < 4 * 7.6 for c in counts), counts
