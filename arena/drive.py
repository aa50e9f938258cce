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
from arena.compiled import compiled
from arena.rng import RandomTree
from levels.model import DriveErrors, RobotModel

GRAVITY = 9.81  # m/s^2, for the friction force limits

# a drive's state and constants, in its row (`DiffDrive.row`, a row of `arena.stepping`'s table)
WHEEL_L, WHEEL_R, TARGET_L, TARGET_R, ACCEL, DT, TRACK, TURN, RATE, MOTION_V, MOTION_H = range(11)
ROW = 11
RATE_CHANGED, MOTION_CHANGED = 1, 2  # what `advance` tells the control body to take


@compiled(inline="always")
def ramp(current: float, target: float, max_change: float) -> float:
    """Move `current` towards `target` by at most `max_change` (Python's `min` and `max`: the
    first argument unless the second is smaller, or larger)."""
    change = target - current
    low = change if change < max_change else max_change
    if low > -max_change:
        return current + low
    return current + -max_change


@compiled(inline="always")
def advance(d: np.ndarray, heading: float) -> int:
    """The drive's equations, for one physics step of a robot at `heading`, on its row `d`:
    the wheels ramp towards their targets at the acceleration limit; the control body turns at
    (right - left) / track times the turn factor and moves at the wheels' mean speed along the
    heading (standing or spinning in place: no velocity). Returns which of the control body's
    rate and motion changed (RATE_CHANGED | MOTION_CHANGED): only those are set again.
    Compiled, and called both by a compiled run (arena.stepping) and a step in Python."""
    if d[WHEEL_L] != d[TARGET_L] or d[WHEEL_R] != d[TARGET_R]:
        dv = d[ACCEL] * d[DT]
        d[WHEEL_L] = ramp(d[WHEEL_L], d[TARGET_L], dv)
        d[WHEEL_R] = ramp(d[WHEEL_R], d[TARGET_R], dv)
    changed = 0
    rate = (d[WHEEL_R] - d[WHEEL_L]) / d[TRACK] * d[TURN]
    if rate != d[RATE]:
        d[RATE] = rate
        changed |= RATE_CHANGED
    v = (d[WHEEL_L] + d[WHEEL_R]) / 2
    h = heading if v != 0.0 else 0.0
    if v != d[MOTION_V] or h != d[MOTION_H]:
        d[MOTION_V] = v
        d[MOTION_H] = h
        changed |= MOTION_CHANGED
    return changed


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
    the match's random `tree`, robot `slot`'s drive errors, else a perfect drive. Its state
    lives in `row` (a row of the world's drive table, given or its own)."""

    def __init__(
        self,
        space: pymunk.Space,
        body: pymunk.Body,
        model: RobotModel,
        dt: float,
        tree: RandomTree | None = None,
        slot: int = 0,
        row: np.ndarray | None = None,
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
        self.row = np.zeros(ROW) if row is None else row
        self.row[:] = 0.0
        self.row[ACCEL] = model.max_wheel_accel * (1.0 - e.accel_slip)
        self.row[DT], self.row[TRACK] = dt, self.track
        self.row[TURN] = 1.0  # share of the wheels' turn rate the ground lets through
        self.row[MOTION_H] = body.angle  # (the motion last set: none, along the start's heading)
        self.commanded = (0.0, 0.0)  # the last command the wheels took (m/s, nominal)
        # commands on their way, in order: [due tick, left, right, what taking it does (`_effect`)]
        self._queue: deque[list] = deque()
        self._ahead = (0.0, 0.0)  # `commanded` once every command whose effect is worked out is taken
        self._ahead_turn = 1.0  # and `turn_factor` then
        self._due = 0

    @property
    def wheels(self) -> tuple[float, float]:
        """The true wheel speeds now (m/s)."""
        return float(self.row[WHEEL_L]), float(self.row[WHEEL_R])

    @property
    def target(self) -> tuple[float, float]:
        """The true wheel speeds the last command taken asks of the servos (m/s)."""
        return float(self.row[TARGET_L]), float(self.row[TARGET_R])

    @property
    def turn_factor(self) -> float:
        """The share of the wheels' turn rate the ground lets through (1: no slip)."""
        return float(self.row[TURN])

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
            self.row[TARGET_L], self.row[TARGET_R], self.row[TURN] = effect

    def halt(self) -> None:
        """Stop at once: wheels and targets at rest, commands on their way dropped, the control
        body still and at the robot's pose (for a robot carried to a new pose)."""
        self._queue.clear()
        self.commanded = self._ahead = (0.0, 0.0)
        self._ahead_turn = 1.0
        row = self.row
        row[WHEEL_L] = row[WHEEL_R] = row[TARGET_L] = row[TARGET_R] = 0.0
        row[TURN] = 1.0
        row[RATE] = row[MOTION_V] = row[MOTION_H] = 0.0
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

    def update(self, heading: float, tick: int) -> None:
        """Take the commands due at `tick`, then one physics step of the drive's equations
        (`advance`) for a robot now at `heading`; the control body is set only where its rate
        or motion changed (pymunk setters are costly)."""
        queue = self._queue
        if queue and queue[0][0] <= tick:  # checked here: this runs every step of every drive
            self.take_due(tick)
        row = self.row
        changed = advance(row, heading)
        if changed & RATE_CHANGED:
            chipmunk.set_angular_velocity(self.control, float(row[RATE]))
        if changed & MOTION_CHANGED:
            v = float(row[MOTION_V])
            chipmunk.set_velocity(self.control, v * math.cos(heading), v * math.sin(heading))
