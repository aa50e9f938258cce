"""Evaluate a random policy on a LaserArena level with the Gymnasium env (needs the rl extra).

    python examples/random_policy.py --level asabe --episodes 3
"""

from __future__ import annotations

import argparse

import gymnasium
import numpy as np


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--level", default="asabe")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args()
    env = gymnasium.make("referee.gym:LaserArena-v0", level=args.level)
    env.action_space.seed(args.seed)
    returns = []
    for episode in range(args.episodes):
        obs, info = env.reset(seed=args.seed + episode)
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            total += reward
            done = terminated or truncated
        score = info["result"]["robots"][0]["score"]["total"]
        print(f"episode {episode}: return {total:8.2f}   referee score {score:8.2f}   progress {info['progress']:.2f}")
        returns.append(total)
    env.close()
    print(f"mean return over {args.episodes} episode(s): {np.mean(returns):.2f}")


if __name__ == "__main__":
    main()
