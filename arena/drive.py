"""Differential drive the pymunk top-down way, with a seeded model of a real drive's errors.

Each robot is dragged by a kinematic control body through a pivot joint and a gear joint
whose force limits stand in for wheel-ground friction (as in pymunk's tank example). The
wheels ramp towards their speed targets at the acceleration limit; the control body then
moves at the resulting forward speed and turn rate. Because the joints are force-limited,
robots push each other and stall against walls instead of passing through.

A real drive does not do what it is told (docs/drive.md): a command reaches the wheels after
the link's latency, a servo ignores small commands and answers large ones non-linearly, each
wheel has its own gain, the true track is not the nominal one, and turns and accelerations
slip. The robot's constants are drawn once per match from its `drive` stream; without a
random tree (ideal mode) the drive is perfect.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pymunk

from arena import chipmunk
from arena.rng import RandomTree
from levels.model import DriveErrors, RobotModel

GRAVITY = 9.81  # m/s^2, for the friction force limits


def ramp(current: float, target: float, max_change: float) -> float:
    """Move `current` towards `target` by at most `max_change`."""
    return current + max(-max_change, min(max_change, target - current))


def servo_response(command: float, top: float, errors: DriveErrors) -> float:
    """The wheel speed (m/s, before the wheel's gain) a continuous-rotation servo gives for a
    commanded speed within [-top, top]: nothing inside the dead band, then a curve from 0 to
    `top` that is linear for `saturation` 0 and rises early and flattens near top speed above."""
    db, sat = errors.dead_band * top, errors.saturation
    if not db and not sat:
        return command
    a = abs(command)
    if a <= db:
        return 0.0
    u = (a - db) / (top - db)
    if sat:
        u = math.tanh(sat * u) / math.tanh(sat)
    return math.copysign(top * u, command)


def turn_share(left: float, right: float) -> float:
    """How much of a wheel command is turning: 1 for a spin or a pivot, 0 for a straight line."""
    total = abs(left) + abs(right)
    return abs(right - left) / total if total else 0.0


class DiffDrive:
    """Wheel state and the control body that carries it into the physics every `dt` s; with
    the match's random `tree`, robot `slot`'s drive errors, else a perfect drive."""

    def __init__(
        self,
        space: pymunk.Space,
        body: pymunk.Body,
        model: RobotModel,
        dt: float,
        tree: RandomTree | None = None,
        slot: int = 0,
    ):
        self.model = model
        self.body = body
        self.dt = dt
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
        self.errors = model.drive if tree is not None else DriveErrors()
        e = self.errors
        self.gains, self.track = (1.0, 1.0), model.track
        self._turns: np.random.Generator | None = None
        self._link: np.random.Generator | None = None
        if tree is not None:
            rng = tree.stream("robot", slot, "drive")
            z = rng.standard_normal(4)  # always four draws, so a zero spread never shifts the others
            radius = 1.0 + e.radius_sd * z[0]
            self.gains = (float(radius * (1.0 + e.gain_sd * z[1])), float(radius * (1.0 + e.gain_sd * z[2])))
            self.track = float(model.track * (1.0 + e.track_sd * z[3]))
            self._turns = tree.stream("robot", slot, "drive", "turn")
            self._link = tree.stream("robot", slot, "drive", "link")
        self.accel = model.max_wheel_accel * (1.0 - e.accel_slip)
        self.commanded = (0.0, 0.0)  # the last command the wheels took (m/s, nominal)
        self.target = (0.0, 0.0)  # true wheel speeds that command asks of the servos
        self.wheels = (0.0, 0.0)
        self.turn_factor = 1.0  # share of the wheels' turn rate the ground lets through
        # commands on their way, in order: [due tick, left, right, what taking it does (`_effect`)]
        self._queue: deque[list] = deque()
        self._ahead = (0.0, 0.0)  # `commanded` once every command whose effect is worked out is taken
        self._ahead_turn = 1.0  # and `turn_factor` then
        self._due = 0
        self._rate = 0.0
        self._motion = (0.0, body.angle)

    def command(self, left: float, right: float, tick: int) -> None:
        """Send wheel speed targets (m/s, clipped to the model's top speed) at physics tick
        `tick`; the wheels take them after the link's latency, in order."""
        top = self.model.max_wheel_speed
        left, right = max(-top, min(top, left)), max(-top, min(top, right))
        delay = 0
        if self._link is not None:
            seconds = self.errors.latency + self.errors.latency_jitter * self._link.random()
            delay = round(seconds / self.dt)
        self._due = max(self._due, tick + delay)
        self._queue.append([self._due, left, right, None])

    def _effect(self, entry: list) -> tuple[float, float, float] | tuple[()]:
        """What taking a queued command does to the servos: its wheel targets and the turn
        factor then, or () for a repeat of the command before it, which changes nothing. Worked
        out once per command, in command order (so a turn's slip draw comes in the same order,
        whether the command is taken a step at a time or by a compiled run)."""
        if entry[3] is None:
            left, right = entry[1], entry[2]
            if (left, right) == self._ahead:
                entry[3] = ()
            else:
                self._ahead = (left, right)
                top, e = self.model.max_wheel_speed, self.errors
                target = (self.gains[0] * servo_response(left, top, e), self.gains[1] * servo_response(right, top, e))
                if self._turns is not None and left != right:  # a turn's slip lasts through its slowing down
                    slip = min(1.0, max(0.0, e.turn_slip + e.turn_slip_sd * float(self._turns.standard_normal())))
                    self._ahead_turn = 1.0 - slip * turn_share(left, right)
                entry[3] = (*target, self._ahead_turn)
        return entry[3]

    def _take(self, entry: list) -> None:
        """The servos get a command: new wheel targets, and for a turn a new slip."""
        effect = self._effect(entry)
        self.commanded = (entry[1], entry[2])
        if effect:
            self.target, self.turn_factor = effect[:2], effect[2]

    def halt(self) -> None:
        """Stop at once: wheels and targets at rest, commands on their way dropped, the control
        body still and at the robot's pose (for a robot carried to a new pose)."""
        self._queue.clear()
        self.commanded = self.target = self.wheels = self._ahead = (0.0, 0.0)
        self.turn_factor = self._ahead_turn = 1.0
        self._rate, self._motion = 0.0, (0.0, 0.0)
        self.control.position = self.body.position
        self.control.angle = self.body.angle
        self.control.velocity = (0.0, 0.0)
        self.control.angular_velocity = 0.0

    def take_due(self, tick: int) -> None:
        """Take the commands due at `tick` (or before)."""
        queue = self._queue
        while queue and queue[0][0] <= tick:
            self._take(queue.popleft())

    def changes(self, until: int) -> list[tuple[float, ...]]:
        """What the commands due before tick `until` do to the servos, in order: (due tick,
        left target, right target, turn factor) for each that changes them (`_effect`), for a
        compiled run to apply at their ticks (arena.stepping); `take_due` then takes them."""
        out: list[tuple[float, ...]] = []
        for entry in self._queue:
            if entry[0] >= until:
                break
            effect = self._effect(entry)
            if effect:
                out.append((entry[0], *effect))
        return out

    def numbers(self) -> tuple[float, ...]:
        """The drive's state and constants, in the order of a row of `arena.stepping`'s table."""
        return (
            *self.wheels,
            *self.target,
            self.accel,
            self.dt,
            self.track,
            self.turn_factor,
            self._rate,
            *self._motion,
        )

    def set_numbers(self, row: list[float]) -> None:
        """Take back the state a compiled run left in the drive's row (`numbers`' order)."""
        self.wheels, self._rate, self._motion = (row[0], row[1]), row[8], (row[9], row[10])

    def update(self, heading: float, tick: int) -> None:
        """Take the commands due at `tick`, ramp the wheels one physics step and set the control
        body's motion for a robot now at `heading` (pymunk setters are costly: unchanged values
        are not set again)."""
        queue = self._queue
        if queue and queue[0][0] <= tick:  # checked here: this runs every step of every drive
            self.take_due(tick)
        if self.wheels != self.target:
            dv = self.accel * self.dt
            self.wheels = (ramp(self.wheels[0], self.target[0], dv), ramp(self.wheels[1], self.target[1], dv))
        rate = (self.wheels[1] - self.wheels[0]) / self.track * self.turn_factor
        if rate != self._rate:
            self._rate = rate
            chipmunk.set_angular_velocity(self.control, rate)
        v = (self.wheels[0] + self.wheels[1]) / 2
        motion = (v, heading if v else 0.0)  # standing or spinning in place: velocity stays 0
        if motion != self._motion:
            self._motion = motion
            chipmunk.set_velocity(self.control, v * math.cos(heading), v * math.sin(heading))
