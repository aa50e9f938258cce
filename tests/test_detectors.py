"""Each detector model's failure modes, against the geometry that should cause them."""

import math

import numpy as np
import pytest

from test_laser import ONE, TWO, hits, make, sense


def bearing_from(world, slot, beacon_id):
    s = world.level.robots[slot].start
    b = world.level.beacons.by_id(beacon_id)
    return math.atan2(b.y - s.y, b.x - s.x), math.dist((s.x, s.y), (b.x, b.y))


def test_reflector_range_limit_and_unlabelled_returns():
    # robot at (1.7, 1.2): P is 1.70 m away, R 2.33 m, Q 2.14 m, S 1.98 m
    w = make("reflector", params="  params: {range: 2.0, timing_noise: 0}")
    (events,), _ = sense(w, 3.0, ideal=False)
    assert all(e.beacon is None for e in hits(events))
    dists = {b: bearing_from(w, 0, b)[1] for b in "PQRS"}
    expected = sum(1 for d in dists.values() if d <= 2.0)
    per_turn = len(hits(events)) / (3.0 * 20.0 / (2 * math.pi))
    assert per_turn == pytest.approx(expected, abs=0.4)
    (ideal,), _ = sense(make("reflector", params="  params: {range: 2.0}"), 3.0, ideal=True)
    assert len(hits(ideal)) / (3.0 * 20.0 / (2 * math.pi)) == pytest.approx(4, abs=0.4)


def with_facing(kind, beacon_line, degrees, params=""):
    """The test table with one beacon facing `degrees`."""
    from arena.loader import parse_level
    from arena.world import World
    from test_laser import TABLE
    text = TABLE.format(kind=kind, omega=60.0, robots=ONE, params=params, obstacles="")
    text = text.replace(beacon_line, beacon_line[:-1] + f", facing: {degrees}}}")
    return World(parse_level(text.encode(), "t.yaml"))


def test_reflector_incidence_limit():
    # P at (0.2, 0.3) seen from the robot at (1.7, 1.2); turn P's face away from the robot
    to_robot = math.degrees(math.atan2(1.2 - 0.3, 1.7 - 0.2))
    for offset, seen in ((30, True), (50, False)):
        w = with_facing("reflector", "{id: P, at: [0.2, 0.3]}", to_robot + offset,
                        "  params: {max_incidence: 40}")
        (events,), _ = sense(w, 1.0, ideal=False)
        back, _ = bearing_from(w, 0, "P")
        rel = (back - w.level.robots[0].start.heading) % (2 * math.pi)
        p_returns = [e for e in hits(events) if abs((e.time * 60.0) % (2 * math.pi) - rel) < 1e-3]
        assert bool(p_returns) == seen, offset


def test_reflector_false_returns_poisson():
    rate, seconds = 5.0, 20.0
    w = make("reflector", params=f"  params: {{false_rate: {rate}}}", omega=20.0)
    (events,), _ = sense(w, seconds, ideal=False)
    true_times = 4 * seconds * 20.0 / (2 * math.pi)
    false = len(hits(events)) - round(true_times)
    mean = rate * seconds
    assert abs(false - mean) < 4 * math.sqrt(mean)
    (ideal,), _ = sense(make("reflector", params=f"  params: {{false_rate: {rate}}}"), seconds, ideal=True)
    assert abs(len(hits(ideal)) - true_times) <= 4


def test_sensor_array_tangential_speed_limit():
    # omega * distance > limit * cos(incidence) -> missed. At 150 rad/s: P (1.70 m) sweeps
    # at 255 m/s, R (2.33 m) at 350 m/s; limit 300 m/s.
    w = make("sensor_array", omega=150.0, params="  params: {max_tangential_speed: 300}")
    (events,), _ = sense(w, 1.0, ideal=False)
    facing = {b.id: b.facing for b in w.level.beacons.items}
    for b in "PQRS":
        bearing, d = bearing_from(w, 0, b)
        inc = abs(math.remainder(bearing + math.pi - facing[b], 2 * math.pi))
        expect_seen = 150.0 * d <= 300 * math.cos(inc)
        assert bool(hits(events, b)) == expect_seen, b
    assert hits(events, "P") and not hits(events, "R")  # the layout really tests both sides
    (ideal,), _ = sense(make("sensor_array", omega=150.0, params="  params: {max_tangential_speed: 300}"),
                        1.0, ideal=True)
    assert all(hits(ideal, b) for b in "PQRS")


