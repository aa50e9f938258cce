"""Sensing.flush hands each robot its events in event order (time, then kind, beacon and
source) while sorting only where its sources could break that order: checked against the
plain sort of the same events, on batches built to hold ties and mixed sources."""

import pytest
from helpers import exact_starts, variant

from arena.rng import RandomTree
from arena.sensing.events import event_order
from arena.sensing.pipeline import Sensing
from arena.world import World

CASES = {
    # every revolution merges a pulse: merged pulses share their predecessor's time
    "merged": ("asabe-race", {"beacons__params__merge_rate": 1.0}),
    # every robot sees every pulse, and false pulses come with them
    "shared": ("asabe-race", {"beacons__crosstalk": "shared", "beacons__params__false_rate": 30.0}),
    # unlabelled returns, false returns and index clicks in one batch
    "reflector": ("vannoy", {"beacons__params__false_rate": 30.0}),
    "quantized": ("ubersetzig", {"beacons__params__false_rate": 30.0}),
    "flash": ("simi", {}),
    "light": ("osentoski", {}),
}


def batches(name: str, changes: dict, seconds: float = 4.0) -> list[list[list]]:
    level = variant(name, f"levels/{name}.yaml", **changes)
    world = World(level)
    sensing = Sensing(world, RandomTree(4))
    for slot in range(len(level.robots)):
        world.command(slot, 0.05 + 0.02 * slot, 0.12)
    out = []
    for k in range(round(seconds * level.physics_rate)):
        world.step()
        sensing.record()
        if (k + 1) % level.steps_per_control == 0:
            out.append(sensing.flush())
    return out


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_robot_gets_its_events_in_event_order(case):
    name, changes = CASES[case]
    ties = mixed = events_seen = 0
    for batch in batches(name, changes):
        for events in batch:
            assert events == sorted(events, key=event_order)
            events_seen += len(events)
            ties += sum(a.time == b.time for a, b in zip(events, events[1:]))
            mixed += len({(e.kind, e.source == -1) for e in events}) > 1
    assert events_seen
    if case == "merged":
        assert ties  # the sort of tied hits ran
    if case in ("shared", "reflector", "quantized"):
        assert mixed  # batches mixed hits with false returns or index clicks


def test_a_turret_scan_after_a_move_holds_no_sample_from_before_it():
    # osentoski's turret turns once in 2 s; the robot is carried 0.5 s into a turn: the first
    # scan after the move must be a whole turn sensed where it now stands, so it ends at least
    # a turn after the move
    from levels.model import Pose

    level = variant("osentoski", "levels/osentoski.yaml", **exact_starts("osentoski"))
    world = World(level)
    sensing = Sensing(world, RandomTree(4))
    period = level.robots[0].laser.period
    control = level.steps_per_control
    moved_at, first_after = None, None
    for k in range(round(3 * period * level.physics_rate)):
        world.step()
        sensing.record()
        if (k + 1) % control:
            continue
        scans = [e for e in sensing.flush()[0] if e.kind == "scan"]
        if moved_at is not None and scans and first_after is None:
            first_after = scans[0].time
        if moved_at is None and world.time >= period + 0.5:
            world.place(0, Pose(1.8, 0.5, 1.0))
            sensing.moved()
            moved_at = world.time
    assert moved_at is not None and first_after is not None
    assert first_after >= moved_at + period - 1e-6
