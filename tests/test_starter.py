"""The starter controller (`ref:starter`: a waypoint follower with a filter of its own, in one file) localizes and drives."""

import ast
import math
import sys

import pytest

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots.controllers import starter
from robots.controllers.starter import fix


def test_fix_recovers_a_moving_robot_from_synthetic_hits():
    # independent truth: crossing times from the geometry of a robot driving east at 0.12 m/s
    beacons = {"O": (0, 0), "A": (1.83, 0), "B": (1.83, 1.22), "C": (0, 1.22)}
    omega, v, x0, y0 = 31.0, 0.12, 0.5, 0.61
    hits = []
    for b, (bx, by) in beacons.items():
        t = 0.2  # solve omega * t = bearing(t) mod 2 pi by fixed-point iteration near t
        bearing = math.atan2(by - y0, bx - x0 - v * t)
        t = (bearing % (2 * math.pi)) / omega + 2 * math.pi / omega
        for _ in range(50):
            t = ((math.atan2(by - y0, bx - x0 - v * t)) % (2 * math.pi) + 2 * math.pi) / omega
        hits.append((t, b))
    hits.sort()
    x, y = fix(hits, beacons, omega, (x0, y0), (v, 0.0))
    assert (x, y) == pytest.approx((x0 + v * hits[-1][0], y0), abs=1e-9)


def test_fix_drops_a_merged_pulse():
    beacons = {"O": (0, 0), "A": (1.83, 0), "B": (1.83, 1.22), "C": (0, 1.22)}
    omega, x0, y0 = 81.0, 1.16, 0.53
    hits = sorted(((math.atan2(by - y0, bx - x0) % (2 * math.pi)) / omega, b) for b, (bx, by) in beacons.items())
    bad = hits[:1] + [(hits[2][0], hits[1][1])] + hits[2:]  # pulse 2 reported at pulse 3's time
    assert fix(bad, beacons, omega, (0.9, 0.6)) is None  # two beacons left: no fix, never a wrong one
    period = 2 * math.pi / omega
    more = bad + [(t + period, b) for t, b in hits]  # the next revolution is clean
    assert fix(more, beacons, omega, (0.9, 0.6)) == pytest.approx((x0, y0), abs=1e-9)


def test_starter_static_is_exact_when_ideal_and_follows_the_line():
    static = play_match(load_level(levels.path("bac-static")), [resolve("ref:starter")], ideal=True)
    loc = static["robots"][0]["localization"]
    assert loc["position_max"] < 1e-6 and loc["fraction"] > 0.99
    line = play_match(load_level(levels.path("bac-line")), [resolve("ref:starter")], ideal=True)
    r = line["robots"][0]
    assert r["task"]["reached"] == 10 and r["localization"]["position_rms"] < 0.005


def test_starter_stays_one_self_contained_file():
    # `laserarena new` copies this one file for a team: it may import the API and the standard library only
    tree = ast.parse(open(starter.__file__).read())
    modules = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names} | {
        n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
    }
    assert all(m == "robots.api" or m.split(".")[0] in sys.stdlib_module_names for m in modules), modules
