"""Vannoy 2001: unlabelled reflections in their cyclic order, the circle method, and the
heading from the click-to-first-reflection time; stop-and-scan to the charger.

His sector rule (long / medium / short) picks one of the "three possible scenarios that make
sense", and fails where the sectors are alike: "There is of course one point where the angles
between all three reflectors will all be 120 degrees. In this case, the robot would have to
move". So every scenario is solved, and all that fit inside the field are candidates; the
robot moves to tell them apart (robots.controllers.stop_and_scan)."""

from __future__ import annotations

from robots.controllers.stop_and_scan import StopAndScan
from robots.toolkit.angles import Revolution
from robots.toolkit.associate import hypotheses
from robots.toolkit.motion import Pose


class Vannoy(StopAndScan):
    def candidates(self, rev: Revolution) -> list[Pose]:
        # "If there were less than or more than three reflections, we know that there has been a problem"
        if len(rev.hits) != 3 or len(self.beacons) != 3:
            return []
        return [c for c in hypotheses(self.relative(rev), self.beacons) if self.inside(c[0], c[1])]
