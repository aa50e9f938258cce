"""From a trained policy to a submission: the .npz format, `laserarena new --from-policy`, a
team that drives exactly as the policy did in the env, and the example that trains and submits.
Needs the rl extra (installed by `make test`)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import run_cli

pytest.importorskip("gymnasium", reason="the rl extra is not installed: pip install '.[rl]'")

from referee.records.replay_reader import load
from robots.toolkit.policy import Policy


def steering_policy(size: int, base: int) -> Policy:
    """A linear policy whose actions are known: half speed ahead, turning towards the goal
    block's next waypoint (the sine of its bearing pulls the wheels apart)."""
    w = np.zeros((size, 2))
    w[base + 1] = (-1.5, 1.5)
    return Policy([w], [np.array([0.5, 0.5])], goal=True)


def test_a_policy_team_drives_in_the_sandbox_exactly_as_the_policy_in_the_env(shared_dir):
    """The env's episode and `laserarena run` of the team `new --from-policy` made from the same
    weights end at the same pose to 1e-9 m: the sandboxed controller encodes its observations
    and maps its actions with the env's own code. The policy steers by the goal block alone, so
    reaching every waypoint shows the block leads the robot along the path."""
    from referee.gym import LaserArenaEnv

    env = LaserArenaEnv(level="bac-line", ideal=True, goal=True)
    policy = steering_policy(env.observation_space.shape[0], env.session.encoders[0].base)
    obs, _ = env.reset(seed=1)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy.act(obs))
        done = terminated or truncated
    env.close()
    played = info["result"]["robots"][0]
    assert played["task"]["reached"] == played["task"]["total"] == 10

    policy.save(shared_dir / "weights.npz")
    made = run_cli("new", "steer", "--from-policy", "weights.npz", cwd=shared_dir)
    assert made.returncode == 0, made.stderr
    assert sorted(p.name for p in (shared_dir / "steer").iterdir()) == ["README.md", "__init__.py", "policy.npz"]
    for p in (shared_dir / "steer").iterdir():
        p.chmod(0o644)  # readable by the sandbox's user, whatever the umask
    ran = run_cli("run", "bac-line", "--team", "steer", "--ideal", "--seed", "1", "--json", "r.json", cwd=shared_dir)
    assert ran.returncode == 0, ran.stderr
    robot = json.loads((shared_dir / "r.json").read_text())["robots"][0]
    assert robot["faults"] == [] and robot["team"] == "steer"
    assert robot["final_pose"] == pytest.approx(played["final_pose"], abs=1e-9)
    assert robot["task"]["finished"] == pytest.approx(played["task"]["finished"], abs=1e-9)
    # the env's agent gave no estimate; the team reports its tracker's pose, which the referee scores
    assert robot["localization"]["estimates"] > 0 and robot["score"]["localization"] > 0


def test_policy_round_trips_and_new_refuses_what_is_not_one(tmp_path):
    rng = np.random.default_rng(3)
    policy = Policy([rng.normal(size=(7, 4)), rng.normal(size=(4, 2))], [rng.normal(size=4), rng.normal(size=2)])
    policy.save(tmp_path / "p.npz")
    back = Policy.load(tmp_path / "p.npz")
    x = rng.normal(size=7)
    assert np.array_equal(back.act(x), policy.act(x)) and (back.goal, back.inputs, back.outputs) == (False, 7, 2)
    assert np.array_equal(
        policy.act(x), np.tanh(np.tanh(x @ policy.weights[0] + policy.biases[0]) @ policy.weights[1] + policy.biases[1])
    )
    (tmp_path / "notes.txt").write_text("not weights\n")
    for bad, says in [("notes.txt", "not a policy .npz"), ("missing.npz", "no such file")]:
        out = run_cli("new", "team", "--from-policy", bad, cwd=tmp_path)
        assert out.returncode == 2 and says in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert not (tmp_path / "team").exists()


def test_train_and_submit_example_quick(shared_dir):
    """`examples/train_and_submit.py --quick` trains for a moment, saves the weights, makes the
    team and plays it in a tournament against the references: the team loads and plays every
    heat without a fault."""
    script = Path(__file__).resolve().parent.parent / "examples" / "train_and_submit.py"
    out = shared_dir / "trained"
    proc = subprocess.run(
        [sys.executable, str(script), "--quick", "--out", str(out)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert Policy.load(out / "learner" / "policy.npz").goal
    standings = json.loads((out / "report" / "standings.json").read_text())["standings"]
    assert sorted(s["team"] for s in standings) == ["learner", "ref:dead-reckoning", "ref:idle"]
    results = [load(r).result for r in sorted((out / "report" / "replays").glob("*.replay"))]
    mine = [r for res in results for r in res["robots"] if r["team"] == "learner"]
    assert mine and all(r["faults"] == [] for r in mine)
    assert "learner" in proc.stdout and "ref:dead-reckoning" in proc.stdout
