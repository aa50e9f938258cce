"""Train a policy on a LaserArena level with plain numpy, submit it, and play it in a tournament.

    python examples/train_and_submit.py                  # asabe, a few minutes on one core
    python examples/train_and_submit.py --quick          # bac-line, seconds: a smoke test

The policy is linear (robots.toolkit.policy: a tanh of weights x observation + bias) on the
Gymnasium env's goal-conditioned observation (`goal=True`: the next waypoint in the robot's own
frame, from its own pose estimate). Only the goal block's weights and the biases are searched,
by the cross-entropy method: each generation draws a population of parameter vectors around
the mean, plays one episode with each (every one on the generation's same match seed), and
moves the mean and spread to the best few, starting from "drive ahead". Then it saves `policy.npz`, makes a team of it with
`laserarena new NAME --from-policy`, and plays that team against ref:idle and
ref:dead-reckoning with `laserarena tournament` (docs/rl.md). Needs the rl extra.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from referee.gym import LaserArenaEnv
from robots.toolkit.features import GOAL
from robots.toolkit.policy import Policy


def policy_of(theta: np.ndarray, size: int, base: int) -> Policy:
    """The linear policy a parameter vector stands for: goal-block weights (GOAL x 2), then biases (2)."""
    w = np.zeros((size, 2))
    w[base : base + GOAL] = theta[: 2 * GOAL].reshape(GOAL, 2)
    return Policy([w], [theta[2 * GOAL :]], goal=True)


def episode(env: LaserArenaEnv, policy: Policy, seed: int) -> tuple[float, dict]:
    """One episode's return and its last info."""
    obs, info = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        total += reward
        done = terminated or truncated
    return total, info


def train(level: str, generations: int, population: int, elite: int, seed: int) -> Policy:
    """The cross-entropy method over the linear policy's goal weights and biases."""
    env = LaserArenaEnv(level=level, goal=True)
    size, base = env.observation_space.shape[0], env.unwrapped.session.encoders[0].base
    rng = np.random.default_rng(seed)
    # start from "ahead at a third of top speed": driving straight is how the tracker learns an
    # unknown heading, and a robot that stands still teaches the search nothing
    mean, sd = np.r_[np.zeros(2 * GOAL), 0.3, 0.3], np.full(2 * GOAL + 2, 0.5)
    for g in range(generations):
        started = time.perf_counter()
        match_seed = int(rng.integers(0, 2**31 - 1))
        thetas = mean + sd * rng.standard_normal((population, len(mean)))
        returns = np.array([episode(env, policy_of(t, size, base), match_seed)[0] for t in thetas])
        best = thetas[np.argsort(returns)[-elite:]]
        mean, sd = best.mean(axis=0), best.std(axis=0) + 0.05  # a floor keeps it searching
        took = time.perf_counter() - started
        print(
            f"generation {g + 1}/{generations}: best {returns.max():7.2f}  mean {returns.mean():7.2f}  ({took:.1f} s)"
        )
    env.close()
    return policy_of(mean, size, base)


def laserarena(*args: str, cwd: Path) -> str:
    """Run the laserarena command line (this interpreter's), as a user would; its output."""
    done = subprocess.run([sys.executable, "-m", "referee", *args], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"laserarena {' '.join(args)} failed:\n{done.stderr}")
    return done.stdout


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--level", help="the level to train and play on (default asabe; bac-line with --quick)")
    p.add_argument("--generations", type=int, help="default 10 (1 with --quick)")
    p.add_argument("--population", type=int, help="episodes per generation (default 12; 4 with --quick)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default="trained", help="the folder for policy.npz, the team and the tournament")
    p.add_argument("--team", default="learner", help="the team's name (a Python package name)")
    p.add_argument("--quick", action="store_true", help="a tiny run of a few seconds, to see every stage work")
    args = p.parse_args()
    level = args.level or ("bac-line" if args.quick else "asabe")
    generations = args.generations or (1 if args.quick else 10)
    population = args.population or (4 if args.quick else 12)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)

    started = time.perf_counter()
    policy = train(level, generations, population, max(2, population // 4), args.seed)
    print(f"trained in {time.perf_counter() - started:.0f} s")
    weights = out / "policy.npz"
    policy.save(weights)
    env = LaserArenaEnv(level=level, goal=True)
    for s in range(1, 4):
        ret, info = episode(env, policy, 1000 + s)
        print(f"seed {1000 + s}: return {ret:7.2f}  progress {info['progress']:.2f}")
    env.close()

    print(laserarena("new", args.team, "--from-policy", str(weights), "--dir", str(out), cwd=out), end="")
    standings = laserarena(
        "tournament",
        level,
        "--team",
        args.team,
        "--team",
        "ref:idle",
        "--team",
        "ref:dead-reckoning",
        "--rounds",
        "1" if args.quick else "3",
        "--db",
        "tournament.sqlite",
        "--out",
        "report",
        cwd=out,
    )
    print(standings, end="")


if __name__ == "__main__":
    main()
