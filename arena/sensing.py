"""Sensing: every robot's spinning laser against the level's beacons, batch by batch.

`record()` runs after every physics step and only stores each robot's pose (cheap);
`flush()` runs at each control tick and turns the steps since the last tick into
detections, all at once (compiled loops, arena.kernels): laser phases (with speed wobble and the lag when the
body turns), where each beam leaves (the body's position, leaned by the floor's tilt: arena.floor),
exact crossing times (arena.laser), occlusion by other robots' silhouettes at
the crossing instant and by obstacles, the detector model of the level's beacon kind (its
optics set when each pulse fires, or whether it does), index clicks, and the random errors.
"""

from __future__ import annotations

import math
from functools import partial
from itertools import chain, repeat
from types import SimpleNamespace
from typing import cast

import numpy as np
import pymunk

from arena import detectors as det
from arena import floor, kernels
from arena.angles import TWO_PI, wrap_angle
from arena.laser import Crossings, Trajectory, find_crossings, find_phase_marks
from arena.rng import RandomTree
from arena.world import CAT_OBSTACLE, World

_NONE, _NO_ROWS = np.zeros(0), np.zeros((0, 0))  # a kernel's array argument that is not there

# a Detection from a tuple of all its fields in order, with no Python call per event
NEW_DETECTION = partial(tuple.__new__, det.Detection)


def event_order(d: det.Detection) -> tuple:
    """The order of one controller's events: by time, then kind, beacon and source."""
    return (d.time, d.kind, d.beacon or "", d.source)


