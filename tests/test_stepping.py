"""A run of physics steps in one compiled loop (`World.run`, arena.stepping) against the
plain way, `World.step` a step at a time: the same states bit for bit, the same drive state,
the same contacts at the same ticks, the same speeds as pymunk's own `Vec2d.length`, and a
watched run that stops at the step an independent distance test names."""

import math

import numpy as np
import pytest
from helpers import variant

from arena import chipmunk, drive, stepping
from arena.rng import RandomTree
from arena.world import Watch, World

# Four robots packed close, told to drive into one another and the walls, then back out:
# commands come due in the middle of runs (the link's latency), and contacts begin and end.
LEVEL = variant(
    "asabe-race",
    robots__0__start=[0.30, 0.25, 0],
    robots__1__start=[0.50, 0.25, 180],  # degrees
    robots__2__start=[0.40, 0.45, -90],
    robots__3__start=[0.15, 0.12, 225],
)
PLAN = [(0.3, 0.3), (0.25, -0.05), (-0.2, -0.3), (0.3, 0.1), (0.0, 0.0), (0.1, 0.1)]


def commands(world: World, period: int) -> None:
    for slot in range(4):
        left, right = PLAN[(period + slot) % len(PLAN)]
        world.command(slot, left, right)


def stepwise(world: World, steps: int) -> tuple[np.ndarray, list]:
    states, speeds = [], []
    for _ in range(steps):
        world.step()
        states.append(world.state)
        speeds.append(tuple(b.velocity.length for b in world.bodies))
    return np.array(states), speeds


def drives(world: World) -> list:
    return [(d.row.tolist(), list(d._queue)) for d in world.drives]


def touching(world: World) -> list:
    """The contacts going on: when each began, the robot, where, the impulse."""
    return sorted((tick, a.slot, point, impulse) for tick, a, _, point, impulse in world._touching.values())


def test_the_layout_is_checked_and_found_on_this_pymunk():
    assert chipmunk.body_layout() == chipmunk.LAYOUT


@pytest.mark.parametrize("errors", [True, False], ids=["drive errors", "ideal"])
def test_a_compiled_run_gives_what_step_by_step_gives(errors):
    plain, compiled = (World(LEVEL, RandomTree(7) if errors else None) for _ in range(2))
    for period in range(40):
        commands(plain, period)
        commands(compiled, period)
        want, want_speeds = stepwise(plain, LEVEL.steps_per_control)
        got, got_speeds = compiled.run(LEVEL.steps_per_control, speeds=True)
        assert got.tobytes() == want.tobytes(), f"period {period}"
        assert got_speeds == want_speeds
        assert compiled.state == plain.state and compiled.tick == plain.tick
        assert drives(compiled) == drives(plain)
    assert len(plain.contacts) >= 6  # robots met each other and the walls, and parted again
    assert {c.other for c in plain.contacts} >= {"robot", "wall"}
    assert compiled.contacts == plain.contacts and compiled.contact_ends == plain.contact_ends
    assert touching(compiled) == touching(plain)


def test_without_the_layout_the_run_steps_in_python(monkeypatch):
    monkeypatch.setattr(chipmunk, "body_layout", lambda: None)
    monkeypatch.setattr(stepping, "run_steps", None)  # not reached
    plain, fallback = World(LEVEL, RandomTree(3)), World(LEVEL, RandomTree(3))
    for period in range(10):
        commands(plain, period)
        commands(fallback, period)
        want, want_speeds = stepwise(plain, LEVEL.steps_per_control)
        got, got_speeds = fallback.run(LEVEL.steps_per_control, speeds=True)
        assert got.tobytes() == want.tobytes() and got_speeds == want_speeds
    assert fallback.contacts == plain.contacts


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_a_watched_run_stops_after_the_first_step_near_a_point(monkeypatch, compiled):
    if not compiled:
        monkeypatch.setattr(chipmunk, "body_layout", lambda: None)
    world, probe = World(LEVEL, None), World(LEVEL, None)
    world.command(0, 0.2, 0.2)  # robot 0 drives straight along +x from (0.30, 0.25)
    probe.command(0, 0.2, 0.2)
    path, _ = stepwise(probe, 400)
    goal, radius = (0.45, 0.25), 0.01
    first = next(i for i, s in enumerate(path) if math.dist(s[0:2], goal) <= radius)
    assert 50 < first < 350
    got, speeds = world.run(400, watch=Watch(((2, 9.0, 9.0), (0, *goal)), radius * radius))
    assert len(got) == first + 1 and world.tick == first + 1 and speeds is None
    assert got.tobytes() == path[: first + 1].tobytes()


