"""`LaserArena-v0` as a vector env of its own: several matches of one level in this process,
stepped together (`gymnasium.make_vec`'s default for the id; "async" runs a process per env).

Each env is the one-robot env's session (`AgentSession`), its seeds and resets as Gymnasium's
`SyncVectorEnv` would give them (an env seeded `s + i`, an ended episode reset at its next
step from the env's own generator), without a wrapped env per world.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from levels.model import Level
from referee.gym.session import AgentSession, load, match_seed


class LaserArenaVectorEnv(VectorEnv):
    """`num_envs` matches of `level`, robot `slot` of each the agent; the other keywords are
    `LaserArena-v0`'s (docs/rl.md). Observations, rewards and flags come as arrays, one row per env."""

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 2,
        level: str | Path | Level = "asabe",
        slot: int = 0,
        others: list[str] | None = None,
        ideal: bool = False,
        report_estimate: bool = False,
        goal: bool = False,
    ):
        if num_envs < 1:
            raise ValueError(f"num_envs {num_envs}: at least 1")
        loaded = load(level)
        self.sessions = [
            AgentSession(loaded, (slot,), others, ideal, report_estimate, None, goal) for _ in range(num_envs)
        ]
        self.num_envs, self.slot = num_envs, slot
        enc = self.sessions[0].encoders[slot]
        self.single_observation_space = gymnasium.spaces.Box(enc.low, enc.high, dtype=np.float32)
        size = self.sessions[0].action_size()
        self.single_action_space = gymnasium.spaces.Box(-1.0, 1.0, (size,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._generators: list[np.random.Generator | None] = [None] * num_envs
        self._ended = np.zeros(num_envs, dtype=np.bool_)
        self._observations = np.zeros((num_envs, *self.single_observation_space.shape), dtype=np.float32)

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """New matches: `seed` an int (env i plays `seed + i`), a list (one each) or None (drawn)."""
        seeds: list[int | None]
        if isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            seeds = [None] * self.num_envs if seed is None else list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"{len(seeds)} seeds for {self.num_envs} envs")
        infos: dict[str, Any] = {}
        for i, s in enumerate(seeds):
            if s is not None or self._generators[i] is None:
                self._generators[i], _ = seeding.np_random(s)
            infos = self._add_info(infos, self._reset_one(i, s), i)
        self._ended[:] = False
        return self._observations.copy(), infos

    def _reset_one(self, i: int, seed: int | None) -> dict[str, int]:
        """Start env `i`'s next match: `seed`, or the next from its generator."""
        generator = self._generators[i]
        assert generator is not None
        played = match_seed(seed, generator)
        self._observations[i] = self.sessions[i].reset(played)[self.slot]
        return {"seed": played}

    def step(self, actions):
        """One control period of every env; an env whose episode ended at the last step is reset instead."""
        actions = np.asarray(actions)
        rewards = np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, dtype=np.bool_)
        truncated = np.zeros(self.num_envs, dtype=np.bool_)
        infos: dict[str, Any] = {}
        for i, session in enumerate(self.sessions):
            if self._ended[i]:
                info: dict[str, Any] = self._reset_one(i, None)
            else:
                out = session.step({self.slot: actions[i]})
                s = self.slot
                self._observations[i] = out.observations[s]
                rewards[i], terminated[i], truncated[i], info = (
                    out.rewards[s],
                    out.terminated[s],
                    out.truncated[s],
                    out.infos[s],
                )
            infos = self._add_info(infos, info, i)
        self._ended = terminated | truncated
        return self._observations.copy(), rewards, terminated, truncated, infos

    def close_extras(self, **kwargs: Any) -> None:
        for session in self.sessions:
            session.close()