class Sensing:
    """The lasers and beacon hardware of one match."""

    def __init__(self, world: World, rng: RandomTree, ideal: bool = False):
        level = world.level
        self.world = world
        self.ideal = ideal
        self.kind = level.beacons.kind
        self.params = det.effective_params(level.beacons.params, ideal)
        self.crosstalk = level.beacons.crosstalk
        items = level.beacons.items
        self.ids = [b.id for b in items]
        # where the detectors really are: the map's coordinates, off by the surveying error
        # (uniform in a disc of radius `placement_error`, drawn once per match)
        g = rng.stream("beacons", "placement")
        spread = self.params.get("placement_error", 0.0) * np.sqrt(g.random(len(items)))
        angle = TWO_PI * g.random(len(items))
        self.bx = np.array([b.x for b in items]) + spread * np.cos(angle)
        self.by = np.array([b.y for b in items]) + spread * np.sin(angle)
        self.facing = np.array([b.facing for b in items])
        # each detector's response relative to the nominal one (Bac's hand-trimmed arrays); none when ideal
        gains = np.array([b.gain for b in items])
        self.gain = None if ideal or (gains == 1.0).all() else gains
        self.beacon_radius = level.beacons.radius
        robots = level.robots
        self.n = len(robots)
        self.omega = np.array([r.laser.angular_velocity for r in robots])
        self.beam_offset = np.array([0.0 if ideal else r.laser.beam_offset for r in robots])
        self._offsets = self.beam_offset if self.beam_offset.any() else None  # None: every beam on its axis
        self.direction = np.sign(self.omega)
        # a tilted floor leans each robot: its beam leaves `laser.height` above its base, off it
        height = np.array([r.laser.height for r in robots])
        self.tilt = floor.tilt(level.floor, rng, ideal) if height.any() else None
        self.height = height
        self.index = np.array([r.laser.index for r in robots])
        self._any_index = bool(self.index.any())
        # what each robot puts in the laser plane: a circle at its centre (mast, laser housing)
        self.silhouette = np.array([r.model.silhouette_radius for r in robots])
        # how far that circle can reach from the robot's centre at a batch start, within a batch
        batch = level.control_period
        self.reach = self.silhouette + np.array([2 * r.model.max_wheel_speed * batch for r in robots])
        self.has_obstacles = bool(level.obstacles)
        self.obstacle_filter = pymunk.ShapeFilter(mask=CAT_OBSTACLE)
        self.dt = world.dt
        self.rng = {
            name: [rng.stream("robot", r, name) for r in range(self.n)]
            for name in ("wobble", "detector", "timing", "false", "light")
        }
        self.merge_key = int(rng.stream("beacons", "merge").integers(1 << 62))
        # shared crosstalk: when each array's one line is next free to make a flank (`_flanks`),
        # and the table's false pulses, one stream for every controller
        self.line_low_until = [-math.inf] * len(items)
        self.table_false = rng.stream("beacons", "false")
        p = self.params
        self._light_noise = float(p.get("light_noise", 0.0)) if p.get("light_noise", 0.0) > 0 else 0.0
        self._timing_noise = p["timing_noise"] if p.get("timing_noise", 0.0) > 0 else 0.0
        self._clock_hz = float(p.get("clock_hz", 0.0))
        # Bac's merged measurements (arena.kernels.merge), as kernels.pulses takes them
        merges = (self.kind == "sensor_array", float(p.get("merge_rate", 0.0)))
        self._merging = (merges[0], self.direction, len(self.ids), merges[1], np.uint64(self.merge_key))
        self.wobble = np.zeros(self.n)
        self.spin_lag = np.zeros(self.n)  # the laser's relative rate minus its steady value (rad/s)
        self.body_rate = np.zeros(self.n)  # the body's yaw rate in the last step (rad/s)
        self.phi = np.zeros(self.n)  # unwrapped laser phase; 0 = straight ahead at t = 0
        self.scans: dict[tuple[int, int], np.ndarray] = {}  # (robot, turn) -> light samples
        self._rows: list[tuple | np.ndarray] = []  # a state (`record`) or a run's states (`record_many`)
        self._ramps: dict[int, np.ndarray] = {}  # batch length -> step-end times from its start
        self._powers: dict[tuple[float, tuple], np.ndarray] = {}  # (a, batch shape) -> a^1..a^n per row
        self._last = world.state
        self._last_t = world.time
        if not _loaded:
            _load_kernels(world, ideal)

    def record(self) -> None:
        """Store the robots' poses after a physics step."""
        self._rows.append(self.world.state)

    def record_many(self, states: np.ndarray) -> None:
        """Store the world's states after several physics steps (`World.run`: a row each)."""
        self._rows.append(states)

    def moved(self) -> None:
        """The world's robots were carried to new poses (`World.place`) right after a flush:
        the next batch starts from where they now stand, so no beam sweeps across the move."""
        if self._rows:
            raise RuntimeError("robots may be moved only at a control tick, after the flush")
        self._last = self.world.state
        self.body_rate[:] = 0.0
        self.scans.clear()  # a turret's turn begun before the move is no scan of where it now stands

    def flush(self) -> list[list[det.Detection]]:
        """Detections per robot for the steps recorded since the last flush, in event order
        (`event_order`). Each source of events (hits, false returns, index clicks, scans)
        yields its own events in that order; only a robot that got events from two sources,
        or hits at one time, needs a sort."""
        rows = self._rows
        if not rows:
            return [[] for _ in range(self.n)]
        if all(isinstance(row, tuple) for row in rows):  # one state a step (`record`)
            flat = np.fromiter(chain(self._last, chain.from_iterable(rows)), float, (len(rows) + 1) * 3 * self.n)
        else:  # runs of states (`record_many`), or both
            flat = np.vstack([self._last, *rows])
        poses = flat.reshape(-1, self.n, 3)
        steps = len(poses) - 1
        t = self._last_t + self._ramp(steps)
        t[-1] = self.world.time  # exact at the end, so batches join without drift
        traj = Trajectory(t=t, x=poses[:, :, 0], y=poses[:, :, 1], h=poses[:, :, 2], phi=self._phases(poses[:, :, 2]))
        self._last, self._last_t, self._rows = tuple(poses[-1].ravel().tolist()), self.world.time, []
        self.phi = traj.phi[-1].copy()
        lasers = traj if self.tilt is None else self._leaned(traj)

        sources = [self._light(traj, lasers) if self.kind == "light" else self._hits(traj, lasers)]
        if self.kind in ("reflector", "sensor_array") and self.params["false_rate"] > 0:
            if self.crosstalk == "shared":  # a false pulse is an array's, seen by all
                sources.append(self._to_everyone(self._table_false_pulses(traj)))
            else:
                sources.append([self._false_returns(traj, r) for r in range(self.n)])
        if self._any_index:
            sources.append(self._index(traj))
        out = []
        for r in range(self.n):
            lists = [events[r] for events in sources if events[r]]
            if len(lists) == 1:
                out.append(lists[0])
                continue
            merged = [d for events in lists for d in events]
            merged.sort(key=event_order)  # stable: what the sources yield in order stays so
            out.append(merged)
        return out

    def _leaned(self, traj: Trajectory) -> Trajectory:
        """Where the beams leave, step by step: each body's position, leaned by the floor's tilt
        there (arena.floor); the body itself (`traj`) is what the score and other beams see."""
        assert self.tilt is not None
        dx, dy = self.tilt.lean(traj.x, traj.y, self.height)
        return Trajectory(t=traj.t, x=traj.x + dx, y=traj.y + dy, h=traj.h, phi=traj.phi)

    def _ramp(self, steps: int) -> np.ndarray:
        """Step-end times of a batch of `steps` steps from its start (cached per length)."""
        ramp = self._ramps.get(steps)
        if ramp is None:
            ramp = self._ramps[steps] = np.arange(steps + 1) * self.dt
        return ramp

    # ---- laser phase ---------------------------------------------------------------------

    def _phases(self, heading: np.ndarray) -> np.ndarray:
        """Unwrapped laser phases at the step ends, from the body headings there.

        The spin rate relative to the body wobbles as an Ornstein-Uhlenbeck process (relative
        std `wobble`, correlation time `wobble_time`), and it answers the body's turns (Bac:
        "the laser angular velocity was not constant while the robot turned"): the rotor's
        inertia keeps its rate in the world when the body's yaw rate changes, so the relative
        rate first drops by that change, then the motor brings it back, with time constant
        `spin_time`, to its steady value less `spin_coupling` x the body's yaw rate."""
        steps = len(heading) - 1
        p = self.params
        noise = _NO_ROWS
        wobble = (0.0, 0.0, _NO_ROWS, self.wobble)
        if p["wobble"] > 0:
            a = math.exp(-self.dt / p["wobble_time"])
            noise = np.array([g.normal(size=steps) for g in self.rng["wobble"]]).T
            wobble = (math.sqrt(1 - a * a) * p["wobble"], a, self._powers_of(a, noise.shape), self.wobble)
        spin = (-1.0, 0.0, _NO_ROWS, self.spin_lag, self.body_rate)  # a negative decay: no lag
        if p.get("spin_time", 0.0) > 0:
            a = math.exp(-self.dt / p["spin_time"])
            spin = (a, (1 - a) * p.get("spin_coupling", 0.0), self._powers_of(a, (steps, self.n)), *spin[3:])
        phi, self.wobble, self.spin_lag, self.body_rate = kernels.laser_phases(
            self.omega, self.dt, self.phi, heading, noise, wobble, spin
        )
        return phi

    def _powers_of(self, a: float, shape: tuple[int, int]) -> np.ndarray:
        """a^1..a^steps per row for a batch of `shape` (cached), or none where a^steps
        underflows (kernels.first_order then takes the recursion)."""
        key = (a, shape)
        powers = self._powers.get(key)
        if powers is None:
            if a ** shape[0] < 1e-150:
                powers = _NO_ROWS
            else:
                powers = np.ascontiguousarray(np.broadcast_to(a ** np.arange(1, shape[0] + 1)[:, None], shape))
            self._powers[key] = powers
        return powers

    # ---- occlusion ------------------------------------------------------------------------

    def _blocked(
        self,
        traj: Trajectory,
        robot: np.ndarray,
        step: np.ndarray,
        s: np.ndarray,
        px: np.ndarray,
        py: np.ndarray,
        beacon: np.ndarray,
    ) -> np.ndarray:
        """Whether the segment from each laser to each beacon's near edge is blocked by another
        robot (at that instant) or an obstacle. Walls bound a convex field and never block."""
        blocked, qx, qy = kernels.blocked(
            px, py, self.bx[beacon], self.by[beacon], float(self.beacon_radius), robot, step, s,
            traj.x, traj.y, self.reach, self.silhouette,
        )  # fmt: skip
        if self.has_obstacles:
            space = self.world.space
            for i in np.nonzero(~blocked)[0]:
                first = space.segment_query_first((px[i], py[i]), (qx[i], qy[i]), 0.0, self.obstacle_filter)
                blocked[i] = first is not None
        return blocked

    # ---- beam-beacon hits -----------------------------------------------------------------

    def _hits(self, traj: Trajectory, lasers: Trajectory) -> list[list[det.Detection]]:
        """The beacons' pulses: the crossings of the beams leaving from `lasers`, blocked by the
        bodies of `traj`, through the detector model."""
        out: list[list[det.Detection]] = [[] for _ in range(self.n)]
        c = find_crossings(lasers, self.bx, self.by, self._offsets)
        if not len(c):
            return out
        p = self.params
        keep: np.ndarray | None = ~self._blocked(traj, c.robot, c.step, c.s, c.x, c.y, c.beacon)
        keep &= det.visible(self.kind, c, self.facing, p)
        if self._light_noise and not keep.all():
            c, keep = c.take(np.nonzero(keep)[0]), None  # the light's draws are for these alone
        offset, detected = _NONE, keep
        if self.kind != "reflector" and len(c):  # finite beam and detector widths
            inc = det.incidence(c, self.facing)
            ok, offset = det.optics(c, inc, self._fluctuation(c, det.sensitivity(self.kind, c, inc, p, self.gain)), p)
            detected = ok if keep is None else ok & keep
        if len(offset) != len(c):
            offset = np.zeros(len(c))
        if detected is None:
            detected = np.ones(len(c), dtype=bool)
        if not detected.any():
            return out
        draws = _NONE
        if self._timing_noise:  # one draw per pulse from its robot's stream
            counts = np.bincount(c.robot[detected], minlength=self.n).tolist()
            draws = np.concatenate(
                [g.normal(0.0, self._timing_noise, size=k) for g, k in zip(self.rng["timing"], counts) if k]
            )
        window = (float(traj.t[0]), float(traj.t[-1]))
        source, robot, beacon, times, phase, (counts_, tied_) = kernels.pulses(
            c.t, offset, detected, c.robot, c.beacon, c.phi, draws, window, self.omega,
            self.kind == "reflector", self._clock_hz, det.first_tick_after(window[0], p), self._merging,
        )  # fmt: skip
        counts = counts_.tolist()
        steps = p["counts_per_turn"] if self.kind == "flash_detector" else p["quantization"]
        latched = steps or self.kind == "flash_detector"  # an encoder reports angles even when ideal
        m = len(source)
        if self.kind == "reflector" and steps:  # a stepped head: what it reads is the step, and when it got there
            times = det.step_time(times, phase, self.omega[robot], steps, window[0])
        angles = det.quantize_angle(phase, steps).tolist() if latched else [None] * m
        labels = [self.ids[b] for b in beacon.tolist()] if self.kind != "reflector" else [None] * m
        beams = zip(c.x[source].tolist(), c.y[source].tolist(), self.bx[beacon].tolist(), self.by[beacon].tolist())
        robots, times_ = robot.tolist(), times.tolist()
        if self.crosstalk == "shared":
            low = (p.get("rise_time", 0.0) - 2 * offset[source]).tolist()  # the optics' dwell, and the release
            kept = self._flanks(times_, beacon.tolist(), low)
            pulses = [f for f, k in zip(zip(robots, times_, labels, angles, beams), kept) if k]
            return self._to_everyone(pulses)
        fields = zip(robots, times_, repeat("hit"), labels, angles, repeat(()), robots, beams)
        events = list(map(NEW_DETECTION, fields))
        # times never decrease within a robot; hits at one time go by their keys (a stepped head's
        # times, moved back to their steps, may reorder two returns of one step: sorted too)
        stepped = self.kind == "reflector" and bool(steps)
        start = 0
        for r, (k, tied) in enumerate(zip(counts, tied_.tolist())):
            out[r] = events[start : start + k]
            start += k
            if tied or stepped:
                out[r].sort(key=event_order)
        return out

    def _flanks(self, times: list[float], beacon: list[int], low: list[float]) -> list[bool]:
        """Which of a batch's pulses (every robot's, `low` s long each) make a flank on their
        array's one line. Bac: "all 20 phototransistors in the array were placed in parallel",
        pulled up to 5 V, "producing an analog pulse ... when any of the 20 phototransistors in
        the array was triggered"; the comparator feeds a latch that "the negative flank" sets.
        So a sweep that reaches an array while another laser still holds its line low makes no
        flank of its own: it is lost, and the earlier pulse's time stands. How long the line
        stays low is ours: the optics' time above threshold plus the phototransistor's rise
        time to let go (`rise_time`). State carries across batches: a pulse at a period's end
        can hide one at the next period's start."""
        kept = [False] * len(times)
        for i in sorted(range(len(times)), key=times.__getitem__):  # stable: ties keep robot order
            b = beacon[i]
            if times[i] >= self.line_low_until[b]:
                kept[i] = True
                self.line_low_until[b] = times[i] + low[i]
        return kept

    def _to_everyone(self, pulses: list[tuple]) -> list[list[det.Detection]]:
        """Every controller gets every pulse (robot, time, label, angle, beam): an array's
        output says which array fired, not whose laser it was."""
        out: list[list[det.Detection]] = [[] for _ in range(self.n)]
        for r, t, label, angle, beam in pulses:
            for rx in range(self.n):
                out[rx].append(det.Detection(rx, t, "hit", label, angle, (), r, beam))
        for events in out:
            events.sort(key=event_order)
        return out

    def _fluctuation(self, c: Crossings, sensitivity: np.ndarray) -> np.ndarray:
        """The detector's response to each sweep: `sensitivity` times how much of its usual
        light the sweep brings, log-normal with std `light_noise` of its logarithm (none when
        0). Near a detector's limit the light hovers at the threshold, so such sweeps fire late
        or not at all."""
        sigma = self.params.get("light_noise", 0.0)
        if not sigma > 0:
            return sensitivity
        out = np.ones(len(c))
        for r in np.unique(c.robot):
            mine = np.nonzero(c.robot == r)[0]
            out[mine] = np.exp(sigma * self.rng["detector"][r].normal(size=len(mine)))
        return sensitivity * out

    def _false_returns(self, traj: Trajectory, r: int) -> list[det.Detection]:
        """Spurious pulses (shiny surfaces, stray light, electrical noise): a Poisson process in
        time; a sensor array's false pulse carries the label of an array drawn uniformly."""
        g = self.rng["false"][r]
        t0, t1 = traj.t[0], traj.t[-1]
        count = g.poisson(self.params["false_rate"] * (t1 - t0))
        if not count:
            return []
        events = []
        times = np.sort(g.uniform(t0, t1, size=count))
        if self.kind == "sensor_array":
            labels = g.integers(len(self.ids), size=len(times))
            for t, b in zip(det.counter_clock(times, self.params).tolist(), labels.tolist()):
                events.append(det.Detection(r, t, "hit", self.ids[b], None, source=-1))
            events.sort(key=event_order)  # one clock tick may hold two
            return events
        for t in times:
            angle = None
            steps = self.params["quantization"]
            if steps:
                k = min(int(np.searchsorted(traj.t, t)) - 1, len(traj.t) - 2)
                s = (t - traj.t[k]) / (traj.t[k + 1] - traj.t[k])
                phase = np.array([traj.phi[k, r] + s * (traj.phi[k + 1, r] - traj.phi[k, r])])
                angle = float(det.quantize_angle(phase, steps)[0])
                t = float(det.step_time(np.array([t]), phase, self.omega[r : r + 1], steps, float(traj.t[0]))[0])
            events.append(det.Detection(r, float(t), "hit", None, angle, source=-1))
        if self.params["quantization"]:
            events.sort(key=event_order)  # two returns at one step: its time, rounded either way
        return events

    def _table_false_pulses(self, traj: Trajectory) -> list[tuple]:
        """Shared crosstalk's false pulses (robot -1, time, label, no angle, no beam): a
        Poisson process in time at `false_rate` for the whole table, as one robot alone
        would see them, each on an array drawn uniformly."""
        g = self.table_false
        t0, t1 = traj.t[0], traj.t[-1]
        count = g.poisson(self.params["false_rate"] * (t1 - t0))
        if not count:
            return []
        times = det.counter_clock(np.sort(g.uniform(t0, t1, size=count)), self.params).tolist()
        labels = g.integers(len(self.ids), size=count).tolist()
        return [(-1, t, self.ids[b], None, None) for t, b in zip(times, labels)]

    # ---- index switch ---------------------------------------------------------------------

    def _index(self, traj: Trajectory) -> list[list[det.Detection]]:
        """Index clicks per robot, in time order."""
        out: list[list[det.Detection]] = [[] for _ in range(self.n)]
        robot, _, _, t, _ = find_phase_marks(traj, 1, self.direction)
        for r, ti in zip(robot.tolist(), t.tolist()):
            if self.index[r]:
                out[r].append(det.Detection(r, ti, "index", source=r))
        return out

    # ---- lights and a sampled turret -------------------------------------------------------

    def _light(self, traj: Trajectory, lasers: Trajectory) -> list[list[det.Detection]]:
        """Osentoski's turret: N brightness samples per turn at relative angles 2 pi k / N, taken
        where the turret stands (`lasers`); a full turn of samples is one `scan` event at the time
        of its last sample."""
        out: list[list[det.Detection]] = [[] for _ in range(self.n)]
        p = self.params
        per_turn = int(p["samples_per_turn"])
        robot, step, s, t, mark = find_phase_marks(traj, per_turn, self.direction)
        if not len(robot):
            return out
        x, y, h = lasers.pose_at(step, s, robot)
        k = mark % per_turn
        beam = h + TWO_PI * k / per_turn
        if p["servo_jitter"] > 0:
            beam = beam + np.concatenate([self.rng["light"][r].normal(0.0, p["servo_jitter"], 1) for r in robot])
        m, nl = len(robot), len(self.ids)
        rep = np.repeat(np.arange(m), nl)
        lights = np.tile(np.arange(nl), m)
        blocked = self._blocked(traj, robot[rep], step[rep], s[rep], x[rep], y[rep], lights).reshape(m, nl)
        dx, dy = self.bx[None, :] - x[:, None], self.by[None, :] - y[:, None]
        delta = wrap_angle(beam[:, None] - np.arctan2(dy, dx))
        value = det.brightness(delta, np.hypot(dx, dy), ~blocked, p)
        for i in range(m):
            r, turn = int(robot[i]), int(mark[i] // per_turn)
            v = value[i]
            if p["brightness_noise"] > 0:
                v = v + self.rng["light"][r].normal(0.0, p["brightness_noise"])
            scan = self.scans.setdefault((r, turn), np.full(per_turn, -1.0))
            scan[k[i]] = max(0.0, min(255.0, v))
            if (scan >= 0).all():  # a full turn (the very first may lack its sample at t = 0)
                del self.scans[(r, turn)]
                samples = tuple(int(round(u)) for u in scan)
                out[r].append(det.Detection(r, float(t[i]), "scan", samples=samples, source=r))
        return out


_loaded = False  # this process has run every sensing kernel once (numba loads them on first use)


def _load_kernels(world: World, ideal: bool) -> None:
    """Run one control period of a throwaway Sensing (its own random streams, the world's
    poses held still while the lasers turn), so that numba loads the compiled kernels now, when
    a match is made, rather than inside its first period: loading takes a tenth of a second or
    more, which is no cost of sensing."""
    global _loaded
    _loaded = True
    level = world.level
    still = SimpleNamespace(level=level, dt=world.dt, state=world.state, time=0.0, space=world.space)
    sensing = Sensing(cast(World, still), RandomTree(0), ideal)
    still.time = level.steps_per_control * world.dt
    for _ in range(level.steps_per_control):
        sensing.record()
    sensing.flush()
