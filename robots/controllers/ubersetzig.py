"""Ubersetzig 1999: three retroreflective targets on one wall, angles in 256 binary steps,
solved by his circle-centre method; stop-and-scan to the goal. A scan that does not show
exactly three targets within half a turn is rejected ("lost: can't find 3 targets",
"targets on more than one wall")."""

from __future__ import annotations

import math

from robots.controllers.stop_and_scan import StopAndScan
from robots.toolkit.angles import Revolution
from robots.toolkit.solvers import wall


class Ubersetzig(StopAndScan):
    BEARING_SIGMA = 2 * math.pi / 256 / math.sqrt(12)  # "256 divisions in a complete circle": a uniform step

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

    def fix(self, rev: Revolution) -> tuple[float, float, float] | None:
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
        return x, y, math.remainder(heading, 2 * math.pi)
