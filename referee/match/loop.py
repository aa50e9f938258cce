"""The lockstep match loop.

One control tick: every controller gets its Observation (all are sent before any answer is
awaited, so controller processes compute at the same time) and answers a Command -> the drive
takes the wheel speeds -> the world steps physics `steps_per_control` times; what is checked
after each physics step (sensing, which fills each robot's inbox of events; task progress;
the rules; replay frames) is worked out for the whole period at once from the states of its
steps, with the same results. The match ends at the time limit, or as soon as every robot has
finished its task or been stopped by a fault.

This is the turn pipeline alone: the controllers' launch and close are the `fleet`'s, what a
team is told is built in `views`, the result is assembled in `result`, and the replay's writes
go to a `Recorder`, put off while the controllers compute (`deferral`).
"""

from __future__ import annotations

import functools
from pathlib import Path

from arena import floor, placement
from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.world import Watch, World
from levels.match import ControllerLimits
from levels.model import Level, Pose
from referee.match.deferral import Deferral
from referee.match.drawings import DrawingBudget, Warnings
from referee.match.estimates import EstimateStats
from referee.match.fleet import Fleet
from referee.match.report import RobotReport
from referee.match.result import match_result, robot_result
from referee.match.rules import Rules
from referee.match.tasks import TaskTracker
from referee.match.views import brief_for, frames, poses, replay_header, to_event
from referee.records.replay_writer import Recorder, ReplayWriter
from referee.records.results import Fault, MatchResult
from referee.sandbox.exchange import exchange
from referee.sandbox.teams import Team
from robots.api import Command, Observation, SensorEvent

EVERY_STEP = Watch((), 0.0)  # no robot still driving: the match ends at the next step
STILL = 0.01  # a wheel slower than this share of its top speed stands still (a goto arrival)