def test_sensor_array_merges_and_clock():
    rate = 0.2
    w = make("sensor_array", params=f"  params: {{merge_rate: {rate}, clock_hz: 20.0e+6}}")
    (events,), _ = sense(w, 20.0, ideal=False, every=48)
    times = np.array([e.time for e in hits(events)])
    # a merged pulse is reported at the next pulse's time: equal consecutive times
    merged = np.sum(np.diff(times) == 0)
    n = len(times)
    expected = rate * n * (1 - 1 / (0.2 * 20 * 20 / (2 * math.pi)))  # none merged at batch ends
    assert abs(merged - expected) < 4 * math.sqrt(n * rate * (1 - rate))
    # 20 MHz counter: every time is a whole number of 50 ns ticks
    ticks = times * 20e6
    assert np.all(np.abs(ticks - np.round(ticks)) < 1e-3)
    assert all(e.beacon in "PQRS" for e in hits(events))


def test_flash_detector_encoder_angles_and_incidence_limit():
    w = make("flash_detector", omega=60.0)
    (events,), _ = sense(w, 2.0, ideal=False)
    quantum = 2 * math.pi / 12500
    h0 = w.level.robots[0].start.heading
    for e in hits(events):
        counts = e.angle / quantum
        assert abs(counts - round(counts)) < 1e-6  # whole encoder counts
        bearing, _ = bearing_from(w, 0, e.beacon)
        true_rel = (bearing - h0) % (2 * math.pi)
        assert 0 <= true_rel - e.angle < quantum + 1e-12  # latched: truncated, never ahead
    (ideal,), _ = sense(make("flash_detector", omega=60.0), 0.5, ideal=True)
    for e in hits(ideal):  # ideal: the exact relative angle, to rounding
        bearing, _ = bearing_from(w, 0, e.beacon)
        assert e.angle == pytest.approx((bearing - h0) % (2 * math.pi), abs=1e-9)
    # the incidence limit falls with range: 44 deg at 1 ft, 27 deg at 7 ft (linear between)
    from arena.detectors import flash_limit
    p = w.level.beacons.params
    limits = flash_limit(np.array([0.3048, 4 * 0.3048, 7 * 0.3048]), p)
    assert np.degrees(limits) == pytest.approx([44, 35.5, 27])


def test_flash_detector_misses_beyond_its_incidence_limit():
    # P faces away from the robot by 20 or 40 deg; its limit at ~1.7 m range is ~29.5 deg
    to_robot = math.degrees(math.atan2(1.2 - 0.3, 1.7 - 0.2))
    for offset, seen in ((20, True), (40, False)):
        w = with_facing("flash_detector", "{id: P, at: [0.2, 0.3]}", to_robot + offset)
        (events,), _ = sense(w, 1.0, ideal=False)
        assert bool(hits(events, "P")) == seen


def test_binary_angle_quantization():
    w = make("reflector", params="  params: {quantization: 256}")
    (events,), _ = sense(w, 1.0, ideal=False)
    q = 2 * math.pi / 256
    for e in hits(events):
        assert abs(e.angle / q - round(e.angle / q)) < 1e-6
        rel = (e.time * 20.0) % (2 * math.pi)
        assert 0 <= rel - e.angle < q + 1e-9
    (ideal,), _ = sense(make("reflector", params="  params: {quantization: 256}"), 1.0, ideal=True)
    assert all(e.angle is None for e in hits(ideal))


