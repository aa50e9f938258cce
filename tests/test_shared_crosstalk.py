"""Shared crosstalk, Bac's own arrays: every array latches every robot's pulse. What the arrays
report (one line per array, so a sweep while another laser holds it low is lost; every
controller hears every pulse), and how a robot tells its own pulses from the others' by when
they come (robots.toolkit: `one_laser`, the HitTracker), down to a short race that all finish."""

import math

import pytest
from helpers import ARRAYS, table_brief, variant

from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.world import World
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots.api import SensorEvent, StartInfo
from robots.toolkit.associate import one_laser
from robots.toolkit.tracker import HitTracker

OMEGA = 81.0
PERIOD = 2 * math.pi / OMEGA
OWN, OTHERS = (0.7, 0.5, 0.3), [(1.2, 0.8, 2.0), (0.4, 0.9, 4.4), (1.4, 0.35, 5.5)]


def laser_pulses(x: float, y: float, beam0: float, seconds: float) -> list[SensorEvent]:
    """Exact pulse times of a standing laser whose beam points at world angle beam0 at t = 0."""
    out = []
    for k in range(int(seconds / PERIOD) + 1):
        for b, (bx, by) in ARRAYS.items():
            t = (math.atan2(by - y, bx - x) - beam0) % (2 * math.pi) / OMEGA + k * PERIOD
            if t < seconds:
                out.append(SensorEvent(t, "hit", b))
    return sorted(out, key=lambda e: e.time)


def feed(tracker: HitTracker, events: list[SensorEvent], seconds: float) -> None:
    """Give the tracker the events control period by control period, as the referee does."""
    events = sorted(events, key=lambda e: e.time)
    for k in range(round(seconds / 0.2)):
        now = 0.2 * (k + 1)
        tracker.feed([e for e in events if now - 0.2 < e.time <= now], now)


# ---- what the arrays report -----------------------------------------------------------------


def shared_sensing(**changes) -> tuple[World, Sensing]:
    world = World(variant("asabe-race-shared", "levels/asabe-race-shared.yaml", **changes))
    return world, Sensing(world, RandomTree(4))


def test_a_sweep_while_another_laser_holds_the_line_low_makes_no_flank():
    # one comparator per array: the first sweep pulls the line low for its 50 us, the second
    # lands inside that and is lost; a sweep of another array, or after the line let go, is kept
    _, sensing = shared_sensing()
    kept = sensing.lines.flanks([1.0, 1.00002, 1.00001, 1.0001], [0, 0, 1, 0], [5e-5] * 4)
    assert kept == [True, False, True, True]
    # the line is still low at the start of the next batch
    assert sensing.lines.flanks([1.00013, 1.0002], [0, 0], [5e-5, 5e-5]) == [False, True]


def test_every_controller_hears_every_pulse_and_the_same_false_pulses():
    world, sensing = shared_sensing(beacons__params__false_rate=30.0)
    for slot in range(4):
        world.command(slot, 0.05 + 0.02 * slot, 0.12)
    false = 0
    for k in range(2 * 240):
        world.step()
        sensing.record()
        if (k + 1) % world.level.steps_per_control == 0:
            heard = [[(d.time, d.beacon, d.source) for d in events] for events in sensing.flush()]
            assert all(h == heard[0] for h in heard)  # what the arrays latched, for everyone
            assert {s for _, _, s in heard[0]} >= {0, 1, 2, 3}
            false += sum(s == -1 for _, _, s in heard[0])
    assert false > 20  # 30 per s for the table, not per robot


# ---- telling one's own pulses by when they come -----------------------------------------------


