"""Revolution bookkeeping, BeAMS midpoints, the wheel model, the EKF and the HitTracker on
synthetic data whose truth is geometry."""

import dataclasses
import math
import random

import pytest
from helpers import ARRAYS, table_brief

from robots.api import SensorEvent, StartInfo, TaskInfo
from robots.controllers.bac import Bac
from robots.toolkit.angles import BeaconRevolutions, IndexRevolutions, Revolution, midpoint, plausible, wrap
from robots.toolkit.ekf import BearingEKF, FloatEKF
from robots.toolkit.motion import Wheels, heading_change
from robots.toolkit.revolution import revolution_fix
from robots.toolkit.tracker import HitTracker


def test_index_revolutions_give_angles_from_time_fractions():
    period = 0.5
    events = [
        SensorEvent(0.0, "index"),
        SensorEvent(0.125, "hit"),
        SensorEvent(0.3, "hit"),
        SensorEvent(0.5, "index"),
        SensorEvent(0.55, "hit"),
        SensorEvent(1.0, "index"),
    ]
    revs = IndexRevolutions().feed(events)
    assert len(revs) == 2 and revs[0].period == period
    assert [a for a, _ in revs[0].hits] == pytest.approx([math.pi / 2, 2 * math.pi * 0.6])
    cw = IndexRevolutions(sign=-1.0).feed(events)  # a clockwise laser: angles go the other way
    assert cw[0].hits[0][0] == pytest.approx(2 * math.pi - math.pi / 2)
    latched = IndexRevolutions().feed(
        [SensorEvent(0, "index"), SensorEvent(0.1, "hit", None, 1.0), SensorEvent(0.5, "index")]
    )
    assert latched[0].hits[0][0] == 1.0  # a hardware angle wins over the time fraction


def test_beacon_revolutions_and_plausibility():
    ev = [
        SensorEvent(t, "hit", b)
        for t, b in [(0.0, "O"), (0.02, "A"), (0.05, "B"), (0.08, "O"), (0.1, "A"), (0.16, "O")]
    ]
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
    hits = sorted(
        ((math.atan2(by - y, bx - x) - h) % (2 * math.pi) / omega + k * 2 * math.pi / omega, (bx, by))
        for k in range(25)
        for bx, by in beacons
    )
    t, accepted = 0.0, 0
    for th, beacon in hits:
        ekf.predict(th - t, 0.0, 0.0)
        t = th
        accepted += ekf.hit(*beacon, 1e-6)
    ex, ey, _ = ekf.pose
    assert accepted > 90 and math.dist((ex, ey), (x, y)) < 1e-4
    ekf.predict(0.5 * 2 * math.pi / omega / 4, 0.0, 0.0)  # an eighth of a turn later
    assert not ekf.hit(*beacons[0], 1e-6)  # the beam is not pointing at it now: gated out


def test_the_float_ekf_is_the_ekf_up_to_rounding():
    """FloatEKF writes BearingEKF's algebra out term by term: every update, gate, innovation and
    box cut agree with it to rounding, along a drive with hits, latched angles and clicks."""
    rng = random.Random(5)
    start = dict(var_xy=1e-3, var_heading=1e-2, var_sum=1e-4, var_rate=0.04, q_drift=0.02, wobble=0.005)
    filters = [kind(0.6, 0.4, 0.3, 0.2, 40.0, **start) for kind in (BearingEKF, FloatEKF)]
    for k in range(400):
        dt, v, w = rng.uniform(0, 0.03), rng.uniform(-0.1, 0.2), rng.uniform(-1, 1)
        beacon = rng.choice([(0.0, 0.0), (2.0, 0.0), (2.0, 1.5), (0.0, 1.5)])
        said = []
        for ekf in filters:
            ekf.predict(dt, v, w)
            said.append(ekf.hit_innovation(*beacon, 1e-6))
            if k % 7 == 0:
                said.append(ekf.index(1e-4, gate=math.inf))
            elif k % 5 == 0:
                said.append(ekf.relative(*beacon, 0.3, 1e-4, gate=1.0))
            else:
                said.append(ekf.hit(*beacon, 4e-6, gate=1e9))
        assert said[0] == pytest.approx(said[2], rel=1e-9, abs=1e-12) and said[1] == said[3]
    for ekf in filters:
        ekf.widen(1e-2)
        ekf.confine((0.0, 0.0, 0.65, 1.5))
    a, b = filters
    assert b.s == pytest.approx(a.s, rel=1e-9) and b.P == pytest.approx(a.P, rel=1e-6, abs=1e-15)
    assert b.pose == pytest.approx(a.pose) and b.variance(2) == pytest.approx(a.variance(2), rel=1e-6)


