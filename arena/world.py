"""The physical world of a level: a pymunk space in SI units stepped at a fixed dt.

Update order within one step (fixed, documented in docs/levels.md): each robot's drive in
slot order, then `space.step(dt)`, then the clock.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from operator import itemgetter

import numpy as np
import pymunk

from arena import chipmunk, stepping
from arena.angles import wrap
from arena.drive import ROW, DiffDrive
from arena.rng import RandomTree
from levels.model import Level, Pose

WALL_THICKNESS = 0.02  # m; walls lie just outside the field border

# Collision categories, for shape filters (the laser's occlusion queries use them too).
CAT_WALL, CAT_OBSTACLE, CAT_BEACON, CAT_ROBOT = 1, 2, 4, 8
# Collision types, for contact callbacks; the names are what a contact reports it touched.
KIND_OF_TYPE = {1: "robot", 2: "wall", 3: "obstacle", 4: "beacon"}
TYPE_OF_CATEGORY = {CAT_WALL: 2, CAT_OBSTACLE: 3, CAT_BEACON: 4, CAT_ROBOT: 1}


@dataclass(frozen=True)
class Watch:
    """Where a run of steps may stop early (`World.run`): after a step at which a robot of
    `points` (slot, x, y) stands within sqrt(`near`) metres of its point."""

    points: tuple[tuple[int, float, float], ...]
    near: float


@dataclass(frozen=True)
class Contact:
    """A robot touching something, from first touch to separation: when it began, what it
    touched ("robot" and the other slot, "wall", "obstacle", "beacon"), where, and the
    collision impulse at first touch (N s)."""

    tick: int
    robot: int
    other: str
    other_robot: int | None
    point: tuple[float, float]
    impulse: float


def _within(dx: float, dy: float, near: float) -> bool:
    """An offset no longer than sqrt(`near`), as `arena.stepping` computes it."""
    return dx * dx + dy * dy <= near


def _deferring(callback: Callable[..., None]) -> Callable[..., None]:
    """A contact callback whose exception (a bug, or an interrupt that lands in it) is kept
    and raised when chipmunk's step has returned (`_raise_deferred`): raised in the
    callback, cffi would print it and go on."""

    @functools.wraps(callback)
    def deferring(self: World, *args: object) -> None:
        try:
            callback(self, *args)
        except BaseException as e:  # kept, and raised after the step
            if self._deferred is None:
                self._deferred = e

    return deferring


_NO_POINTS, _NO_CHANGES = np.zeros((0, 3)), np.zeros((0, 5))  # a run's watch points, servo changes: none


class World:
    """Walls, obstacles, beacons and robots of one level, and their differential drives.
    With the match's random tree each drive has its robot's errors; without one (ideal mode)
    every drive is perfect. Robots stand at `starts` (arena.placement draws them), else at
    the level's nominal starts."""

    def __init__(self, level: Level, rng: RandomTree | None = None, starts: tuple[Pose, ...] | None = None):
        self.level = level
        self.dt = level.dt
        self.tick = 0
        self.space = pymunk.Space()
        self.space.gravity = (0, 0)
        self.space.iterations = 20
        if level.field.walls:
            self._add_walls()
        for ob in level.obstacles:
            solid: pymunk.Shape
            if ob.kind == "circle":
                solid = pymunk.Circle(self.space.static_body, ob.radius, ob.points[0])
            else:
                solid = pymunk.Poly(self.space.static_body, ob.points)
            self._static(solid, CAT_OBSTACLE)
        self.beacon_shapes = []
        for b in level.beacons.items:
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
            body.position = (b.x, b.y)
            disc = pymunk.Circle(body, level.beacons.radius)
            self.space.add(body)
            self._static(disc, CAT_BEACON)
            self.beacon_shapes.append(disc)
        self.bodies: list[pymunk.Body] = []
        self.shapes: list[pymunk.Poly] = []
        self.drives: list[DiffDrive] = []
        self._drive_table = np.zeros((len(level.robots), ROW))  # every drive's row, in slot order
        for r in level.robots:
            m = r.model
            start = r.start if starts is None else starts[r.slot]
            body = pymunk.Body(m.mass, pymunk.moment_for_box(m.mass, (m.length, m.width)))
            body.position = (start.x, start.y)
            body.angle = start.heading
            shape = pymunk.Poly.create_box(body, (m.length, m.width))
            shape.friction = 0.4
            shape.elasticity = 0.1
            shape.filter = pymunk.ShapeFilter(group=r.slot + 1, categories=CAT_ROBOT)
            self.space.add(body, shape)
            self.bodies.append(body)
            self.shapes.append(shape)
            self.drives.append(DiffDrive(self.space, body, m, level.dt, rng, r.slot, self._drive_table[r.slot]))
            shape.collision_type = 1
            shape.slot = r.slot
        self.state = self._read_state()
        self._addresses: tuple[int, int, np.ndarray, np.ndarray, np.ndarray] | None = None  # for compiled runs
        self._clock = np.zeros(1, np.int64)  # the tick of the step a compiled run is taking
        self._compiled = False  # a compiled run is under way (the contact callbacks read `_clock`)
        self._deferred: BaseException | None = None  # raised in a contact callback, raised after the step
        self.contacts: list[Contact] = []  # finished contacts, in order of their end
        self.contact_ends: list[int] = []  # the tick after which each finished contact was known
        self._touching: dict[tuple[int, int], list] = {}
        for other_type in KIND_OF_TYPE:
            self.space.on_collision(1, other_type, begin=self._begin, separate=self._separate)

    def _raise_deferred(self) -> None:
        """Raise what a contact callback raised during the last step, if anything."""
        if self._deferred is not None:
            e, self._deferred = self._deferred, None
            raise e

    @_deferring
    def _begin(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        """First touch: the collision impulse is what it takes to stop the approach along the
        contact normal, reduced mass x closing speed x (1 + restitution). Measured once here,
        so no Python callback runs on every step of a long contact."""
        a, b = arbiter.shapes
        assert a.body is not None and b.body is not None  # shapes in a space are attached to bodies
        cps = arbiter.contact_point_set
        point = tuple(cps.points[0].point_a) if cps.points else tuple(a.body.position)
        ma = a.body.mass
        mb = b.body.mass if b.body.body_type == pymunk.Body.DYNAMIC else math.inf
        reduced = ma if mb == math.inf else ma * mb / (ma + mb)
        closing = (a.body.velocity - b.body.velocity).dot(cps.normal)
        impulse = reduced * abs(closing) * (1 + arbiter.restitution)
        self._touching[(id(a), id(b))] = [self._ticking() + 1, a, b, point, impulse]

    @_deferring
    def _separate(self, arbiter: pymunk.Arbiter, space: pymunk.Space, data: object) -> None:
        a, b = arbiter.shapes
        entry = self._touching.pop((id(a), id(b)), None)
        if entry is not None:
            self._finish(entry, self._ticking() + 1)  # during the step that ends at tick + 1

    def _ticking(self) -> int:
        """The tick at which the step under way began."""
        return int(self._clock[0]) if self._compiled else self.tick

    def _finish(self, entry: list, known: int) -> None:
        tick, a, b, point, impulse = entry
        other = KIND_OF_TYPE[b.collision_type]
        self.contact_ends.append(known)
        self.contacts.append(
            Contact(
                tick,
                a.slot,
                other,
                getattr(b, "slot", None) if other == "robot" else None,
                (float(point[0]), float(point[1])),
                impulse,
            )
        )

    def end_contacts(self) -> None:
        """Close every contact still going on (at the end of a match)."""
        since = len(self.contacts)
        for entry in self._touching.values():
            self._finish(entry, self.tick)
        self._touching.clear()
        self._order_contacts(since)

    def _order_contacts(self, since: int) -> None:
        """Put the contacts that ended since the first `since` in a fixed order: by the tick
        their end was known, then when they began, the robot, what it touched, where and how
        hard. Chipmunk reports contacts ending in one step in the order of a hash of their
        shapes' addresses, which differ from one process to the next."""
        if len(self.contacts) - since < 2:
            return
        ended = sorted(
            zip(self.contact_ends[since:], self.contacts[since:]),
            key=lambda e: (
                e[0],
                e[1].tick,
                e[1].robot,
                e[1].other,
                -1 if e[1].other_robot is None else e[1].other_robot,
                e[1].point,
                e[1].impulse,
            ),
        )
        self.contact_ends[since:] = [known for known, _ in ended]
        self.contacts[since:] = [contact for _, contact in ended]

    def _static(self, shape: pymunk.Shape, category: int) -> None:
        shape.collision_type = TYPE_OF_CATEGORY[category]
        shape.friction = 0.6
        shape.elasticity = 0.1
        shape.filter = pymunk.ShapeFilter(categories=category)
        self.space.add(shape)

    def _add_walls(self) -> None:
        f, r = self.level.field, WALL_THICKNESS / 2
        x0, y0, x1, y1 = f.xmin - r, f.ymin - r, f.xmax + r, f.ymax + r
        for a, b in (((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))):
            self._static(pymunk.Segment(self.space.static_body, a, b, r), CAT_WALL)

    @property
    def time(self) -> float:
        """Simulated time (s), exact as tick / physics rate."""
        return self.tick / self.level.physics_rate

    def command(self, slot: int, left: float, right: float) -> None:
        """Send robot `slot` its wheel speed targets (m/s); they take effect after its link's latency."""
        self.drives[slot].command(left, right, self.tick)

    def _read_state(self) -> tuple[float, ...]:
        return chipmunk.poses(self.bodies)

    def step(self) -> None:
        """Advance the world one physics step. `state` then holds every robot's
        x, y and unwrapped heading, flat, read once per step for the drives and the sensing."""
        for drive, heading in zip(self.drives, self.state[2::3]):
            drive.update(heading, self.tick)
        since = len(self.contacts)
        chipmunk.step(self.space, self.dt)
        self.tick += 1
        self.state = self._read_state()
        if len(self.contacts) > since + 1:  # several ended in this step (checked here: bare stepping's cost)
            self._order_contacts(since)
        if self._deferred is not None:
            self._raise_deferred()

    def run(
        self, steps: int, speeds: bool = False, watch: Watch | None = None
    ) -> tuple[np.ndarray, list[tuple[float, ...]] | None]:
        """Advance `steps` physics steps, or fewer: stop after a step at which a robot of
        `watch` stands near its point. Return the `state` after each step, a row each, and (if
        `speeds`) every robot's speed (m/s) then: what a control period's checks read, all at
        once (referee.match.loop). The steps run compiled (`arena.stepping`) where this
        process's chipmunk allows, with the numbers `step` gives."""
        n = len(self.bodies)
        if steps < 0:
            raise ValueError(f"a run of {steps} steps")
        for slot, _, _ in watch.points if watch else ():
            if not 0 <= slot < n:
                raise ValueError(f"a watch on robot {slot} of a world of {n}")
        layout = chipmunk.body_layout()
        space = self.space
        if layout is None or not chipmunk.settled(space):
            return self._run_stepwise(steps, speeds, watch)
        if self._addresses is None:  # fixed for the world's life: found once
            self._addresses = (
                chipmunk.step_function(),
                chipmunk.address(space),
                np.array([chipmunk.address(b) for b in self.bodies], np.int64),
                np.array([chipmunk.address(d.control) for d in self.drives], np.int64),
                np.array(layout, np.int64),
            )
        function, space_address, bodies, controls, places = self._addresses
        states = np.empty((steps, 3 * n))
        velocities = np.empty((steps if speeds else 0, 2 * n))
        points = (
            np.array([(3 * slot, x, y) for slot, x, y in watch.points], float).reshape(-1, 3) if watch else _NO_POINTS
        )
        near = watch.near if watch else 0.0
        done, since = 0, len(self.contacts)
        self._clock[0], self._compiled = self.tick, True
        try:
            with chipmunk.locked(space):  # callbacks must not add or remove shapes meanwhile
                changes = self._changes(self.tick + steps)
                table = self._drive_table  # each drive's row: the run updates them in place
                ran = 0
                try:
                    ran = stepping.run_steps(
                        function,
                        space_address,
                        self.dt,
                        bodies,
                        controls,
                        table,
                        places,
                        changes,
                        self.tick,
                        self._clock,
                        points,
                        near,
                        states,
                        velocities,
                    )
                finally:  # what the steps did stays told, whatever is raised after them
                    done = abs(ran)
                    self.tick += done
                    for drive in self.drives:
                        drive.take_due(self.tick - 1)  # what the run applied, taken
                self._raise_deferred()
        finally:
            self._compiled = False
            self._order_contacts(since)
            if done:
                self.state = tuple(states[done - 1].tolist())
        states = states[:done]
        moving = None
        if speeds:
            moving = [
                tuple(math.sqrt(x**2 + y**2) for x, y in zip(row[0::2], row[1::2]))  # as pymunk's Vec2d.length
                for row in velocities[:done].tolist()
            ]
        return states, moving

    def _changes(self, until: int) -> np.ndarray:
        """Every drive's servo changes due before tick `until` (`DiffDrive.changes`, its slot
        after its tick), in order of their ticks, a row each: a drive's own stay in command order."""
        rows = [(due, slot, *rest) for slot, drive in enumerate(self.drives) for due, *rest in drive.changes(until)]
        if not rows:
            return _NO_CHANGES
        rows.sort(key=itemgetter(0))  # stable
        return np.array(rows, float)

    def _run_stepwise(
        self, steps: int, speeds: bool, watch: Watch | None
    ) -> tuple[np.ndarray, list[tuple[float, ...]] | None]:
        """`run`, a `step` at a time in Python."""
        states: list[tuple[float, ...]] = []
        moving: list[tuple[float, ...]] = []
        points = [(3 * slot, x, y) for slot, x, y in watch.points] if watch else []
        near = watch.near if watch else 0.0
        for _ in range(steps):
            self.step()
            state = self.state
            states.append(state)
            if speeds:
                moving.append(tuple(body.velocity.length for body in self.bodies))
            if any(_within(state[i] - x, state[i + 1] - y, near) for i, x, y in points):
                break
        return np.array(states, float).reshape(-1, 3 * len(self.bodies)), moving if speeds else None

    def place(self, slot: int, pose: Pose) -> None:
        """Carry robot `slot` to `pose` and set it down at rest, its wheels stopped and any
        command still on its way dropped (a trial's new pose: docs/rules.md)."""
        body = self.bodies[slot]
        body.position = (pose.x, pose.y)
        body.angle = pose.heading
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        self.space.reindex_shapes_for_body(body)
        self.drives[slot].halt()
        self.state = self._read_state()

    def pose(self, slot: int) -> Pose:
        """The true pose of robot `slot`, heading wrapped to (-pi, pi]."""
        x, y, h = self.state[3 * slot : 3 * slot + 3]
        return Pose(x, y, wrap(h))