def test_one_laser_picks_out_the_pulses_of_the_laser_near_the_prior():
    own = laser_pulses(*OWN, 3 * PERIOD)
    everyone = sorted(own + [e for o in OTHERS for e in laser_pulses(*o, 3 * PERIOD)], key=lambda e: e.time)
    last = own[-1].time
    hits = [(e.time, e.beacon) for e in everyone if e.time <= last]
    sets = one_laser(hits, ARRAYS, prior=(0.71, 0.49), radius=0.02, rate=OMEGA)
    assert sets[0] == [(e.time, e.beacon) for e in own[-4:]]  # the last turn of its own, all four
    assert all(len(s) < 4 for s in sets[1:])


def test_tracker_takes_its_own_pulses_and_leaves_the_others():
    # announced within 1 cm, any heading: it notices the other lasers, starts from its own turn
    # and from then on takes no pulse of theirs
    tracker = HitTracker(table_brief(StartInfo(0.705, 0.495, 0.0, position_spread=0.01, heading_spread=math.pi)))
    own = laser_pulses(*OWN, 2.0)
    others = [e for o in OTHERS for e in laser_pulses(*o, 2.0)]
    feed(tracker, own + others, 2.0)
    assert tracker.crowded and tracker.pose is not None
    assert math.dist(tracker.pose[:2], OWN[:2]) < 1e-3
    assert tracker.recent and {t for t, _ in tracker.recent} <= {e.time for e in own}


def test_a_pulse_of_another_laser_where_its_own_is_due_is_refused():
    tracker = HitTracker(table_brief(StartInfo(0.705, 0.495, 0.0, position_spread=0.01, heading_spread=math.pi)))
    own = laser_pulses(*OWN, 2.0)
    others = [e for o in OTHERS for e in laser_pulses(*o, 2.0)]
    feed(tracker, own + others, 1.0)
    # the next turn, its own laser is hidden from A and another laser's pulse reaches A 0.3 ms
    # (0.024 rad) late: that is 3 sd and more off where its own is due, so it is not taken
    due = next(e for e in own if e.time > 1.0 and e.beacon == "A")
    rest = [e for e in own + others if 1.0 < e.time <= 1.2 and e is not due]
    tracker.feed(sorted([*rest, SensorEvent(due.time + 3e-4, "hit", "A")], key=lambda e: e.time), 1.2)
    assert (due.time + 3e-4, "A") not in tracker.recent
    assert {t for t, _ in tracker.recent} <= {e.time for e in own}  # its own pulses of that turn were taken
    assert math.dist(tracker.pose[:2], OWN[:2]) < 1e-3


def test_a_lone_laser_never_counts_as_crowded():
    # one laser and a few false pulses, as on a single-robot level: the tracker stays as it was
    tracker = HitTracker(table_brief(StartInfo(0.705, 0.495, 0.0, position_spread=0.01, heading_spread=math.pi)))
    false = [SensorEvent(t, "hit", b) for t, b in ((0.31, "A"), (1.05, "B"), (1.9, "C"))]
    feed(tracker, laser_pulses(*OWN, 3.0) + false, 3.0)
    assert not tracker.crowded and tracker.pose is not None
    assert math.dist(tracker.pose[:2], OWN[:2]) < 1e-3


# ---- a race on the shared arrays ---------------------------------------------------------------


@pytest.mark.parametrize("seed", [1, 2])
def test_a_short_shared_race_every_robot_finishes(seed):
    # each robot's first leg and turn only: four ref:bac robots find their own pulses among the
    # others' from a start they must find the heading of, and drive on them
    short = {f"robots__{i}__path": path[:2] for i, path in enumerate(race_paths())}
    level = variant("asabe-race-shared", "short-shared.yaml", time_limit=30, **short)
    result = play_match(level, [resolve("ref:bac")] * 4, seed=seed, isolate=False)
    for r in result.robots:
        assert r.task.reached == r.task.total == 2, r
        assert r.localization.position_rms is not None and r.localization.position_rms < 0.02, r


def race_paths() -> list[list[list[float]]]:
    import yaml

    import levels

    return [r["path"] for r in yaml.safe_load(levels.path("asabe-race-shared").read_text())["robots"]]
