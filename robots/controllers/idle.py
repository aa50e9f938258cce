"""A controller that stands still and reports nothing: the baseline every other beats."""

from robots.api import Command, Controller, Observation


class Idle(Controller):
    def step(self, observation: Observation) -> Command:
        return Command(0.0, 0.0)
