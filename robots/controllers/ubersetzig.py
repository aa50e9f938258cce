"""Ubersetzig 1999: three retroreflective targets on one wall, angles read in the head's 200 raw steps,
solved by his circle-centre method; stop-and-scan to the goal. A scan that does not show
exactly three targets within half a turn is rejected ("lost: can't find 3 targets",
"targets on more than one wall").

One raw step is 1.8 deg (the seed's code turns it into 1.406 deg BAMs, "* 64 / 50"; we keep
the raw reading), and from the far end of the room that moves a fix by tens of centimetres
along the wall. So each step read is taken as its middle, and at every stop the
robot looks again after turning on the spot by two thirds of a step, three times: the same
targets then fall at other places within the steps, and the filter, which takes a repeated
reading of a head at rest only once, averages what the steps hide."""

from __future__ import annotations

import math

from robots.controllers.stop_and_scan import StopAndScan
from robots.toolkit.angles import Revolution, wrap
from robots.toolkit.motion import Pose
from robots.toolkit.solvers import wall


class Ubersetzig(StopAndScan):
    ANGLE_STEP = 2 * math.pi / 200  # the raw step: the seed converts it to its 256 BAMs by "hit * 64 / 50"
    LATCHED_SIGMA = ANGLE_STEP / math.sqrt(12)  # uniform within the step
    SLACK = 0.5  # m: at the far end of the room one step of a target's angle moves the fix this much
    DITHERS = 3
    DITHER = 2 / 3 * ANGLE_STEP

    def setup(self, brief) -> None:
        super().setup(brief)
        # the wall frame: origin at the middle target, y along the targets, x into the field
        p1, p2, p3 = [(b.x, b.y) for b in brief.beacons[:3]]
        cx, cy = (brief.field[0] + brief.field[2]) / 2, (brief.field[1] + brief.field[3]) / 2
        if (p3[0] - p1[0]) * (cy - p2[1]) - (p3[1] - p1[1]) * (cx - p2[0]) > 0:
            p1, p3 = p3, p1  # keep the frame right-handed with the field on its +x side
        self.origin = p2
        self.spacing = math.dist(p1, p3) / 2
        ay = ((p3[0] - p1[0]) / (2 * self.spacing), (p3[1] - p1[1]) / (2 * self.spacing))
        self.axes = ((ay[1], -ay[0]), ay)

    def candidates(self, rev: Revolution) -> list[Pose]:
        pose = self.fix(rev)
        return [pose] if pose is not None and self.inside(pose[0], pose[1]) else []

    def fix(self, rev: Revolution) -> Pose | None:
        """The pose from one standing turn by the circle-centre method, or None."""
        angles = self.relative(rev)
        if len(angles) != 3:
            return None
        order = sorted(angles)
        gaps = [(order[(i + 1) % 3] - order[i]) % (2 * math.pi) for i in range(3)]
        big = max(range(3), key=lambda i: gaps[i])
        if gaps[big] < math.pi:
            return None  # the targets do not all lie within half a turn: not one wall
        # counter-clockwise after the big gap: the target at +y of the wall frame, then 2, then -y
        t_plus, t_mid, t_minus = (order[(big + 1 + k) % 3] for k in range(3))
        a12, a23 = (t_minus - t_mid) % (2 * math.pi), (t_mid - t_plus) % (2 * math.pi)
        fix = wall(self.spacing, a12, a23)
        if not fix.ok:
            return None
        (ax, ay), (ox, oy) = self.axes, self.origin
        x, y = ox + fix.x * ax[0] + fix.y * ay[0], oy + fix.x * ax[1] + fix.y * ay[1]
        heading = math.atan2(oy - y, ox - x) - t_mid  # the middle target's world bearing
        return x, y, wrap(heading)
