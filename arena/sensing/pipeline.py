"""Sensing: every robot's spinning laser against the level's beacons, batch by batch.

`record()` runs after every physics step and only stores each robot's pose (cheap);
`flush()` runs at each control tick and turns the steps since the last tick into
detections, all at once, calling each stage once, in order: the laser phases (spin: speed
wobble and the lag when the body turns), where each beam leaves (the body's position, leaned
by the floor's tilt: arena.floor), exact crossing times (crossings), occlusion by other robots'
silhouettes at the crossing instant and by obstacles (occlusion), the gates and optics of the
level's beacon kind (hardware, optics), the pulses as the hardware reads them (pulses), then
false pulses, index clicks, and the lights' scans (light). Where beams leave from the bodies and
only robots block them, the poses, phases and pulses are one compiled call (sweep.sense_period).
"""

from __future__ import annotations

from itertools import chain, repeat
from types import SimpleNamespace
from typing import cast

import numpy as np

from arena import floor
from arena.angles import TWO_PI
from arena.heap import lasting
from arena.rng import RandomTree
from arena.sensing import hardware, reflector, sensor_array, sweep
from arena.sensing.crossings import Trajectory, find_phase_marks
from arena.sensing.events import NEW_DETECTION, Detection, event_order
from arena.sensing.light import Turrets
from arena.sensing.normals import NO_DRAWS, Normals
from arena.sensing.occlusion import Occlusion
from arena.sensing.readout import FalseClock, first_tick_after, quantize_angle
from arena.sensing.spin import Spin
from arena.world import World

_NONE = np.zeros(0)  # a kernel's array argument that is not there
_NO_ROWS = np.zeros((0, 0))  # the same, of two dimensions