@pytest.mark.parametrize("mode", ["coded", "shared"])
def test_crosstalk_coded_vs_shared(mode):
    w = make("sensor_array", robots=TWO.replace("[0.95, 0.75, 0]", "[2.9, 2.2, 0]"),
             params=f"  crosstalk: {mode}")
    events, _ = sense(w, 2.0, ideal=True)
    own = [[e for e in evs if e.kind == "hit" and e.source == r] for r, evs in enumerate(events)]
    everyone = sum(len(o) for o in own)
    for r, evs in enumerate(events):
        n = len(hits(evs))
        assert n == (len(own[r]) if mode == "coded" else everyone)
        assert len(own[r]) > 15


def test_wobble_varies_the_revolution_period_and_ideal_removes_it():
    w = make("sensor_array", omega=20.0, params="  params: {wobble: 0.01, wobble_time: 0.2}")
    (events,), _ = sense(w, 20.0, ideal=False)
    gaps = np.diff([e.time for e in hits(events, "P")])
    period = 2 * math.pi / 20.0
    assert 0.002 < np.std(gaps) / period < 0.02
    (ideal,), _ = sense(make("sensor_array", omega=20.0, params="  params: {wobble: 0.01}"), 5.0, ideal=True)
    assert np.allclose(np.diff([e.time for e in hits(ideal, "P")]), period, rtol=0, atol=1e-9)


def test_light_turret_scan_peaks_at_the_lights():
    w = make("light", omega=math.pi, params="  params: {samples_per_turn: 120, beam_width: 6}")
    (events,), _ = sense(w, 6.0, ideal=True)
    scans = [e for e in events if e.kind == "scan"]
    assert len(scans) >= 2 and all(len(e.samples) == 120 for e in scans)
    s = np.array(scans[0].samples)
    h0 = w.level.robots[0].start.heading
    sigma = 6 / 2.3548  # deg: a 6 deg full width at half maximum
    for b in "PQRS":
        bearing, d = bearing_from(w, 0, b)
        k = round(((bearing - h0) % (2 * math.pi)) / (2 * math.pi / 120)) % 120
        window = s[[(k - 1) % 120, k, (k + 1) % 120]]
        # the nearest sample is within 1.5 deg of the light: at least exp(-(1.5/sigma)^2/2) of
        # its brightness, which falls as (1 m / d)^2 beyond the 1 m saturation range
        brightest = min(1.0, (1.0 / d) ** 2) * math.exp(-0.5 * (1.5 / sigma) ** 2)
        assert window.min() <= 255 * (1 - brightest) + 1
    assert np.median(s) == 255  # dark elsewhere


def test_light_turret_far_lights_merge_into_one_peak():
    # two lights 10 cm apart seen from 3 m: 1.9 deg apart, inside a 6 deg beam -> one dip
    from arena.loader import parse_level
    from arena.world import World
    text = """
name: merge
description: two close lights
time_limit: 10
control_period: 0.05
field: {size: [4.0, 3.0]}
beacons:
  kind: light
  params: {beam_width: 6}
  items: [{id: A, at: [3.5, 1.45]}, {id: B, at: [3.5, 1.55]}]
laser: {angular_velocity: 3.141592653589793, index: false}
robots: [{model: boe-bot, start: [0.5, 1.5, 0]}]
task: {kind: localize}
default_controller: ref:idle
"""
    (events,), _ = sense(World(parse_level(text.encode(), "m.yaml")), 5.0, ideal=True)
    s = np.array([e for e in events if e.kind == "scan"][0].samples)
    dips = np.nonzero((s < 250) & (s <= np.roll(s, 1)) & (s <= np.roll(s, -1)))[0]
    assert len(dips) == 1


def test_ideal_mode_same_events_for_any_seed():
    params = "  params: {timing_noise: 1.0e-4, merge_rate: 0.1, wobble: 0.01}"
    a, _ = sense(make("sensor_array", params=params), 2.0, ideal=True, seed=1)
    b, _ = sense(make("sensor_array", params=params), 2.0, ideal=True, seed=2)
    c, _ = sense(make("sensor_array", params=params), 2.0, ideal=False, seed=1)
    d, _ = sense(make("sensor_array", params=params), 2.0, ideal=False, seed=2)
    assert a == b and c != d
