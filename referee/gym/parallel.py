"""A PettingZoo ParallelEnv: every robot of a level is an agent (`robot_0`, `robot_1`, ...).

    from referee.gym import parallel
    env = parallel.parallel_env(level="asabe-race")   # or parallel.env(...): the AEC form

Each agent observes and acts as in the Gymnasium env (docs/rl.md); an agent that finishes
its task (or is stopped) leaves `agents` and its robot stands still while the others play on.
Needs the `rl` extra.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from levels.model import Level
from referee.gym.session import AgentSession, load, match_seed


class LaserArenaParallelEnv(ParallelEnv):
    """All robot slots of `level` are agents, stepped together once per control period."""

    metadata = {"name": "laserarena_v0", "render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(
        self,
        level: str | Path | Level = "asabe-race",
        ideal: bool = False,
        report_estimate: bool = False,
        replay: str | Path | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (480, 360),
        goal: bool = False,
    ):
        level = load(level)
        n = len(level.robots)
        self.session = AgentSession(level, tuple(range(n)), [], ideal, report_estimate, replay, goal)
        self.possible_agents = [f"robot_{s}" for s in range(n)]
        self.slots = {agent: s for s, agent in enumerate(self.possible_agents)}  # agent name -> robot slot
        self.agents: list[str] = []
        self.render_mode, self.render_size = render_mode, render_size
        self._rng = np.random.default_rng()
        self._observation_spaces: dict[str, gymnasium.spaces.Box] = {}
        self._action_spaces: dict[str, gymnasium.spaces.Box] = {}

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        """`agent`'s observation space: the same object on every call, as PettingZoo expects."""
        if agent not in self._observation_spaces:
            enc = self.session.encoders[self.slots[agent]]
            self._observation_spaces[agent] = gymnasium.spaces.Box(enc.low, enc.high, dtype=np.float32)
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        """`agent`'s action space (wheel commands in [-1, 1]): the same object on every call."""
        if agent not in self._action_spaces:
            size = (self.session.action_size(),)
            self._action_spaces[agent] = gymnasium.spaces.Box(-1.0, 1.0, size, dtype=np.float32)
        return self._action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        """A new match: with `seed`, that match seed; without, the next from the env's generator."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        played = match_seed(seed, self._rng)
        obs = self.session.reset(played)
        self.agents = list(self.possible_agents)
        return ({a: obs[self.slots[a]] for a in self.agents}, {a: {"seed": played} for a in self.agents})

    def step(self, actions: dict):
        slots = self.slots
        out = self.session.step({slots[a]: actions[a] for a in self.agents if a in actions})
        live = [(a, slots[a]) for a in self.agents]
        result = tuple({a: d[s] for a, s in live} for d in out)  # observations, rewards, terminated, truncated, infos
        self.agents = [a for a, s in live if not (out.terminated[s] or out.truncated[s])]
        return result

    def render(self):
        if self.render_mode == "rgb_array":
            from referee.gym.view import frame

            return frame(self.session, self.render_size)
        return None

    def close(self) -> None:
        self.session.close()


def parallel_env(**kwargs) -> LaserArenaParallelEnv:
    """The parallel env (keywords as LaserArenaParallelEnv's), as PettingZoo's own environments
    name their factory."""
    return LaserArenaParallelEnv(**kwargs)


def env(**kwargs) -> AECEnv:
    """The same env in PettingZoo's AEC form (agents act in turn; a cycle of all agents is one
    control period), through PettingZoo's own `parallel_to_aec` conversion."""
    return parallel_to_aec(parallel_env(**kwargs))