def test_ramp_is_pythons_min_and_max():
    """The compiled ramp moves by at most the step as Python's `min` and `max` would, to the
    sign of a zero and through NaNs and infinities."""
    values = [-0.3, -0.1, -0.0, 0.0, 1e-17, 0.05, 0.1, 0.3, math.inf, -math.inf, math.nan]
    for current in values:
        for target in values:
            for step in (0.0, 1e-3, 0.2, math.inf):
                want, got = current + max(-step, min(step, target - current)), drive.ramp(current, target, step)
                assert (
                    math.isnan(want)
                    and math.isnan(got)
                    or (want, math.copysign(1, want))
                    == (
                        got,
                        math.copysign(1, got),
                    )
                ), (current, target, step)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_a_run_stops_at_its_watch_on_the_step_before_a_command_comes_due(monkeypatch, compiled):
    """The loop stops where a command comes due; a watched robot that arrives on that very
    step must still stop the run there."""
    if not compiled:
        monkeypatch.setattr(chipmunk, "body_layout", lambda: None)
    world, probe = World(LEVEL, RandomTree(5)), World(LEVEL, RandomTree(5))
    for w in (world, probe):
        w.command(0, 0.2, 0.2)
        w.run(60)  # under way (the first run also settles the bodies pymunk added)
        w.command(0, 0.25, 0.25)
    due = probe.drives[0]._queue[-1][0]
    assert due > probe.tick + 2  # the link's latency puts it a few steps ahead
    while probe.tick < due:
        probe.step()
    goal = probe.state[0:2]  # where robot 0 stands after the step that ends at the due tick
    got, _ = world.run(40, watch=Watch(((0, *goal),), 1e-18))
    assert world.tick == due and len(got) == due - 60
    assert world.state == probe.state


def test_a_turn_waiting_when_a_run_stops_early_is_taken_later_as_steps_take_it():
    """A compiled run works out what a command does (a turn's slip is a random draw) before
    the command comes due. A run its watch stops before then leaves the command waiting, worked
    out once: the runs after it give what stepping gives, bit for bit, and so do the draws of
    the turns after it."""
    world, probe = World(LEVEL, RandomTree(5)), World(LEVEL, RandomTree(5))
    for w in (world, probe):
        w.command(0, 0.2, 0.2)
        w.run(60)
        w.command(0, 0.1, 0.3)  # a turn, due a few steps on
        w.command(1, 0.3, -0.1)
    due = probe.drives[0]._queue[-1][0]
    assert due > probe.tick + 2
    while probe.tick < due - 1:
        probe.step()
    goal = probe.state[0:2]  # where robot 0 stands two steps before its turn comes due
    world.run(40, watch=Watch(((0, *goal),), 1e-18))
    assert world.tick == due - 1 and world.drives[0]._queue[0][3]  # stopped, the turn worked out and waiting
    for period in range(12):
        want, _ = stepwise(probe, LEVEL.steps_per_control)
        got, _ = world.run(LEVEL.steps_per_control)
        assert got.tobytes() == want.tobytes(), f"period {period}"
        assert drives(world) == drives(probe)
        commands(world, period)
        commands(probe, period)
    assert world.drives[0].turn_factor != 1.0  # the turns did slip


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_what_a_contact_callback_raises_comes_after_the_step(monkeypatch, compiled):
    """An exception in a contact callback (an interrupt landing there) is raised once
    chipmunk's step returns, not printed and lost; the world is left as the steps made it."""
    if not compiled:
        monkeypatch.setattr(chipmunk, "body_layout", lambda: None)
    world = World(LEVEL, None)
    world.run(2)

    def interrupted(self):
        raise KeyboardInterrupt

    monkeypatch.setattr(World, "_ticking", interrupted)  # called at a contact's first touch
    for slot in range(4):
        world.command(slot, 0.3, 0.3)
    with pytest.raises(KeyboardInterrupt):
        for _ in range(20):
            world.run(LEVEL.steps_per_control)
    assert 2 < world.tick < 2 + 20 * LEVEL.steps_per_control
    poses = [(b.position.x, b.position.y, b.angle) for b in world.bodies]
    assert world.state == tuple(v for p in poses for v in p)
    assert not world.space._locked and not world._compiled


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_a_run_of_no_robot_or_negative_steps_is_refused(monkeypatch, compiled):
    if not compiled:
        monkeypatch.setattr(chipmunk, "body_layout", lambda: None)
    world = World(LEVEL, None)
    world.run(2)
    with pytest.raises(ValueError):
        world.run(10, watch=Watch(((4, 0.0, 0.0),), 1.0))  # four robots: slots 0 to 3
    with pytest.raises(ValueError):
        world.run(-1)
    assert world.tick == 2
    got, _ = world.run(0)
    assert got.shape == (0, 12) and world.tick == 2


