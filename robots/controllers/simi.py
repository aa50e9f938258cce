"""Simi 2000: flash detectors latch the laser's encoder; Newton-Raphson gives x, y and heading.

Each revolution between index clicks yields one encoder angle per detector; the pose is
solved from them by Newton-Raphson, started from the last pose (the very first time from
the field centre, as Simi started from a fixed guess). The robot stands still (a localize
task) or drives its path by the same stop-and-go as Vannoy's and Ubersetzig's robots.
"""

from __future__ import annotations

from robots.controllers.stop_and_scan import StopAndScan
from robots.toolkit.angles import Revolution
from robots.toolkit.motion import Pose
from robots.toolkit.solvers import newton


class Simi(StopAndScan):
    def candidates(self, rev: Revolution) -> list[Pose]:
        seen = {b: a for a, b in rev.hits if b is not None}
        if len(seen) < 3:
            return []
        xmin, ymin, xmax, ymax = self.brief.field
        guess = self.tracker.pose or ((xmin + xmax) / 2, (ymin + ymax) / 2, 0.0)
        ids = sorted(seen)
        fix = newton([self.beacons[b] for b in ids], [seen[b] for b in ids], guess)
        return [(fix.x, fix.y, fix.heading)] if fix.ok and self.inside(fix.x, fix.y) else []
