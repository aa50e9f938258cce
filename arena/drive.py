"""Differential drive the pymunk top-down way.

Each robot is dragged by a kinematic control body through a pivot joint and a gear joint
whose force limits stand in for wheel-ground friction (as in pymunk's tank example). The
wheels ramp towards their commanded speeds at the model's acceleration limit; the control
body then moves at the resulting forward speed and turn rate. Because the joints are
force-limited, robots push each other and stall against walls instead of passing through.
"""

from __future__ import annotations

import math

import pymunk

from arena.level import RobotModel

GRAVITY = 9.81  # m/s^2, for the friction force limits


def ramp(current: float, target: float, max_change: float) -> float:
    """Move `current` towards `target` by at most `max_change`."""
    return current + max(-max_change, min(max_change, target - current))


class DiffDrive:
    """Wheel state and the control body that carries it into the physics."""

    def __init__(self, space: pymunk.Space, body: pymunk.Body, model: RobotModel):
        self.model = model
        self.body = body
        self.control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.control.position = body.position
        self.control.angle = body.angle
        friction_force = model.friction * model.mass * GRAVITY
        pivot = pymunk.PivotJoint(self.control, body, (0, 0), (0, 0))
        pivot.max_bias = 0  # match velocities only; positions come from integration
        pivot.max_force = friction_force
        gear = pymunk.GearJoint(self.control, body, 0.0, 1.0)
        gear.max_bias = 0
        gear.max_force = friction_force * model.track / 2
        space.add(self.control, pivot, gear)
        self.target = (0.0, 0.0)
        self.wheels = (0.0, 0.0)
        self._motion = (0.0, body.angle)

    def command(self, left: float, right: float) -> None:
        """Set the wheel speed targets (m/s), clipped to the model's top speed."""
        top = self.model.max_wheel_speed
        self.target = (max(-top, min(top, left)), max(-top, min(top, right)))

    def update(self, dt: float, heading: float) -> None:
        """Ramp the wheels one physics step and set the control body's motion for a robot
        now at `heading` (pymunk setters are costly: unchanged values are not set again)."""
        if self.wheels != self.target:
            dv = self.model.max_wheel_accel * dt
            self.wheels = (ramp(self.wheels[0], self.target[0], dv), ramp(self.wheels[1], self.target[1], dv))
            self.control.angular_velocity = (self.wheels[1] - self.wheels[0]) / self.model.track
        v = (self.wheels[0] + self.wheels[1]) / 2
        motion = (v, heading if v else 0.0)  # standing or spinning in place: velocity stays 0
        if motion != self._motion:
            self._motion = motion
            self.control.velocity = (v * math.cos(heading), v * math.sin(heading))
