"""Sensing.flush hands each robot its events in event order (time, then kind, beacon and
source) while sorting only where its sources could break that order: checked against the
plain sort of the same events, on batches built to hold ties and mixed sources."""

import pytest
from helpers import variant

from arena.rng import RandomTree
from arena.sensing import Sensing, event_order
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
