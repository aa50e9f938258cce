"""Revolution bookkeeping, BeAMS midpoints, the wheel model and the EKF on synthetic data."""

import math

import pytest

from robots.api import SensorEvent
from robots.toolkit.angles import BeaconRevolutions, IndexRevolutions, Revolution, midpoint, plausible
from robots.toolkit.ekf import BearingEKF
from robots.toolkit.motion import Wheels


def test_index_revolutions_give_angles_from_time_fractions():
    period = 0.5
    events = [SensorEvent(0.0, "index"), SensorEvent(0.125, "hit"), SensorEvent(0.3, "hit"),
              SensorEvent(0.5, "index"), SensorEvent(0.55, "hit"), SensorEvent(1.0, "index")]
    revs = IndexRevolutions().feed(events)
    assert len(revs) == 2 and revs[0].period == period
    assert [a for a, _ in revs[0].hits] == pytest.approx([math.pi / 2, 2 * math.pi * 0.6])
    cw = IndexRevolutions(sign=-1.0).feed(events)  # a clockwise laser: angles go the other way
    assert cw[0].hits[0][0] == pytest.approx(2 * math.pi - math.pi / 2)
    latched = IndexRevolutions().feed([SensorEvent(0, "index"), SensorEvent(0.1, "hit", None, 1.0),
                                       SensorEvent(0.5, "index")])
    assert latched[0].hits[0][0] == 1.0  # a hardware angle wins over the time fraction


def test_beacon_revolutions_and_plausibility():
    ev = [SensorEvent(t, "hit", b) for t, b in
          [(0.0, "O"), (0.02, "A"), (0.05, "B"), (0.08, "O"), (0.1, "A"), (0.16, "O")]]
    revs = BeaconRevolutions("O").feed(ev)
    assert [r.period for r in revs] == pytest.approx([0.08, 0.08])
    assert revs[0].hits[0] == (0.0, "O") and revs[0].hits[1][0] == pytest.approx(2 * math.pi * 0.25)
    assert plausible(revs[0], 0.08, 0.001, max_hits=4)
    assert not plausible(Revolution(0, 0.09, revs[0].hits), 0.08, 0.001, max_hits=4)
    assert not plausible(revs[1], 0.08, 0.001, max_hits=4, min_hits=3)  # only two hits
    assert midpoint(1.0, 1.2) == pytest.approx(1.1)


def test_wheels_ramp_like_the_drive():
    w = Wheels(track=0.1, accel=0.5)
    w.command(0.1, 0.1, top=0.17)
    dt, v, turn = w.advance(1.0)
    # 0.2 s ramp at mean 0.05, then 0.8 s at 0.1: mean 0.09
    assert (dt, v, turn) == pytest.approx((1.0, 0.09, 0.0))
    w.command(-0.1, 0.1, top=0.17)
    _, v, turn = w.advance(1.4)  # the left wheel ramps 0.1 -> -0.1 over exactly these 0.4 s
    assert v == pytest.approx(0.05) and turn == pytest.approx(1.0)


def test_ekf_converges_and_gates_an_outlier():
    beacons = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.5), (0.0, 1.5)]
    x, y, h, omega = 0.7, 0.5, 0.4, 40.0
    ekf = BearingEKF(0.75, 0.45, h, 0.0, omega, var_xy=1e-2, var_heading=1e-4, var_sum=1.0, var_rate=1.0)
    # exact hit times of a robot standing still: the beam h + omega t meets bearing b
    hits = sorted(((math.atan2(by - y, bx - x) - h) % (2 * math.pi) / omega + k * 2 * math.pi / omega, (bx, by))
                  for k in range(25) for bx, by in beacons)
    t, accepted = 0.0, 0
    for th, beacon in hits:
        ekf.predict(th - t, 0.0, 0.0)
        t = th
        accepted += ekf.hit(*beacon, 1e-6)
    ex, ey, _ = ekf.pose
    assert accepted > 90 and math.dist((ex, ey), (x, y)) < 1e-4
    ekf.predict(0.5 * 2 * math.pi / omega / 4, 0.0, 0.0)  # an eighth of a turn later
    assert not ekf.hit(*beacons[0], 1e-6)  # the beam is not pointing at it now: gated out
