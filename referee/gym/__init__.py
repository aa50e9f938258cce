"""Gymnasium and PettingZoo environments over the simulation core.

    import gymnasium
    env = gymnasium.make("referee.gym:LaserArena-v0", level="asabe")

- this module: `LaserArenaEnv`, one robot driven by an agent (registered as `LaserArena-v0`);
  `vector`: several of its matches in this process (`gymnasium.make_vec`'s default for the id);
  `parallel`: every robot an agent (PettingZoo);
- `session`: the simulation, its agents and other slots' controllers; `view`: `render()`.

Imports: match, sandbox, records, `arena`, `levels`, `robots` (the API, the toolkit's features
and policy); `gymnasium` and `pettingzoo` only here (the `rl` extra). docs/rl.md.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np

from levels.model import Level
from referee.gym.session import AgentSession, match_seed

ENV_ID = "LaserArena-v0"


class LaserArenaEnv(gymnasium.Env):
    """Robot `slot` of `level` is the agent; other slots run `others` (default: the level's
    default controller) in this process. One step is one control period. `goal` adds the next
    waypoint, in the robot's frame by its own pose estimate, to the observation (docs/rl.md)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}

    def __init__(
        self,
        level: str | Path | Level = "asabe",
        slot: int = 0,
        others: list[str] | None = None,
        ideal: bool = False,
        report_estimate: bool = False,
        replay: str | Path | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (480, 360),
        goal: bool = False,
    ):
        self.session = AgentSession(level, (slot,), others, ideal, report_estimate, replay, goal)
        self.slot = slot
        enc = self.session.encoders[slot]
        self.observation_space = gymnasium.spaces.Box(enc.low, enc.high, dtype=np.float32)
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (self.session.action_size(),), dtype=np.float32)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r}: only 'rgb_array'")
        self.render_mode, self.render_size = render_mode, render_size

    @property
    def brief(self):
        """What the robot's team may know (map, path, hardware): robots.api.Brief."""
        return self.session.encoders[self.slot].brief

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new match: with `seed`, that match seed; without, the next from the env's generator."""
        super().reset(seed=seed)
        played = match_seed(seed, self.np_random)
        obs = self.session.reset(played)
        return obs[self.slot], {"seed": played}

    def step(self, action):
        out = self.session.step({self.slot: action})
        s = self.slot
        return out.observations[s], out.rewards[s], out.terminated[s], out.truncated[s], out.infos[s]

    def render(self):
        if self.render_mode == "rgb_array":
            from referee.gym.view import frame

            return frame(self.session, self.render_size)
        return None

    def close(self) -> None:
        self.session.close()


gymnasium.register(
    id=ENV_ID, entry_point="referee.gym:LaserArenaEnv", vector_entry_point="referee.gym.vector:LaserArenaVectorEnv"
)
