"""The simulation core: one match's world, sensing, task, rules and score, with no processes
and no files. `start` gives the first observations; `step(answers)` takes every robot's
answer to them, steps physics to the next control tick and returns a `Tick` (the shape of a
Gymnasium `Env` and Lux S3's `env.step`). The match (`loop`) is this core plus its
controllers and its recorder; the RL envs are this core plus in-process agents.

What is checked after each physics step (sensing, task progress, the rules, replay frames) is
worked out once for a run of steps, from the states of its steps, with the results of
step-by-step checks (docs/decisions/0021).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

from arena import floor, placement
from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.world import Watch, World
from levels.model import Level, Pose
from referee.match.deferral import Deferral
from referee.match.drawings import DrawingBudget, Warnings
from referee.match.estimates import EstimateStats
from referee.match.report import RobotReport, Tick
from referee.match.result import match_result, robot_result
from referee.match.rules import Foul, Rules
from referee.match.tasks import TaskTracker
from referee.match.views import frames, poses, to_event
from referee.records.replay_writer import Recorder
from referee.records.results import Fault, MatchResult
from robots.api import Command, Observation, SensorEvent

__all__ = ["STILL", "Simulation"]

EVERY_STEP = Watch((), 0.0)  # no robot still driving: the match ends at the next step
STILL = 0.01  # a wheel slower than this share of its top speed stands still (a goto arrival)


class Simulation:
    """One match of `level` for robots whose teams are named `labels` (in slot order, for the
    result). `recorder` (optional) hears what happens, in order; with `defer`, its writes wait
    for `flush()` (the match calls it while its controllers compute). `noise_key` (hex) mixes
    a secret into every random stream (docs/integrity.md); `ideal` turns every sensor noise
    and failure and every drive error off."""

    def __init__(
        self,
        level: Level,
        labels: Sequence[str],
        seed: int | None = None,
        ideal: bool = False,
        noise_key: str | None = None,
        recorder: Recorder | None = None,
        defer: bool = False,
    ):
        n = len(level.robots)
        if len(labels) != n:
            raise ValueError(f"{level.name} has {n} robot slots, got {len(labels)} teams")
        self.level, self.labels = level, tuple(labels)
        self.seed = level.seed if seed is None else seed
        self.ideal = ideal
        tree = RandomTree(self.seed, noise_key)
        # where the robots really stand, trial by trial (the first trial is the start): drawn
        # even when ideal, since that is the task's uncertainty, not the hardware's
        self.starts: tuple[Pose, ...] = placement.starts(level, tree)
        tiles = floor.grid(level.floor, tree, ideal)  # the experimenter's tiles: perfect when ideal
        self.trial_poses = placement.trial_poses(level, tree, self.starts, tiles)
        self.trial = 0
        self.world = World(level, None if ideal else tree, self.starts)
        self.sensing = Sensing(self.world, tree, ideal)
        self.inbox: list[list[SensorEvent]] = [[] for _ in range(n)]
        self.faults: list[list[Fault]] = [[] for _ in range(n)]
        self.stopped = [False] * n
        self.warnings = [Warnings() for _ in range(n)]
        self.drawings = [DrawingBudget(w) for w in self.warnings]  # what each robot may still draw
        self.tracker = TaskTracker(level, self.starts)
        self.estimates = [EstimateStats(level.rules.position_scale, level.rules.heading_scale) for _ in range(n)]
        self.rules = Rules(level)
        self._told = [0] * n  # fouls a Tick has already reported, per robot
        # how far any robot may travel (path length) in one control period: twice the fastest top
        # speed, and 0.5 m/s for a push or a bounce on top (the match can only end near a final target)
        top = max((r.model.max_wheel_speed for r in level.robots), default=0.0)
        self.reach = (2 * top + 0.5) * level.control_period
        self.recorder = recorder
        self.deferred = Deferral()
        if defer:
            self.deferred.hold()
        self.total_steps = round(level.time_limit * level.physics_rate)
        self.ended = False
        self.end_reason = "time_limit"
        # localize trials begin at control ticks that cut the match into equal spans
        count = len(self.trial_poses)
        ticks = level.control_ticks
        self.trial_ticks = [(j * ticks // count) * level.steps_per_control for j in range(1, count)]

    # ---- the turn pipeline ----------------------------------------------------------------

    def start(self, faults: Sequence[Fault | None] = ()) -> Tick:
        """Begin: record each robot's fault at setup (None: none), the first frame, and return
        the first observations."""
        for slot, fault in enumerate(faults):
            if fault:
                self._fault(slot, fault)
        if self.recorder:
            self.recorder.frame(self.world.time, poses(self.world.state))
        self.ended = self.world.tick >= self.total_steps
        return self._tick((None,) * len(self.labels))

    def step(self, answers: Sequence[Command | Fault | None]) -> Tick:
        """One control tick: take each robot's answer to its last observation (None: it had
        none), step physics to the next control tick or the match's end, and report."""
        if self.ended:
            raise RuntimeError("the match has ended")
        earned = tuple(None if out is None else self._answer(slot, out) for slot, out in enumerate(answers))
        self._advance()
        return self._tick(earned)

    def flush(self) -> None:
        """Hand the recorder, in order, what was put off (with `defer`)."""
        self.deferred.flush()

    def _tick(self, earned: tuple[float | None, ...]) -> Tick:
        """The report of the tick just stepped, with the next observations unless it ended."""
        observations = self._observe() if not self.ended else (None,) * len(self.labels)
        slots = range(len(self.labels))
        return Tick(
            time=self.world.time,
            observations=observations,
            earned=earned,
            progress=tuple(map(self.tracker.progress, slots)),
            fouls=tuple(map(self._new_fouls, slots)),
            ended=self.ended,
        )

    def _new_fouls(self, slot: int) -> tuple[Foul, ...]:
        """Robot `slot`'s fouls called since the last Tick reported them."""
        mine = self.rules.fouls[slot]
        out, self._told[slot] = tuple(mine[self._told[slot] :]), len(mine)
        return out

    def _observe(self) -> tuple[Observation | None, ...]:
        """Deliver the sensor events since the last tick: each robot's Observation (None for a
        stopped robot, which is counted estimate-less)."""
        time, tick = self.world.time, self.world.tick // self.level.steps_per_control
        detected = self.sensing.flush()
        for slot, detections in enumerate(detected):
            self.inbox[slot].extend(map(to_event, detections))
        if self.recorder and any(detected):
            self.deferred.put(functools.partial(self.recorder.events, detected))
        out: list[Observation | None] = []
        for slot in range(len(self.labels)):
            if self.stopped[slot]:
                self.estimates[slot].add(self.world.pose(slot), None)
                out.append(None)
                continue
            events, self.inbox[slot] = tuple(self.inbox[slot]), []
            out.append(Observation(tick=tick, time=time, events=events, trial=self.trial))
        return tuple(out)

    def _answer(self, slot: int, out: Command | Fault) -> float | None:
        """Take robot `slot`'s answer; the tick quality its estimate earned (None without one)."""
        self.deferred.flush()
        time, truth = self.world.time, self.world.pose(slot)
        if isinstance(out, Fault):  # a skipped tick keeps the last command; others stop the robot
            self._fault(slot, out)
            self.estimates[slot].add(truth, None)
            return None
        self.world.command(slot, float(out.left), float(out.right))
        stats = self.estimates[slot]
        before = stats.quality_sum
        stats.add(truth, out.estimate)
        earned = None if out.estimate is None else stats.quality_sum - before
        # the drawings that can be drawn, within the budgets; the others are warnings and never
        # reach the replay, render or watch
        tick = self.world.tick // self.level.steps_per_control
        drawings = self.drawings[slot].keep(tick, out.debug) if out.debug else ()
        if self.recorder:
            if out.estimate is not None:
                self.recorder.record("est", t=time, r=slot, e=list(out.estimate))
            if drawings:
                self.recorder.record("dbg", t=time, r=slot, d=drawings)
        return earned

    def _fault(self, slot: int, fault: Fault) -> None:
        self.faults[slot].append(fault)
        p = self.world.pose(slot)
        self.rules.controller(slot, fault.tick * self.level.steps_per_control, fault.kind, (p.x, p.y), fault.message)
        if fault.fatal:
            self.stopped[slot] = True
            self.world.command(slot, 0.0, 0.0)

    def _over(self) -> bool:
        if self.tracker.finished_count + sum(self.stopped) < len(self.labels):
            return False  # the cheap test first: this runs after every physics step
        return all(self.stopped[s] or self.tracker.done(s) for s in range(len(self.labels)))

    def _advance(self) -> None:
        """Step physics up to the next control tick, or to the end of the match: the time limit,
        or every robot done or stopped (sets `ended`). A run of steps stops early only after a
        step at which the match may have ended: a robot still driving stood within its final
        target's radius."""
        if self.trial_ticks and self.world.tick >= self.trial_ticks[0]:
            self._next_trial()
        left = min(self.level.steps_per_control, self.total_steps - self.world.tick)
        while left:
            watch = self._finish_line()  # again after a stop: a robot that finished is no longer watched
            left -= self._steps(1 if watch is EVERY_STEP else left, watch)
            if not left:
                self._stood()
            if self._over():
                done = any(map(self.tracker.done, range(len(self.labels))))
                self.end_reason = "task_complete" if done else "all_stopped"
                self.ended = True
                return
        self.ended = self.world.tick >= self.total_steps

    def _next_trial(self) -> None:
        """Carry every robot to its pose of the next trial, at rest (docs/rules.md): the
        observation that ends this control period is the first that tells the new trial."""
        self.trial += 1
        self.trial_ticks.pop(0)
        for slot, pose in enumerate(self.trial_poses[self.trial]):
            self.world.place(slot, pose)
        self.sensing.moved()
        self.rules.moved()
        if self.recorder:
            self.deferred.put(functools.partial(self.recorder.record, "trial", t=self.world.time, n=self.trial))

    def _stood(self) -> None:
        """At a control tick: tell the task whether each robot's wheels are still (slower than
        STILL of its top wheel speed), where a goto robot arrives by standing."""
        tracker, state = self.tracker, self.world.state
        if tracker.kind != "goto":
            return
        for slot, drive in enumerate(self.world.drives):
            still = max(abs(w) for w in drive.wheels) <= STILL * drive.model.max_wheel_speed
            tracker.stand(slot, still, state[3 * slot], state[3 * slot + 1], self.world.time)

    def _finish_line(self) -> Watch | None:
        """Where, in a world state, the match may have ended at that step (None: it cannot end
        within this control period). Only a robot still driving that finishes its task can end
        it, at a step where it stands within its final target's radius; a robot that cannot
        reach every target it has left this period (see `reach`) is not watched."""
        tracker = self.tracker
        going = [s for s in range(len(self.labels)) if not (self.stopped[s] or tracker.done(s))]
        if not going:
            return EVERY_STEP
        state = self.world.state
        watched = []
        for slot in going if tracker.kind != "goto" else ():  # a goto robot arrives at a control tick
            targets = tracker.targets(slot)
            if targets and tracker.still_to_travel(slot, state[3 * slot], state[3 * slot + 1]) <= self.reach:
                watched.append((slot, *targets[-1]))
        if not watched:
            return None
        return Watch(tuple(watched), tracker.near**2)  # a hair wide: stopping a run early is always safe

    def _steps(self, count: int, watch: Watch | None) -> int:
        """Up to `count` physics steps (fewer if a robot of `watch` reaches its point), then the
        checks after each of them; returns how many steps ran."""
        world, level = self.world, self.level
        first = world.tick + 1
        table, speeds = world.run(count, speeds=bool(level.rules.speed_limit), watch=watch)
        self.sensing.record_many(table)
        every = level.steps_per_record
        self.tracker.advance(table, first, level.physics_rate, every)
        self.rules.after_steps(world, table, speeds)
        if self.recorder:
            start = -first % every  # the first step of this run that is recorded
            if start < len(table):
                recorded = frames(table[start::every], first + start, every, level.physics_rate)
                self.deferred.put(functools.partial(self.recorder.frames, recorded))
        return len(table)

    # ---- standing and result --------------------------------------------------------------

    def report(self, slot: int) -> RobotReport:
        """Robot `slot`'s standing now (what a trainer's reward and a picture may read)."""
        tracker, stats, start = self.tracker, self.estimates[slot], self.starts[slot]
        state = self.world.state
        return RobotReport(
            time=self.world.time,
            progress=tracker.progress(slot),
            reached=tracker.next[slot],
            targets=tuple(tracker.targets(slot)),
            start=(start.x, start.y),
            finished=tracker.finished[slot],
            stopped=self.stopped[slot],
            position=(float(state[3 * slot]), float(state[3 * slot + 1])),
            heading=self.world.pose(slot).heading,
            quality_sum=stats.quality_sum,
            quality=stats.quality,
            penalties=tuple(f.penalty for f in self.rules.fouls[slot]),
        )

    def end(self) -> MatchResult:
        """Finish the rules, record the fouls and faults, close the recorder, and return the
        result. A robot stopped by a fault is counted without an estimate to the time limit: a
        controller that faults on purpose ends nothing early."""
        self.deferred.flush()
        for slot, stopped in enumerate(self.stopped):
            if stopped:
                self.estimates[slot].silent_until(self.level.control_ticks)
        self.rules.finish(self.world)
        self.ended = True
        result = self._result()
        if self.recorder:
            for slot in range(len(self.labels)):
                for foul in self.rules.fouls[slot]:
                    self.recorder.record("foul", r=slot, **foul.to_record().to_dict())
                for fault in self.faults[slot]:
                    self.recorder.record("fault", r=slot, **fault.to_dict())
            self.recorder.close(result)
        return result

    def _result(self) -> MatchResult:
        robots = [
            robot_result(
                slot,
                label,
                self.world.pose(slot),
                self.tracker,
                self.estimates[slot],
                self.rules.fouls[slot],
                self.faults[slot],
                self.stopped[slot],
                self.warnings[slot],
                self.level.time_limit,
            )
            for slot, label in enumerate(self.labels)
        ]
        return match_result(self.level, self.seed, self.ideal, self.world.time, self.end_reason, robots)