class Match:
    """One match of a level between teams (one per robot slot), run to its end by `run()`."""

    def __init__(
        self,
        level: Level,
        teams: list[Team],
        seed: int | None = None,
        replay: str | Path | None = None,
        ideal: bool = False,
        isolate: bool = True,
        limits: ControllerLimits | None = None,
        logs: Path | None = None,
        recorder: Recorder | None = None,
        noise_key: str | None = None,
    ):
        if len(teams) != len(level.robots):
            raise ValueError(f"{level.name} has {len(level.robots)} robot slots, got {len(teams)} teams")
        self.level = level
        self.teams = teams
        # first: a root referee's controller template starts now and imports while the world
        # is made and a process's first match loads the compiled kernels
        self.fleet = Fleet(teams, level.limits if limits is None else limits, logs, isolate)
        self.seed = level.seed if seed is None else seed
        self.ideal = ideal
        tree = RandomTree(self.seed, noise_key)  # noise_key: the grader's secret (docs/integrity.md)
        # where the robots really stand, trial by trial (the first trial is the start): drawn
        # even when ideal, since that is the task's uncertainty, not the hardware's
        self.starts: tuple[Pose, ...] = placement.starts(level, tree)
        tiles = floor.grid(level.floor, tree, ideal)  # the experimenter's tiles: perfect when ideal
        self.trial_poses = placement.trial_poses(level, tree, self.starts, tiles)
        self.trial = 0
        self.world = World(level, None if ideal else tree, self.starts)
        self.sensing = Sensing(self.world, tree, ideal)
        self.inbox: list[list[SensorEvent]] = [[] for _ in teams]
        self.faults: list[list[Fault]] = [[] for _ in teams]
        self.stopped = [False] * len(teams)
        self.warnings = [Warnings() for _ in teams]
        self.drawings = [DrawingBudget(w) for w in self.warnings]  # what each robot may still draw
        self.tracker = TaskTracker(level, self.starts)
        self.estimates = [EstimateStats(level.rules.position_scale, level.rules.heading_scale) for _ in teams]
        self.rules = Rules(level)
        # how far any robot may travel (path length) in one control period: twice the fastest top speed, and
        # 0.5 m/s for a push or a bounce on top (the match can only end near a final target)
        top = max((r.model.max_wheel_speed for r in level.robots), default=0.0)
        self.reach = (2 * top + 0.5) * level.control_period
        self.writer: Recorder | None = recorder
        if replay is not None:
            self.writer = ReplayWriter(replay, replay_header(level, teams, self.seed, ideal, noise_key))
        self.deferred = Deferral()  # run() holds the replay's writes until the controllers compute
        self.end_reason = "time_limit"

    def _fault(self, slot: int, fault: Fault) -> None:
        self.faults[slot].append(fault)
        p = self.world.pose(slot)
        self.rules.controller(slot, fault.tick * self.level.steps_per_control, fault.kind, (p.x, p.y), fault.message)
        if fault.fatal:
            self.stopped[slot] = True
            self.world.command(slot, 0.0, 0.0)

    def _over(self) -> bool:
        if self.tracker.finished_count + sum(self.stopped) < len(self.teams):
            return False  # the cheap test first: this runs after every physics step
        return all(self.stopped[s] or self.tracker.done(s) for s in range(len(self.teams)))

    def observe(self) -> list[Observation | None]:
        """The first half of a control tick: deliver the sensor events since the last tick and
        return each robot's Observation (None for a stopped robot, which is counted estimate-less)."""
        time, tick = self.world.time, self.world.tick // self.level.steps_per_control
        detected = self.sensing.flush()
        for slot, detections in enumerate(detected):
            self.inbox[slot].extend(map(to_event, detections))
        if self.writer and any(detected):
            self.deferred.put(functools.partial(self.writer.events, detected))
        out: list[Observation | None] = []
        for slot in range(len(self.teams)):
            if self.stopped[slot]:
                self.estimates[slot].add(self.world.pose(slot), None)
                out.append(None)
                continue
            events, self.inbox[slot] = tuple(self.inbox[slot]), []
            out.append(Observation(tick=tick, time=time, events=events, trial=self.trial))
        return out

    def answer(self, slot: int, out: Command | Fault) -> float | None:
        """The second half of a control tick for one robot: take its controller's answer.
        Returns the tick quality its estimate earned (None without one)."""
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
        if self.writer:
            if out.estimate is not None:
                self.writer.record("est", t=time, r=slot, e=list(out.estimate))
            if drawings:
                self.writer.record("dbg", t=time, r=slot, d=drawings)
        return earned

    def play_own(self, slot: int, obs: Observation) -> None:
        """Robot `slot`'s own controller answers `obs` (a step-wise driver's other slots)."""
        self.answer(slot, self.fleet.bots[slot].step(obs))

    def report(self, slot: int) -> RobotReport:
        """Robot `slot`'s standing now, for a step-wise driver (referee.gym)."""
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

    def _control_tick(self) -> None:
        # every controller gets its observation before any answer is awaited: they compute at
        # once, and meanwhile the referee writes the replay of the period just stepped
        for slot, out in enumerate(exchange(self.fleet.bots, self.observe(), meanwhile=self.deferred.flush)):
            if out is not None:
                self.answer(slot, out)

    def run(self) -> MatchResult:
        """Run the match to its end and return the result (see docs/results.md)."""
        try:
            self.begin()
            self.deferred.hold()
            while not self.ended:
                self._control_tick()
                self.advance()
            return self.end()
        except BaseException:
            if self.writer is not None:
                self.writer.discard()  # an interrupted match leaves no half-written replay
            raise
        finally:
            self.close()

    def close(self) -> None:
        """End every controller (their processes, if isolated) and give back the CPU, if one was claimed."""
        self.fleet.close()

    def begin(self) -> None:
        """Start the controllers, give each its brief, record the first frame. A step-wise
        driver (referee.gym) then repeats observe / answer / advance until `ended`, and calls `end()`."""
        level, world = self.level, self.world
        faults = self.fleet.start([brief_for(level, slot) for slot in range(len(self.teams))])
        for slot, fault in enumerate(faults):
            if fault:
                self._fault(slot, fault)
        if self.writer:
            self.writer.frame(world.time, poses(world.state))
        self.total_steps = round(level.time_limit * level.physics_rate)
        self.ended = world.tick >= self.total_steps
        # localize trials begin at control ticks that cut the match into equal spans
        count = len(self.trial_poses)
        self.trial_ticks = [(j * level.control_ticks // count) * level.steps_per_control for j in range(1, count)]

    def _next_trial(self) -> None:
        """Carry every robot to its pose of the next trial, at rest (docs/rules.md): the
        observation that ends this control period is the first that tells the new trial."""
        self.trial += 1
        self.trial_ticks.pop(0)
        for slot, pose in enumerate(self.trial_poses[self.trial]):
            self.world.place(slot, pose)
        self.sensing.moved()
        self.rules.moved()
        if self.writer:
            self.deferred.put(functools.partial(self.writer.record, "trial", t=self.world.time, n=self.trial))

    def advance(self) -> None:
        """Step physics up to the next control tick, or to the end of the match: the time limit,
        or every robot done or stopped (sets `ended`). The checks after each step (sensing,
        task progress, rules, replay frames) run once for a run of steps, as step-by-step
        checks would give them. A run stops early only after a step at which the match may
        have ended: a robot still driving stood within its final target's radius."""
        if self.trial_ticks and self.world.tick >= self.trial_ticks[0]:
            self._next_trial()
        left = min(self.level.steps_per_control, self.total_steps - self.world.tick)
        while left:
            watch = self._finish_line()  # again after a stop: a robot that finished is no longer watched
            left -= self._steps(1 if watch is EVERY_STEP else left, watch)
            if not left:
                self._stood()
            if self._over():
                self.end_reason = (
                    "task_complete" if any(map(self.tracker.done, range(len(self.teams)))) else "all_stopped"
                )
                self.ended = True
                return
        self.ended = self.world.tick >= self.total_steps

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
        """Where, in a world state, the match may have ended at that step (None: it cannot
        end within this control period). Only a robot still driving that finishes its task can
        end it, at a step where it stands within its final target's radius. A robot that
        cannot reach every target it has left this period (see `reach`) is not watched: a lap
        that passes its final point before its last target does not stop the run at every step."""
        tracker = self.tracker
        going = [s for s in range(len(self.teams)) if not (self.stopped[s] or tracker.done(s))]
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
        """Up to `count` physics steps (fewer if a robot of `watch` reaches its point), then
        the checks after each of them; returns how many steps ran."""
        world, level = self.world, self.level
        first = world.tick + 1
        table, speeds = world.run(count, speeds=bool(level.rules.speed_limit), watch=watch)
        self.sensing.record_many(table)
        every = level.steps_per_record
        self.tracker.advance(table, first, level.physics_rate, every)
        self.rules.after_steps(world, table, speeds)
        if self.writer:
            start = -first % every  # the first step of this run that is recorded
            if start < len(table):
                recorded = frames(table[start::every], first + start, every, level.physics_rate)
                self.deferred.put(functools.partial(self.writer.frames, recorded))
        return len(table)

    def end(self) -> MatchResult:
        """Finish the rules, write the replay's last records, and return the result. A robot
        stopped by a fault is counted without an estimate to the time limit: a controller that
        faults on purpose ends nothing early (a match whose robots are all stopped ends at once)."""
        self.deferred.flush()
        world = self.world
        for slot, stopped in enumerate(self.stopped):
            if stopped:
                self.estimates[slot].silent_until(self.level.control_ticks)
        self.rules.finish(world)
        self.ended = True
        result = self._result()
        if self.writer:
            for slot in range(len(self.teams)):
                for foul in self.rules.fouls[slot]:
                    self.writer.record("foul", r=slot, **foul.to_record().to_dict())
                for fault in self.faults[slot]:
                    self.writer.record("fault", r=slot, **fault.to_dict())
            self.writer.close(result)
        return result

    def _result(self) -> MatchResult:
        """The result of the match as it stands (`end` calls it once the rules are finished)."""
        robots = [
            robot_result(
                slot,
                team.label,
                self.world.pose(slot),
                self.tracker,
                self.estimates[slot],
                self.rules.fouls[slot],
                self.faults[slot],
                self.stopped[slot],
                self.warnings[slot],
                self.level.time_limit,
            )
            for slot, team in enumerate(self.teams)
        ]
        return match_result(self.level, self.seed, self.ideal, self.world.time, self.end_reason, robots)


def play_match(
    level: Level,
    teams: list[Team],
    seed: int | None = None,
    replay: str | Path | None = None,
    ideal: bool = False,
    isolate: bool = True,
    limits: ControllerLimits | None = None,
    logs: Path | None = None,
    noise_key: str | None = None,
) -> MatchResult:
    """Play one match of loaded teams and return its result (the public `referee.run_match`
    names level and teams as a user does). `ideal` turns every sensor noise and failure and
    every drive error off; `isolate=False` runs the controllers inside this process instead of
    their own; `limits` replaces the level's controller limits (`fleet.NO_LIMITS` for debugging);
    `logs` is a folder for each controller's output (`slotN.log`), tracebacks included;
    `noise_key` (hex) mixes a secret into every random stream, so the public seed alone cannot
    reproduce the noise."""
    return Match(level, teams, seed, replay, ideal, isolate, limits, logs, noise_key=noise_key).run()
