"""Which beacon is which, for unlabelled returns (reflectors).

How it works, in detail: docs/internals.md, `robots/toolkit/associate.py`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import product

from robots.toolkit.solvers import circles

TWO_PI = 2 * math.pi


@dataclass(frozen=True)
class Association:
    """Beacon ids for each return (None where unmatched), and whether the rule could decide."""

    ids: tuple[str | None, ...]
    ambiguous: bool = False


def _gaps(angles: list[float]) -> list[float]:
    """Sector sizes from each return to the next, going round (sum 2 pi)."""
    n = len(angles)
    return [(angles[(i + 1) % n] - angles[i]) % TWO_PI or TWO_PI for i in range(n)]


def by_sectors(
    angles: list[float],
    beacons: dict[str, tuple[float, float]],
    reference: tuple[float, float],
    margin: float = math.radians(5),
) -> Association:
    """Vannoy's sector-order rule for any layout: `angles` of one revolution's returns in the
    order seen (counter-clockwise), `beacons` by id, `reference` a point inside the layout."""
    ids = list(beacons)
    n = len(ids)
    if len(angles) != n:
        return Association((None,) * len(angles), True)
    rx, ry = reference
    # beacons in counter-clockwise order seen from the reference, and their predicted sectors
    ccw = sorted(ids, key=lambda b: math.atan2(beacons[b][1] - ry, beacons[b][0] - rx))
    predicted = _gaps([math.atan2(beacons[b][1] - ry, beacons[b][0] - rx) for b in ccw])
    measured = _gaps(sorted(angles))
    rank = lambda g: sorted(range(n), key=lambda i: g[i])  # noqa: E731
    matches = [s for s in range(n) if rank([measured[(i + s) % n] for i in range(n)]) == rank(predicted)]
    close = min(abs(a - b) for i, a in enumerate(sorted(measured)) for b in sorted(measured)[i + 1 :])
    if len(matches) != 1 or close < margin:
        return Association((None,) * n, True)
    shift = matches[0]
    order = sorted(range(n), key=lambda i: angles[i])  # positions of returns in angular order
    out: list[str | None] = [None] * n
    for k, i in enumerate(order):
        out[i] = ccw[(k - shift) % n]
    return Association(tuple(out))


def by_prediction(
    bearings: list[float], beacons: dict[str, tuple[float, float]], pose: tuple[float, float, float], gate: float
) -> Association:
    """Each return to the beacon whose bearing from `pose` (x, y, heading) is nearest, if within
    `gate` rad and not taken by a nearer return; others stay None."""
    x, y, h = pose
    predicted = {b: math.atan2(by - y, bx - x) - h for b, (bx, by) in beacons.items()}
    pairs = sorted(
        (abs(math.remainder(z - p, TWO_PI)), i, b) for i, z in enumerate(bearings) for b, p in predicted.items()
    )
    out: list[str | None] = [None] * len(bearings)
    used: set[str] = set()
    for err, i, b in pairs:
        if err <= gate and out[i] is None and b not in used:
            out[i] = b
            used.add(b)
    return Association(tuple(out), ambiguous=any(o is None for o in out))


def cyclic(
    angles: list[float], beacons: dict[str, tuple[float, float]], reference: tuple[float, float]
) -> list[Association]:
    """Every association of one revolution's returns (`angles`, counter-clockwise from any
    reference, one per beacon) that keeps the beacons' counter-clockwise order seen from
    `reference`: one per cyclic shift, none if the counts differ."""
    ids = list(beacons)
    n = len(ids)
    if len(angles) != n:
        return []
    rx, ry = reference
    ccw = sorted(ids, key=lambda b: math.atan2(beacons[b][1] - ry, beacons[b][0] - rx))
    order = sorted(range(n), key=lambda i: angles[i] % TWO_PI)
    out = []
    for shift in range(n):
        ids_: list[str | None] = [None] * n
        for k, i in enumerate(order):
            ids_[i] = ccw[(k + shift) % n]
        out.append(Association(tuple(ids_)))
    return out


def predicted_angles(beacons: dict[str, tuple[float, float]], pose: tuple[float, float, float]) -> list[float]:
    """The angles, counter-clockwise from straight ahead in [0, 2 pi), at which a robot at
    `pose` (x, y, heading) sees the beacons, in increasing order: its unlabelled revolution."""
    x, y, h = pose
    return sorted((math.atan2(by - y, bx - x) - h) % TWO_PI for bx, by in beacons.values())


def hypotheses(
    angles: list[float], beacons: dict[str, tuple[float, float]], residual: float = 0.02
) -> list[tuple[float, float, float]]:
    """The poses (x, y, heading of angle 0) of every cyclic association (seen from the beacons'
    centroid) of three returns that the circle method solves, each checked against the
    returns: a circle holds both arcs of a chord, which see it under an angle and under its
    supplement, so a solution must give back every return's angle within `residual` rad."""
    centroid = (sum(x for x, _ in beacons.values()) / len(beacons), sum(y for _, y in beacons.values()) / len(beacons))
    out = []
    for assoc in cyclic(angles, beacons, centroid):
        points = [beacons[b] for b in assoc.ids if b is not None]
        fix = circles(points, angles)
        if not fix.ok:
            continue
        errors = [
            math.remainder(math.atan2(by - fix.y, bx - fix.x) - fix.heading - a, TWO_PI)
            for (bx, by), a in zip(points, angles)
        ]
        if max(abs(e) for e in errors) <= residual:
            out.append((fix.x, fix.y, fix.heading))
    return out