@pytest.mark.parametrize("compiled", [True, False], ids=["World.run", "World.step"])
def test_contacts_ending_in_one_step_have_one_order(monkeypatch, compiled):
    # a robot driven square into a corner touches both walls at once and leaves both at once;
    # chipmunk reports such ends in an order that follows its shapes' addresses, which differ
    # from one process to the next: reversing that order must change nothing
    level = variant(
        "asabe-race",
        robots=[{"start": [0.15, 0.15, 225], "start_known": True, "path": [[1.0, 0.5]]}],
        task={"kind": "waypoints", "radius": 0.05},
    )

    def contacts() -> list:
        world = World(level, None)
        for period in range(20):
            v = 0.2 if period < 8 else -0.2
            world.command(0, v, v)
            if compiled:
                world.run(level.steps_per_control)
            else:
                for _ in range(level.steps_per_control):
                    world.step()
        return list(zip(world.contact_ends, world.contacts))

    as_reported = contacts()
    finish = World._finish

    def reported_backwards(self, entry, known):  # each new end goes before those of its step
        finish(self, entry, known)
        first = self.contact_ends.index(known)
        self.contact_ends.insert(first, self.contact_ends.pop())
        self.contacts.insert(first, self.contacts.pop())

    monkeypatch.setattr(World, "_finish", reported_backwards)
    assert contacts() == as_reported
    ends = [known for known, _ in as_reported]
    assert len(as_reported) == 2 and ends[0] == ends[1]  # the case holds: two ends in one step
    assert as_reported[0][1].point < as_reported[1][1].point  # same start, same kind: by place


def test_pymunk_private_parts_are_used_in_one_module_only():
    """Every use of pymunk's private parts (its cffi module, a body's or a space's chipmunk
    struct, the space's own step bookkeeping) is in arena/chipmunk.py, beside its probe and its
    public fallback: a pymunk release that changes them is one module's change."""
    import ast
    from pathlib import Path

    private = {"_body", "_space", "_bodies_to_check", "_add_later", "_locked", "_removed_shapes", "_chipmunk"}
    root = Path(chipmunk.__file__).resolve().parent.parent
    found = []
    for package in ("levels", "arena", "referee", "robots"):
        for f in (root / package).rglob("*.py"):
            if f == Path(chipmunk.__file__).resolve():
                continue
            for node in ast.walk(ast.parse(f.read_text())):
                if isinstance(node, ast.Attribute) and node.attr in private:
                    found.append(f"{f.relative_to(root)}:{node.lineno} .{node.attr}")
                if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pymunk._"):
                    found.append(f"{f.relative_to(root)}:{node.lineno} {node.module}")
    assert found == []
