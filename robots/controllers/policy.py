"""A controller that plays a trained policy: the env's observation encoder, the policy's MLP,
and the env's action-to-command mapping, so it drives as the policy did in the env.

A team built by `laserarena new NAME --from-policy weights.npz` subclasses it beside its
`policy.npz` (docs/rl.md); `weights` names the file. A policy that gives no pose estimate (two
outputs) but sees the goal block reports the encoder's own tracker pose, which the referee
scores: the commands, hence the robot's path, are the policy's alone either way.
"""

from __future__ import annotations

from pathlib import Path

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.features import ObservationEncoder
from robots.toolkit.policy import Policy, command


class PolicyController(Controller):
    """Plays the policy saved at `weights` (a class attribute a subclass sets)."""

    weights: Path | str = "policy.npz"

    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.policy = Policy.load(self.weights)
        self.encoder = ObservationEncoder(brief, self.policy.samples_per_turn, self.policy.goal)
        if self.encoder.size != self.policy.inputs:
            raise ValueError(
                f"the policy takes {self.policy.inputs} inputs; this level's observation has {self.encoder.size} "
                "(a policy plays the levels of its training's beacon count, light samples and goal option)"
            )

    def step(self, observation: Observation) -> Command:
        self.encoder.take(observation)
        cmd = command(self.policy.act(self.encoder.encode(observation.time)), self.brief)
        self.encoder.commanded(cmd.left, cmd.right)
        if cmd.estimate is None and self.encoder.tracker is not None:
            return Command(cmd.left, cmd.right, self.encoder.tracker.pose)
        return cmd
