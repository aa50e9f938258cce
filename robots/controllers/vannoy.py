"""Vannoy 2001: unlabelled reflections identified by sector order, the circle method, and the
heading from the click-to-first-reflection time; stop-and-scan to the charger."""

from __future__ import annotations

from robots.controllers.stop_and_scan import StopAndScan
from robots.toolkit.angles import Revolution
from robots.toolkit.associate import by_sectors
from robots.toolkit.solvers import circles


class Vannoy(StopAndScan):
    def fix(self, rev: Revolution) -> tuple[float, float, float] | None:
        if len(rev.hits) != 3 or len(self.beacons) != 3:
            return None
        rel = self.relative(rev)
        xmin, ymin, xmax, ymax = self.brief.field
        pose = self.tracker.pose
        reference = pose[:2] if pose else ((xmin + xmax) / 2, (ymin + ymax) / 2)
        assoc = by_sectors(rel, self.beacons, reference)
        if assoc.ambiguous:
            return None  # Vannoy: "the robot would have to move ... to resolve the problem"
        fix = circles([self.beacons[b] for b in assoc.ids if b is not None], rel)
        if not fix.ok or not (xmin <= fix.x <= xmax and ymin <= fix.y <= ymax):
            return None
        return fix.x, fix.y, fix.heading