# ---- the wheel model's turn prediction and the HitTracker ----------------------------------


def test_heading_change_of_a_trapezoid_spin():
    # from rest: each wheel ramps to 0.1 m/s in 0.2 s, holds, ramps down in 0.2 s after the
    # stop command at 0.4 s; a trapezoid's area is speed x command time: 0.04 m per wheel
    w = Wheels(track=0.1, accel=0.5)
    turned = heading_change(w, [(0.4, -0.1, 0.1), (0.0, 0.0, 0.0)], top=0.17)
    assert turned == pytest.approx(2 * 0.04 / 0.1)
    assert w.speeds == (0.0, 0.0)  # a prediction leaves the model itself alone
    w.command(0.1, 0.1, top=0.17)
    w.advance(1.0)
    assert heading_change(w, [(0.0, 0.1, 0.1)], top=0.17) == 0.0


def standing_hits(x, y, beam0, omega, turns, skip=()):
    """Exact pulse times of a standing robot whose beam points at world angle beam0 at t = 0."""
    period = 2 * math.pi / omega
    out = []
    for k in range(turns):
        for b, (bx, by) in ARRAYS.items():
            if b not in skip:
                t = (math.atan2(by - y, bx - x) - beam0) % (2 * math.pi) / omega + k * period
                out.append(SensorEvent(t, "hit", b))
    return sorted(out, key=lambda e: e.time)


def test_tracker_starts_from_three_of_four_arrays():
    # one array occluded all along: "the system uses the remaining three pulses"
    tracker = HitTracker(table_brief())
    hits = standing_hits(0.7, 0.5, 0.3, 81.0, 6, skip={"B"})
    tracker.feed(hits, hits[-1].time)
    x, y, _ = tracker.pose
    assert math.dist((x, y), (0.7, 0.5)) < 1e-6


def revolution_of(tracker: HitTracker, recent: list[tuple[float, str]]):
    """The fix the tracker would start from, the newest of `recent` closing its revolution."""
    return revolution_fix(recent, tracker.beacons, tracker.omega + tracker.turn_rate, tracker.time_out)


def test_tracker_checks_revolution_time_and_time_out():
    tracker = HitTracker(table_brief())
    hits = standing_hits(0.7, 0.5, 0.3, 81.0, 2)
    recent = [(e.time, e.beacon) for e in hits[:5]]  # one revolution, closed by its first array
    assert revolution_of(tracker, recent) is not None
    (t0, b0), *rest = recent
    smallest = min(b - a for (a, _), (b, _) in zip(recent, recent[1:]))
    late = rest[-1][0] + 1.5 * smallest  # the closing pulse beyond the smallest pulse duration
    recent = [(t0, b0), *rest[:-1], (late, rest[-1][1])]
    assert revolution_of(tracker, recent) is None  # Bac's revolution-time filter
    # the closing array missed a turn: its revolution spans two turns, beyond the 130 ms time-out
    first, *between, _ = recent
    period = 2 * math.pi / 81.0
    recent = [first, *((t + period, b) for t, b in between), (first[0] + 2 * period, first[1])]
    assert recent[-1][0] - recent[0][0] > 0.130
    assert revolution_of(tracker, recent) is None
    # at 31 rad/s a turn takes 203 ms: the time-out is the same share of a turn, not 130 ms
    slow = HitTracker(table_brief(omega=31.0))
    assert revolution_of(slow, [(e.time, e.beacon) for e in standing_hits(0.7, 0.5, 0.3, 31.0, 2)[:5]]) is not None


def test_tracker_drops_merged_pulses_and_recovers_when_lost():
    # announced start 0.1 m off the truth: most pulses fail the gate until the tracker
    # restarts from a checked revolution, then it holds the true pose
    tracker = HitTracker(table_brief(start=StartInfo(0.8, 0.5, 0.0)))
    hits = standing_hits(0.7, 0.5, 0.3, 81.0, 12)
    merged = SensorEvent(hits[21].time, "hit", hits[20].beacon)  # pulse 20 reported at 21's time
    events = sorted(hits[:20] + [merged] + hits[21:], key=lambda e: e.time)
    tracker.feed(events, events[-1].time)
    x, y, _ = tracker.pose
    assert tracker.restarts == 1 and math.dist((x, y), (0.7, 0.5)) < 1e-4