class Sensing:
    """The lasers and beacon hardware of one match."""

    def __init__(self, world: World, rng: RandomTree, ideal: bool = False):
        level = world.level
        self.world = world
        self.ideal = ideal
        self.kind = level.beacons.kind
        self.params = hardware.effective_params(level.beacons.params, ideal)
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
        self._gains = _NONE if ideal or (gains == 1.0).all() else gains
        robots = level.robots
        self.n = len(robots)
        self.omega = np.array([r.laser.angular_velocity for r in robots])
        self.beam_offset = np.array([0.0 if ideal else r.laser.beam_offset for r in robots])
        self._axis_offsets = self.beam_offset if self.beam_offset.any() else _NONE  # none: every beam on its axis
        self.direction = np.sign(self.omega)
        # a tilted floor leans each robot: its beam leaves `laser.height` above its base, off it
        height = np.array([r.laser.height for r in robots])
        self.tilt = floor.tilt(level.floor, rng, ideal) if height.any() else None
        self.height = height
        self.index = np.array([r.laser.index for r in robots])
        self._any_index = bool(self.index.any())
        self.occlusion = Occlusion(world, self.bx, self.by)
        self.dt = world.dt
        self.rng = {
            name: [rng.stream("robot", r, name) for r in range(self.n)]
            for name in ("wobble", "detector", "timing", "false", "light")
        }
        # each robot's place in its wobble, light and timing draws, and in its false pulses' uniforms
        self._at = np.zeros((4, self.n), np.int64)
        self.spin = Spin(self.omega, self.dt, self.params, self.rng["wobble"], at=self._at[0])
        self.turrets = Turrets(self.params, self.direction, self.rng["light"], self.occlusion)
        self.merge_key = int(rng.stream("beacons", "merge").integers(1 << 62))
        # shared crosstalk: each array's one line, and the table's false pulses, one stream for every controller
        self.lines = sensor_array.SharedLines(len(items))
        self.table_false = rng.stream("beacons", "false")
        p = self.params
        # when false pulses come: each robot's stream, and the table's under shared crosstalk
        self._spurious = self.kind in ("reflector", "sensor_array") and p.get("false_rate", 0.0) > 0
        self._false_rate = float(p.get("false_rate", 0.0))
        uniforms = np.zeros((self.n, 256))  # each robot's false pulses' uniforms, drawn ahead (FalseClock)
        self._false = [
            FalseClock(g, self._false_rate, len(row), row, self._at[3, r : r + 1])
            for r, (g, row) in enumerate(zip(self.rng["false"], uniforms))
        ]
        self._table_false = FalseClock(self.table_false, self._false_rate)
        # the clocks' uniforms `sweep.sense_period` takes quiet periods from: each robot's, unless a table's is shared
        self._false_uniforms = uniforms if self._spurious and self.crosstalk != "shared" else _NO_ROWS
        self._light_noise = float(p.get("light_noise", 0.0)) if p.get("light_noise", 0.0) > 0 else 0.0
        self._timing_noise = p["timing_noise"] if p.get("timing_noise", 0.0) > 0 else 0.0
        self._clock_hz = float(p.get("clock_hz", 0.0))
        self._kind = sweep.KIND_CODES.get(self.kind, -1)  # -1: light turrets, which sweep no detector
        self._gates = sweep.gates(p, float(level.beacons.radius))
        self._optics = np.array(sweep.hardware(p))
        # each kept sweep's light, each pulse's timing: standard normals from each robot's streams
        lit = self._light_noise and self.kind in ("sensor_array", "flash_detector")
        self._light = Normals(self.rng["detector"], at=self._at[1]) if lit else None
        self._light_sigma = self._light_noise if lit else 0.0
        self._timing = Normals(self.rng["timing"], at=self._at[2]) if self._timing_noise else None
        # Bac's merged measurements (arena.sensing.sensor_array.merge), as `pulses` takes them
        merges = (self.kind == "sensor_array", float(p.get("merge_rate", 0.0)))
        self._merging = np.array([float(merges[0]), len(self.ids), merges[1]])
        self._merge_key = np.uint64(self.merge_key)
        self._clock = np.array([self._timing_noise, 0.0, 0.0, self._clock_hz, 0.0])  # `_pulses` fills in the window
        # what `sweep.sense_candidates` takes after the spin: the beacons, then the bodies and the gates
        beacons = (self.bx, self.by, self.facing, self._gains, self._axis_offsets)
        self._hardware = (*beacons, self.occlusion.reach, self.occlusion.silhouette, self._kind, self._gates)
        # the same for `sweep.sense_period`, packed: where beams leave from the bodies and only robots block them
        self._plain = self.kind != "light" and self.tilt is None and not self.occlusion.has_obstacles
        offsets = self.beam_offset if len(self._axis_offsets) else np.zeros(self.n)
        self._robots = np.array([self.omega, self.direction, self.occlusion.reach, self.occlusion.silhouette, offsets])
        self._beacons = np.array([self.bx, self.by, self.facing, gains if len(self._gains) else np.ones(len(items))])
        # per robot, its pulses in a period and whether two read one time (`sweep.sense_period` writes it)
        self._counts = np.zeros((2, self.n), np.int64)
        # what a hit reports (`_hits`): the beacons' labels, the optics' rise time, and the head's encoder
        self._labels = self.ids if self.kind != "reflector" else None
        self._rise_time = float(p.get("rise_time", 0.0))
        self._steps = p["counts_per_turn"] if self.kind == "flash_detector" else p["quantization"]
        self._latched = bool(self._steps) or self.kind == "flash_detector"  # an encoder reports angles even when ideal
        self._stepped = self.kind == "reflector" and bool(self._steps)  # a stepped head
        self._rows: list[tuple | np.ndarray] = []  # a state (`record`) or a run's states (`record_many`)
        self._batches: dict[int, tuple] = {}  # batch length -> buffers for its poses and times (`_batch`)
        self._plans: dict[int, tuple] = {}  # batch length -> what `sweep.sense_period` takes (`_plan`)
        self._draws: tuple = ()  # the batch length the blocks of draws are ready for, and the blocks (`_ready`)
        self._last = np.array(world.state, float)  # where the next batch starts (`sweep.batch_poses` moves it on)
        self._last_t = world.time
        if not _loaded:
            with lasting():  # numba's objects for the kernels live as long as the process
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
        self._last[:] = self.world.state
        self.spin.moved()
        self.turrets.moved()  # a turret's turn begun before the move is no scan of where it now stands

    def flush(self) -> list[list[Detection]]:
        """Detections per robot for the steps recorded since the last flush, in event order
        (`event_order`). Each source of events (hits, false returns, index clicks, scans)
        yields its own events in that order; only a robot that got events from two sources,
        or hits at one time, needs a sort."""
        rows = self._rows
        if not rows:
            return [[] for _ in range(self.n)]
        states: np.ndarray
        if len(rows) == 1 and isinstance(rows[0], np.ndarray):  # one run of states (`record_many`): a match's period
            states = rows[0]
        elif all(isinstance(row, tuple) for row in rows):  # one state a step (`record`)
            states = np.fromiter(chain.from_iterable(rows), float, len(rows) * 3 * self.n).reshape(len(rows), -1)
        else:  # runs of states, or both
            states = np.vstack(rows)
        w0, w1 = self._last_t, self.world.time  # the batch's first and last times (`t[0]`, `t[-1]`)
        if self._plain:  # the poses, the phases, the hits and most quiet periods in one compiled call
            hits, quiet = self._period(states, w1)
        else:
            t, x, y, heading, phi, poses = self._batch(len(states))
            sweep.batch_poses(self._last, states, w0, w1, self.dt, poses[:3], t)
            hits, quiet = self._other(t, x, y, heading, phi), False
        self._last_t, self._rows = w1, []
        sources = [hits]
        traj: Trajectory | None = None  # the batch's, made for the first source that needs it
        if self._spurious:
            if self.crosstalk == "shared":  # a false pulse is an array's, seen by all
                sources.append(self._to_everyone(self._table_false_pulses(w0, w1)))
            elif not quiet:
                false: list[list[Detection]] | None = None
                for r, clock in enumerate(self._false):
                    times = clock.times(w0, w1)
                    if len(times):  # most periods have none
                        false = false or [[] for _ in range(self.n)]
                        traj = traj or Trajectory(*self._batch(len(states))[:5])
                        false[r] = self._false_returns(traj, r, times)
                if false:
                    sources.append(false)
        if self._any_index:
            sources.append(self._index(traj or Trajectory(*self._batch(len(states))[:5])))
        if len(sources) == 1:
            return hits
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

    def _period(self, states: np.ndarray, w1: float) -> tuple[list[list[Detection]], bool]:
        """The batch's poses, phases (into its buffers: `_batch`) and hits, from the world's
        `states` up to the time `w1`, in one compiled call (`sweep.sense_period`): `_pulses`'
        pulses as detections, each robot's draws from its own streams; and whether the batch
        was quiet for every robot's false pulses' clock (readout.quiet: each took its uniform)."""
        steps = len(states)
        plan = self._plans.get(steps)
        if plan is None:
            plan = self._plans[steps] = self._plan(steps)
        t, poses, params, ids, told, powers, lag_powers, need = plan
        draws = self._draws
        if not draws or draws[0] != steps:
            draws = self._ready(steps, need)
        m, short, quiet = sweep.sense_period(
            self._last, states, self._last_t, w1, poses, t, self.spin.live, self._at, draws[1], draws[2], draws[3],
            self._false_uniforms, powers, lag_powers, self._robots, self._beacons, params, self._counts, ids, told,
            self._merge_key,
        )  # fmt: skip
        if short:
            self._draws = ()
        return self._detections(t, ids[:, :m], told[:, :m], *self._counts.tolist()), quiet

    def _ready(self, steps: int, need: int) -> tuple:
        """The blocks of draws `_period` passes, every robot's row holding a batch of `steps`
        steps' need (the wobble's: `steps`; the light's and the timing's: `need`), kept until
        `sweep.sense_period` says a row runs short, or a batch of another length comes."""
        light = self._light.refill(need)[0] if self._light else NO_DRAWS[0]
        timing = self._timing.refill(need)[0] if self._timing else NO_DRAWS[0]
        self._draws = (steps, self.spin.refill(steps)[0], light, timing)
        return self._draws

    def _plan(self, steps: int) -> tuple:
        """What `_period` passes for a batch of `steps` steps, kept per length: its buffers of
        times and poses (`_batch`); `sweep.sense_period`'s scalars; where it writes the pulses,
        with room for one per step, robot and beacon (a beam passes a beacon at most once a
        step); the spin's powers (spin.Spin.model); and a robot's need of light and timing draws
        (its crossings in the batch, at most)."""
        scale, decay, powers, lag_decay, coupled, lag_powers = self.spin.model(steps)
        need = steps * len(self.ids)
        params = sweep.period_params(
            self.dt, (scale, decay, lag_decay, coupled), self._kind, self._light_sigma, self._timing_noise,
            self._clock_hz, self._merging, (len(self._gains) > 0, len(self._axis_offsets) > 0), self._gates,
            self._optics, (steps, need), self._false_rate,
        )  # fmt: skip
        room = steps * self.n * len(self.ids)
        ids, told = np.empty((2, room), np.int64), np.empty((7, room))
        t, *_, poses = self._batch(steps)
        return t, poses, params, ids, told, powers, lag_powers, need

    def _other(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, h: np.ndarray, phi: np.ndarray) -> list:
        """The batch's phases (into `phi`) and hits or scans where `sweep.sense_period` does not
        serve: light turrets, beams leaned by a tilted floor, obstacles."""
        if self.kind == "light":
            phi[:] = self.spin.phases(h)
            traj = Trajectory(t=t, x=x, y=y, h=h, phi=phi)
            return self.turrets.scan(traj, traj if self.tilt is None else self._leaned(traj))
        lx, ly = (x, y) if self.tilt is None else self._lean(x, y)
        phases, hits = self._hits(t, x, y, h, lx, ly)
        phi[:] = phases
        return hits

    def _lean(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where the beams leave, step by step: each body's position (x, y), leaned by the
        floor's tilt there (arena.floor); the body itself is what the score and other beams see."""
        assert self.tilt is not None
        dx, dy = self.tilt.lean(x, y, self.height)
        return x + dx, y + dy

    def _leaned(self, traj: Trajectory) -> Trajectory:
        """`traj` with its positions where the beams leave (`_lean`)."""
        return Trajectory(traj.t, *self._lean(traj.x, traj.y), traj.h, traj.phi)

    def _batch(self, steps: int) -> tuple[np.ndarray, ...]:
        """Buffers for a batch of `steps` steps, kept per length and filled anew by each batch:
        the step-end times, then x, y, heading and the laser's phase (each (steps + 1, robots),
        contiguous: one compiled form for every level), and the block they are rows of. Nothing
        keeps a batch's trajectory past its flush."""
        batch = self._batches.get(steps)
        if batch is None:
            poses = np.empty((4, steps + 1, self.n))
            batch = self._batches[steps] = (np.empty(steps + 1), *poses, poses)
        return batch

    # ---- beam-beacon hits -----------------------------------------------------------------

    def _pulses(
        self, t: np.ndarray, x: np.ndarray, y: np.ndarray, h: np.ndarray, lx: np.ndarray, ly: np.ndarray
    ) -> tuple:
        """The batch's laser phases and pulses, in one compiled call (`sweep.sense`) from the
        step-end times `t`, the bodies' poses (x, y, h) and where the beams leave (lx, ly):
        the phases (spin), then the pulses as the hardware reads them, in `sweep.pulse_rows`'
        two blocks, and per robot their count and whether two read one time. Where the level
        has obstacles, pymunk's segment query runs between `sweep.sense_candidates` and
        `sweep.fire`. Each robot's light and timing draws come from its own streams, drawn
        ahead (normals.Normals)."""
        need = (len(t) - 1) * len(self.ids)  # a robot's crossings in the batch, at most
        light, light_at = self._light.ready(need) if self._light else NO_DRAWS
        timing, timing_at = self._timing.ready(need) if self._timing else NO_DRAWS
        w0 = float(t[0])
        clock = self._clock  # the timing noise's scale, the window's start and end, the clock's rate and first tick
        clock[1], clock[2], clock[4] = w0, t[-1], first_tick_after(w0, self._clock_hz)
        spin = self.spin
        motion = (lx, ly, h, t, x, y, spin.omega, spin.dt, spin.phi, *spin.drive(len(t) - 1), *spin.state())
        sigma, optics = self._light_sigma, self._optics
        if not self.occlusion.has_obstacles:
            return sweep.sense(
                *motion, *self._hardware, light, light_at, sigma, optics, timing, timing_at, clock,
                self.direction, self._merging, self._merge_key,
            )  # fmt: skip
        phi, robot, beacon, rows = sweep.sense_candidates(*motion, *self._hardware)
        self.occlusion.clear_obstacles(rows)  # pymunk's segment query, between the compiled stages
        rows, shift, source, robot, beacon, times, phase, counts = sweep.fire(
            robot, beacon, rows, self._kind, light, light_at, sigma, optics, timing, timing_at, clock,
            self.omega, self.direction, self._merging, self._merge_key,
        )  # fmt: skip
        return phi, *sweep.pulse_rows(rows, shift, source, robot, beacon, times, phase, self.bx, self.by), counts

    def _hits(
        self, t: np.ndarray, x: np.ndarray, y: np.ndarray, h: np.ndarray, lx: np.ndarray, ly: np.ndarray
    ) -> tuple[np.ndarray, list[list[Detection]]]:
        """The batch's laser phases, and the beacons' pulses (`_pulses`) as detections, per
        robot in event order."""
        phi, ids, told, (counts, tied) = self._pulses(t, x, y, h, lx, ly)
        return phi, self._detections(t, ids, told, counts.tolist(), tied.tolist())

    def _detections(
        self, t: np.ndarray, ids: np.ndarray, told: np.ndarray, counts: list[int], ties: list[int]
    ) -> list[list[Detection]]:
        """The batch's pulses (`sweep.pulse_rows`' two blocks, and per robot their count and
        whether two read one time) as detections, per robot in event order."""
        m = ids.shape[1]
        if not m:
            return [[] for _ in range(self.n)]
        steps = self._steps
        robots, beacons = ids.tolist()
        times_, _, laser_x, laser_y, beacon_x, beacon_y, offset = told.tolist()
        if self._stepped:  # a stepped head: what it reads is the step, and when it got there
            times_ = reflector.step_time(told[0], told[1], self.omega[ids[0]], steps, float(t[0])).tolist()
        # each hit's angle and label, as each is taken
        angles = iter(quantize_angle(told[1], steps).tolist()) if self._latched else repeat(None)
        labels = map(self._labels.__getitem__, beacons) if self._labels else repeat(None)
        beams = zip(laser_x, laser_y, beacon_x, beacon_y)
        if self.crosstalk == "shared":
            low = [self._rise_time - 2 * o for o in offset]  # the optics' dwell, and the release
            kept = self.lines.flanks(times_, beacons, low)
            heard = [f for f, k in zip(zip(robots, times_, labels, angles, beams), kept) if k]
            return self._to_everyone(heard)
        fields = zip(robots, times_, repeat("hit"), labels, angles, repeat(()), robots, beams)
        events = list(map(NEW_DETECTION, fields))
        # times never decrease within a robot; hits at one time go by their keys (a stepped head's
        # times, moved back to their steps, may reorder two returns of one step: sorted too)
        stepped = self._stepped
        if self.n == 1:
            if ties[0] or stepped:
                events.sort(key=event_order)
            return [events]
        out: list[list[Detection]] = [[] for _ in range(self.n)]
        start = 0
        for r, (k, tied) in enumerate(zip(counts, ties)):
            out[r] = events[start : start + k]
            start += k
            if tied or stepped:
                out[r].sort(key=event_order)
        return out

    def _to_everyone(self, heard: list[tuple]) -> list[list[Detection]]:
        """Every controller gets every pulse (robot, time, label, angle, beam): an array's
        output says which array fired, not whose laser it was."""
        out: list[list[Detection]] = [[] for _ in range(self.n)]
        for r, t, label, angle, beam in heard:
            for rx in range(self.n):
                out[rx].append(Detection(rx, t, "hit", label, angle, (), r, beam))
        for events in out:
            events.sort(key=event_order)
        return out

    # ---- false pulses and the index switch ---------------------------------------------------

    def _false_returns(self, traj: Trajectory, r: int, times: np.ndarray) -> list[Detection]:
        """Robot `r`'s spurious pulses at `times` in this batch (its trajectory `traj`: its
        clock's, `FalseClock.times`), as its kind reports them."""
        g = self.rng["false"][r]
        if self.kind == "sensor_array":
            return sensor_array.false_pulses(r, times, g, self.ids, self.params)
        return reflector.false_returns(traj, r, times, self.omega, self.params)

    def _table_false_pulses(self, w0: float, w1: float) -> list[tuple]:
        """Shared crosstalk's false pulses in this batch (from `w0` to `w1`), one stream for the whole table."""
        times = self._table_false.times(w0, w1)
        if not len(times):
            return []
        return sensor_array.table_false_pulses(times, self.table_false, self.ids, self.params)

    def _index(self, traj: Trajectory) -> list[list[Detection]]:
        """Index clicks per robot, in time order."""
        out: list[list[Detection]] = [[] for _ in range(self.n)]
        robot, _, _, t, _ = find_phase_marks(traj, 1, self.direction)
        for r, ti in zip(robot.tolist(), t.tolist()):
            if self.index[r]:
                out[r].append(Detection(r, ti, "index", source=r))
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
