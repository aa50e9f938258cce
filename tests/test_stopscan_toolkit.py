"""The toolkit pieces that let a stop-and-scan robot find an announced start region: cyclic
association hypotheses, turn windows, pose algebra, the start region as a cut of the filter,
and the filter of one standing turn. Truth is geometry (and, for the truncated normal, a sum)."""

import math

import numpy as np
import pytest

from robots.api import BeaconInfo, Brief, LaserInfo, RobotInfo, SensorEvent, TaskInfo
from robots.toolkit.angles import TurnWindow
from robots.toolkit.associate import cyclic, hypotheses, predicted_angles
from robots.toolkit.ekf import BearingEKF
from robots.toolkit.motion import advance, between, compose
from robots.toolkit.tracker import HitTracker

FT = 0.3048
# Vannoy's reflectors: A (0, 21), B (13, 21), C (13, 0) ft, none at D (0, 0)
VANNOY = {"A": (0.0, 21 * FT), "B": (13 * FT, 21 * FT), "C": (13 * FT, 0.0)}


def bearings(pose, beacons):
    """Each beacon's angle counter-clockwise from straight ahead, by id."""
    x, y, h = pose
    return {b: (math.atan2(by - y, bx - x) - h) % (2 * math.pi) for b, (bx, by) in beacons.items()}


def fermat_point(points, iterations=2000):
    """The point from which three points are seen 120 degrees apart (Weiszfeld's iteration for
    the geometric median, which is that point when every angle of the triangle is under 120)."""
    x, y = np.mean(points, axis=0)
    for _ in range(iterations):
        w = [1 / math.dist((x, y), p) for p in points]
        x = sum(wi * p[0] for wi, p in zip(w, points)) / sum(w)
        y = sum(wi * p[1] for wi, p in zip(w, points)) / sum(w)
    return x, y


def test_cyclic_associations_keep_the_order_and_one_is_the_truth():
    pose = (8 * FT, 5 * FT, math.radians(220))  # the worked example: compass 230 deg
    seen = bearings(pose, VANNOY)
    angles = [seen["B"], seen["A"], seen["C"]]  # in any order
    found = cyclic(angles, VANNOY, (6.5 * FT, 10.5 * FT))
    assert len(found) == 3 and len({a.ids for a in found}) == 3
    assert ("B", "A", "C") in [a.ids for a in found]
    assert cyclic(angles[:2], VANNOY, (6.5 * FT, 10.5 * FT)) == []


def test_predicted_angles_are_the_revolution_in_order():
    pose = (8 * FT, 5 * FT, math.radians(220))
    assert predicted_angles(VANNOY, pose) == pytest.approx(sorted(bearings(pose, VANNOY).values()))


def test_hypotheses_at_the_worked_example_and_at_the_120_degree_point():
    # from (8, 5) ft only the true scenario fits inside the field
    pose = (8 * FT, 5 * FT, math.radians(220))
    inside = [
        c for c in hypotheses(predicted_angles(VANNOY, pose), VANNOY) if 0 <= c[0] <= 13 * FT and 0 <= c[1] <= 21 * FT
    ]
    assert len(inside) == 1 and inside[0] == pytest.approx(pose[:2] + (math.remainder(pose[2], 2 * math.pi),))
    # "one point where the angles between all three reflectors will all be 120 degrees": every
    # scenario fits there, at the same place, the headings a third of a turn apart
    x, y = fermat_point(list(VANNOY.values()))
    seen = sorted(bearings((x, y, 0.4), VANNOY).values())
    assert [(b - a) % (2 * math.pi) for a, b in zip(seen, seen[1:] + seen[:1])] == pytest.approx([2 * math.pi / 3] * 3)
    found = hypotheses(predicted_angles(VANNOY, (x, y, 0.4)), VANNOY)
    assert len(found) == 3
    for c in found:
        assert math.dist(c[:2], (x, y)) < 1e-6
    headings = sorted((c[2] - 0.4) % (2 * math.pi) for c in found)
    assert headings == pytest.approx([0, 2 * math.pi / 3, 4 * math.pi / 3], abs=1e-6)


def test_turn_window_from_a_click_and_latched_angles():
    period = 4.0
    w = TurnWindow(1.0, period)
    w.restart(0.0)
    # hits before and after the click: angles from the click, either way round
    assert w.feed(SensorEvent(1.0, "hit")) is None  # no click yet to time it from
    rev = w.feed(SensorEvent(2.0, "index"))
    assert rev is not None and [a for a, _ in rev.hits] == pytest.approx([2 * math.pi * 3 / 4])
    rev = w.feed(SensorEvent(3.0, "hit"))
    assert [a for a, _ in rev.hits] == pytest.approx([2 * math.pi * 3 / 4, 2 * math.pi / 4])
    assert not w.whole
    # a turn later the same beacon again: the older return is dropped, and the window is whole
    w.feed(SensorEvent(5.0, "hit"))
    assert [round(e.time, 6) for e in w.events if e.kind == "hit"] == [3.0, 5.0]
    assert w.whole
    # a click far from a turn after the last one: the laser is not tracking, timed angles refused
    assert w.feed(SensorEvent(6.5, "index")) is None
    # a latched angle needs no click
    latched = TurnWindow(1.0, period)
    rev = latched.feed(SensorEvent(0.5, "hit", None, 1.25))
    assert rev is not None and rev.hits == ((1.25, None),)


