"""A controller that finds where it is with the toolkit's tracker and follows the task's
waypoints. docs/controllers.md builds it step by step, as mybot.py; `laserarena new NAME`
writes it as NAME/controller.py, and `--team ref:tutorial` runs it.
"""

import math

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.angles import wrap
from robots.toolkit.steering import HeadingProbe, next_waypoint
from robots.toolkit.tracker import HitTracker

CREEP = 0.03  # m/s: slow, but well above the servos' dead band
SPIN = 0.5  # rad: a heading error above this turns the robot on the spot
STEER = 1.5  # rad/s of turn per rad of heading error, while driving
BRAKE = 1.5  # 1/s: into a corner, the speed (m/s) is at most this times the distance (m) left


class MyBot(Controller):
    def setup(self, brief: Brief) -> None:
        self.brief = brief
        self.tracker = HitTracker(brief)  # the pose from the laser's events and the wheel commands
        self.probe = HeadingProbe()  # drives straight until the heading is known
        self.path = list(brief.task.path) or ([brief.task.goal] if brief.task.goal else [])
        self.target = 0  # the index of the waypoint to drive to
        self.trial = 0

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # a localize level carried the robot elsewhere
            self.trial = observation.trial
            self.tracker.reset()
            self.probe.reset()
        self.tracker.feed(observation.events, observation.time)
        pose = self.tracker.pose  # (x, y, heading), or None before the first fix
        if pose is None:
            left = right = 0.0
        elif self.probe.driving(pose[0], pose[1], self.tracker.heading_sd):
            left = right = CREEP
        else:
            left, right = self.steer(*pose)
        self.tracker.command(left, right)  # what the drive was told: the tracker's odometry
        return Command(left, right, estimate=pose)

    def steer(self, x: float, y: float, heading: float) -> tuple[float, float]:
        """Wheel speeds (m/s) towards the next waypoint from the pose (x, y, heading)."""
        self.target = next_waypoint(self.path, self.target, x, y, self.brief.task.radius / 2)
        if self.target == len(self.path):
            return 0.0, 0.0  # all reached: stand still
        tx, ty = self.path[self.target]
        error = wrap(math.atan2(ty - y, tx - x) - heading)  # how far to turn, + = left
        top, half = self.brief.robot.max_wheel_speed, self.brief.robot.track / 2
        if abs(error) > SPIN:  # turn on the spot, slower as the error shrinks
            turn = min(0.5 * top / half, 0.5 * abs(error) / self.brief.control_period)
            turn = math.copysign(turn, error)
            return -turn * half, turn * half
        speed = 0.7 * top
        after = self.path[self.target + 1 : self.target + 2]  # the waypoint after this one, if any
        if not after or abs(wrap(math.atan2(after[0][1] - ty, after[0][0] - tx) - heading)) > SPIN:
            speed = min(speed, max(CREEP, BRAKE * math.dist((x, y), (tx, ty))))  # slow into a corner
        turn = STEER * error
        return speed - turn * half, speed + turn * half
