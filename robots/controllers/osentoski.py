"""Osentoski: three lights in a line; a turret samples brightness 120 times a turn.

From each scan: keep the samples clearly brighter than the scan's typical value (0 = bright), find
the local minima, refine each by a parabola through the logarithm of the light in it and
its neighbours (exact for a Gaussian beam profile); with exactly three peaks,
the middle one in counter-clockwise order is the middle light, and the angles between it and
the outer ones give the position by the law of sines. The heading follows from the middle
light's bearing. A scan that does not show three clear peaks (near a light, lights merging
from afar, a shaky servo) is skipped, as the seed's robot had to. The robot stands still, so
the reported pose is the median of its fixes since the trial began.
"""

from __future__ import annotations

import math
from statistics import median

from robots.api import Brief, Command, Controller, Observation
from robots.toolkit.angles import wrap
from robots.toolkit.solvers import law_of_sines

SPLIT = 2  # samples (6 deg, one beam width): closer peaks are one light's, split by the servo's shake


def peaks(samples: tuple[int, ...]) -> list[float]:
    """Angles (counter-clockwise from straight ahead) of the bright spots of one scan."""
    n = len(samples)
    # "a filter using the average light value": a robust average (the median, as most samples
    # are dark) and the noise around it, read on the bright side (the quarter of the samples
    # brightest but for the lights lies 0.674 sd below the median; the dark side clips at 255,
    # so a spread measured both ways would hide the noise); spikes within six sd are noise
    ordered = sorted(samples)
    median = ordered[n // 2]
    sd = (median - ordered[n // 4]) / 0.674
    threshold = median - max(5.0, 6.0 * sd)
    minima = [
        k
        for k in range(n)
        if samples[k] < threshold and samples[k] <= samples[k - 1] and samples[k] < samples[(k + 1) % n]
    ]
    # a shaking servo ("more than three light spikes") splits one light's peak in two: of peaks
    # within SPLIT samples of each other only the brightest is a light
    kept: list[int] = []
    for k in sorted(minima, key=lambda k: samples[k]):
        if all(min((k - j) % n, (j - k) % n) > SPLIT for j in kept):
            kept.append(k)
    found = []
    for k in sorted(kept):
        a, b, c = samples[k - 1], samples[k], samples[(k + 1) % n]
        # a beam of Gaussian profile: the log of the light (1 - sample / 255) is a parabola,
        # so the vertex through the log of three samples is exact where nothing saturates
        la, lb, lc = (math.log(max(1e-3, 1.0 - v / 255.0)) for v in (a, b, c))
        curve = 2 * lb - la - lc
        offset = 0.5 * (lc - la) / curve if curve > 0 else 0.0
        found.append(((k + offset) * 2 * math.pi / n) % (2 * math.pi))
    return found


class Osentoski(Controller):
    def setup(self, brief: Brief) -> None:
        self.brief = brief
        lights = [(b.x, b.y) for b in brief.beacons]
        # the middle light is the one between the other two
        self.middle = min(range(3), key=lambda i: sum(math.dist(lights[i], lights[j]) for j in range(3)))
        outer = [lights[i] for i in range(3) if i != self.middle]
        self.m = lights[self.middle]
        self.spacing = math.dist(outer[0], outer[1]) / 2
        cx, cy = (brief.field[0] + brief.field[2]) / 2, (brief.field[1] + brief.field[3]) / 2
        # frame: origin at the middle light, x towards the outer light that leaves the field
        # centre on the -y side (the law of sines puts the robot at y < 0)
        for first, second in (outer, outer[::-1]):
            ux, uy = (second[0] - first[0]) / (2 * self.spacing), (second[1] - first[1]) / (2 * self.spacing)
            if -(cx - self.m[0]) * uy + (cy - self.m[1]) * ux < 0:
                self.axis = (ux, uy)
                break
        self.pose: tuple[float, float, float] | None = None
        self.fixes: list[tuple[float, float, float]] = []
        self.trial = 0

    def fix(self, samples: tuple[int, ...]) -> tuple[float, float, float] | None:
        found = peaks(samples)
        if len(found) != 3:
            return None
        order = sorted(found)
        gaps = [(order[(i + 1) % 3] - order[i]) % (2 * math.pi) for i in range(3)]
        big = max(range(3), key=lambda i: gaps[i])
        if gaps[big] < math.pi:
            return None  # lights on more than one side: not the line of three
        # counter-clockwise after the big gap: the light at +x of our frame, the middle, the -x one
        right, mid, left = (order[(big + 1 + k) % 3] for k in range(3))
        fix = law_of_sines(self.spacing, (left - mid) % (2 * math.pi), (mid - right) % (2 * math.pi))
        if not fix.ok:
            return None
        (ux, uy), (mx, my) = self.axis, self.m
        x = mx + fix.x * ux - fix.y * uy
        y = my + fix.x * uy + fix.y * ux
        heading = math.atan2(my - y, mx - x) - mid
        return x, y, wrap(heading)

    def step(self, observation: Observation) -> Command:
        if observation.trial != self.trial:  # carried to a new pose: its fixes start again
            self.trial, self.pose, self.fixes = observation.trial, None, []
        for e in observation.events:
            if e.kind == "scan":
                pose = self.fix(e.samples)
                if pose is not None:
                    self._fuse(pose)
        return Command(0.0, 0.0, estimate=self.pose)

    def _fuse(self, fix: tuple[float, float, float]) -> None:
        """The robot never moves, so its pose is what its fixes since the trial began agree on:
        their median, each coordinate's (the heading's about the first fix), so that a scan that
        a shaking servo or a merging pair of lights made wrong is outvoted, not averaged in."""
        self.fixes.append(fix)
        h0 = self.fixes[0][2]
        xs, ys = [f[0] for f in self.fixes], [f[1] for f in self.fixes]
        hs = [wrap(f[2] - h0) for f in self.fixes]
        self.pose = (median(xs), median(ys), wrap(h0 + median(hs)))