def test_turn_window_keeps_labelled_returns_of_beacons_close_together():
    # labelled detectors 10 deg apart, seen at A, B, C, then A again a turn later: A's repeat
    # drops A's old pulse only, so the window ending at it keeps B, C and A
    period = 1.0
    w = TurnWindow(1.0, period)
    for t, b, a in ((0.10, "A", 0.0), (0.128, "B", 0.17), (0.5, "C", 2.5), (1.10, "A", 0.0)):
        rev = w.feed(SensorEvent(t, "hit", b, a))
    assert rev is not None and [beacon for _, beacon in rev.hits] == ["B", "C", "A"]


def test_pose_algebra_round_trips():
    a, b = (1.0, 2.0, 0.3), (1.5, 1.2, -2.0)
    assert compose(a, between(a, b)) == pytest.approx(b)
    # straight ahead, then a quarter circle of radius 1 in many small steps
    assert advance((0.0, 0.0, 0.0), 2.0, 0.5, 0.0) == pytest.approx((1.0, 0.0, 0.0))
    pose = (0.0, 0.0, 0.0)
    for _ in range(1000):
        pose = advance(pose, math.pi / 2 / 1000, 1.0, 1.0)
    assert pose == pytest.approx((1.0, 1.0, math.pi / 2), abs=1e-6)


def filter_at(x, y, var):
    return BearingEKF(x, y, 0.0, 0.0, 1.0, var_xy=var, var_heading=0.01, var_sum=0.01, var_rate=1e-4)


def test_confine_is_the_truncated_normal_and_leaves_the_inside_alone():
    box = (0.0, 0.0, 1.0, 1.0)
    inside = filter_at(0.5, 0.5, 1e-4)
    inside.confine(box)
    assert inside.pose[:2] == pytest.approx((0.5, 0.5)) and inside.P[0, 0] == pytest.approx(1e-4)
    # an estimate beyond the edge: the mean and variance of the normal cut to the box, by a sum
    ekf = filter_at(-0.1, 0.5, 0.04)
    ekf.confine(box)
    z = np.linspace(0.0, 1.0, 200001)
    weight = np.exp(-((z + 0.1) ** 2) / (2 * 0.04))
    mean = float((z * weight).sum() / weight.sum())
    var = float(((z - mean) ** 2 * weight).sum() / weight.sum())
    assert ekf.s[0] == pytest.approx(mean, rel=1e-4) and ekf.P[0, 0] == pytest.approx(var, rel=1e-3)
    assert ekf.s[1] == pytest.approx(0.5)


def test_agrees_within_the_joint_uncertainty():
    a, b, c = filter_at(0.0, 0.0, 1e-4), filter_at(0.02, 0.0, 1e-4), filter_at(0.2, 0.0, 1e-4)
    assert a.agrees(b, 16.3) and not a.agrees(c, 16.3)


def brief(beacons, omega):
    return Brief(
        slot=0,
        field=(0.0, 0.0, 13 * FT, 21 * FT),
        beacon_kind="reflector",
        beacons=tuple(BeaconInfo(k, *p) for k, p in beacons.items()),
        laser=LaserInfo(omega, True),
        robot=RobotInfo("generic", 0.3, 0.25, 0.22, 0.5, 1.0),
        task=TaskInfo("goto", 0.3, goal=(0.0, 10.5 * FT)),
        control_period=0.05,
        time_limit=120.0,
    )


def standing_turn(pose, omega, start_phase):
    """Unlabelled returns and index clicks of a robot standing at `pose` for one turn and a
    bit, its laser at `start_phase` (relative to straight ahead) at t = 0."""
    period = 2 * math.pi / omega
    events = [SensorEvent((-start_phase) % (2 * math.pi) / omega, "index")]
    for a in bearings(pose, VANNOY).values():
        events.append(SensorEvent((a - start_phase) % (2 * math.pi) / omega, "hit"))
    events.append(SensorEvent(events[0].time + period, "index"))
    return sorted(events, key=lambda e: e.time)


def test_fit_turn_finds_the_pose_from_exact_returns():
    omega = math.pi / 2
    pose = (8 * FT, 5 * FT, math.radians(220))
    tracker = HitTracker(brief(VANNOY, omega), bearing_sigma=1e-3)
    turn = standing_turn(pose, omega, 1.0)
    tracker.feed([], turn[-1].time)  # the tracker's clock at the turn's last event
    # started from a guess 10 cm and 2 degrees off, the turn's returns bring it to the truth
    guess = (pose[0] + 0.1, pose[1] - 0.05, pose[2] + 0.035)
    ekf = tracker.fit_turn(guess[0], guess[1], guess[2], guess[2], turn)
    assert ekf.pose[:2] == pytest.approx(pose[:2], abs=2e-3)
    assert math.remainder(ekf.pose[2] - pose[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-3)
    assert 0 < ekf.P[0, 0] < 1e-3 and 0 < ekf.P[1, 1] < 1e-3
    tracker.adopt(ekf)
    assert tracker.pose == ekf.pose