def one_laser(
    hits: list[tuple[float, str]],
    beacons: dict[str, tuple[float, float]],
    prior: tuple[float, float],
    radius: float,
    rate: float,
    slack: float = 0.01,
    noise: float = 0.01,
) -> list[list[tuple[float, str]]]:
    """Every set of labelled pulses (time, beacon) that one laser turning at `rate` (rad/s,
    signed) could have made in the turn that ends with the last of `hits`, standing within
    `radius` (m) of `prior`: the last pulse, and at most one earlier pulse per other beacon.

    Seen from where the laser stands, each of its pulses says where its beam points at the
    end of the turn: the bearing of that pulse's beacon, less the angle the beam has turned
    since (rate x elapsed time). For one laser they all agree; another laser's pulses, made
    from elsewhere and at other times, do not. Seen from `prior` rather than the true spot
    they agree within radius / distance for each beacon, and within `slack` x rate x elapsed
    time for a rate off its nominal value by that share, and `noise` (rad) for the pulses'
    own errors: a pulse further off than that is some other laser's. Sets of at least three
    pulses, the largest first."""
    end, closing = hits[-1]
    period = TWO_PI / abs(rate)

    def beam_at_end(t: float, b: str) -> float:
        bx, by = beacons[b]
        return math.atan2(by - prior[1], bx - prior[0]) - rate * (t - end)

    def reach(b: str) -> float:  # how far a pulse of b may point from where the prior says
        return radius / max(math.dist(beacons[b], prior), 1e-3)

    anchor = beam_at_end(end, closing)
    options: dict[str, list[tuple[float, str] | None]] = {b: [None] for b in beacons if b != closing}
    for t, b in hits[:-1]:
        if b == closing or not end - period * (1 - slack) < t < end:
            continue
        tolerance = reach(b) + reach(closing) + slack * abs(rate) * (end - t) + noise
        if abs(math.remainder(beam_at_end(t, b) - anchor, TWO_PI)) <= tolerance:
            options[b].append((t, b))
    out = []
    for chosen in product(*options.values()):
        pulses = sorted([h for h in chosen if h is not None]) + [(end, closing)]
        if len(pulses) >= 3:
            out.append(pulses)
    out.sort(key=len, reverse=True)
    return out