def test_bac_turn_ends_on_the_angle_between_control_ticks():
    # a perfect drive that does exactly what the wheel model says: after one spin turn the
    # robot drives off along the bearing to its waypoint, though the turn's end falls between ticks
    brief = table_brief(start=StartInfo(0.5, 0.5, 0.0))
    brief = dataclasses.replace(brief, task=TaskInfo("waypoints", 0.05, ((0.5 + math.cos(2.0), 0.5 + math.sin(2.0)),)))
    bac = Bac()
    bac.setup(brief)
    wheels, pose, dt = Wheels(0.105, 0.5), [0.5, 0.5, 0.0], 1 / 240
    for tick in range(20):
        left, right = bac._guide(tuple(pose))
        bac.tracker.command(left, right)
        wheels.command(left, right, 0.17)
        for k in range(48):
            _, v, w = wheels.advance(tick * 0.2 + (k + 1) * dt)
            pose = [
                pose[0] + v * math.cos(pose[2] + w * dt / 2) * dt,
                pose[1] + v * math.sin(pose[2] + w * dt / 2) * dt,
                pose[2] + w * dt,
            ]
        bac.tracker.wheels.advance((tick + 1) * 0.2)
        if tick > 2 and wheels.speeds[0] == wheels.speeds[1] > 0:
            break
    bearing = math.atan2(0.5 + math.sin(2.0) - pose[1], 0.5 + math.cos(2.0) - pose[0])
    assert wheels.speeds[0] == wheels.speeds[1] > 0 and abs(wrap(pose[2] - bearing)) < 0.01


def moving_hits(x0, y0, heading, v, beam0, omega, duration):
    """Exact pulse times of a robot driving straight from (x0, y0) at v m/s along `heading`,
    its beam at world angle beam0 + omega t: each crossing solved by fixed-point iteration."""
    out, period = [], 2 * math.pi / omega
    for k in range(int(duration / period) + 1):
        for b, (bx, by) in ARRAYS.items():
            t = k * period
            for _ in range(60):
                px, py = x0 + v * math.cos(heading) * t, y0 + v * math.sin(heading) * t
                t = k * period + (math.atan2(by - py, bx - px) - beam0 - k * 2 * math.pi) % (2 * math.pi) / omega
            if t < duration:
                out.append(SensorEvent(t, "hit", b))
    return sorted(out, key=lambda e: e.time)


def test_tracker_takes_the_heading_from_the_direction_of_travel():
    # the announced heading is 1 rad wrong (a robot put down askew): driving straight, the
    # filtered positions go where the robot goes, and Bac's heading from them corrects it
    tracker = HitTracker(table_brief(start=StartInfo(0.5, 0.5, 1.3)))
    hits = moving_hits(0.5, 0.5, 0.3, 0.1, 0.7, 81.0, 3.0)
    tracker.command(0.1, 0.1)
    tracker.wheels.speeds = (0.1, 0.1)  # already at speed, as the hits assume
    for k in range(15):
        now = 0.2 * (k + 1)
        tracker.feed([e for e in hits if now - 0.2 < e.time <= now], now)
        tracker.command(0.1, 0.1)
    x, y, h = tracker.pose
    assert tracker.restarts == 1  # the heading restarted once from the direction of travel
    assert (
        abs(wrap(h - 0.3)) < 0.03 and math.dist((x, y), (0.5 + 0.3 * math.cos(0.3), 0.5 + 0.3 * math.sin(0.3))) < 0.002
    )


def test_tracker_restarts_when_the_closed_form_fixes_contradict_it():
    # 5 cm off with the lost rule out of play (lost_after beyond the window): the filter takes
    # the pulses with a wrong laser phase, but a revolution of Bac-checked fixes says otherwise
    tracker = HitTracker(table_brief(start=StartInfo(0.75, 0.5, 0.0)), lost_after=17)
    hits = standing_hits(0.7, 0.5, 0.3, 81.0, 6)
    tracker.feed(hits, hits[-1].time)
    x, y, _ = tracker.pose
    assert tracker.restarts == 1 and math.dist((x, y), (0.7, 0.5)) < 1e-4
