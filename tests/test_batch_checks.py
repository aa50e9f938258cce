"""The match works out what is checked after each physics step (task progress, fouls, replay
frames, sensing) once per control period, from the states of the period's steps. A second
way to the same answer: `StepByStep`, a match that checks after every step, written here
the plain way (the per-step calls, in the documented order). Results and replay bytes must
agree, in matches with collisions, speeding, a robot leaving an open field, waypoints
reached mid-period, robots finishing, and a goto task."""

import textwrap

import pytest
from helpers import MINI_LEVEL, edited, exact_starts, variant

from levels.loader import parse_level
from referee.match import loop
from referee.match.simulation import STILL, Simulation
from referee.sandbox.teams import resolve

CHAOS = """
    from robots.api import Command, Controller

    class Chaos(Controller):
        def setup(self, brief):
            self.k = brief.slot

        def step(self, obs):
            phase = int(obs.time / 2 + self.k) % 3
            return [Command(0.3, 0.3), Command(0.3, -0.1), Command(-0.2, -0.25)][phase]
"""


OUT_AND_BACK = """
    from robots.api import Command, Controller

    class OutAndBack(Controller):
        def step(self, obs):
            return Command(0.3, 0.3) if obs.time % 16 < 8 else Command(-0.3, -0.3)
"""


class StepByStep(Simulation):
    """After each physics step: sensing stores the poses, each robot's task progress is
    updated (and its distance from the path sampled at the record rate until it finishes),
    the rules look at the world, a frame is recorded at the record rate; then the end test.
    At the control tick, the task hears whether each robot's wheels are still; the end test again."""

    def _advance(self):
        world, level, tracker = self.world, self.level, self.tracker
        every = level.steps_per_record
        for _ in range(level.steps_per_control):
            world.step()
            self.sensing.record()
            for slot in range(len(self.labels)):
                x, y = world.state[3 * slot], world.state[3 * slot + 1]
                tracker.update(slot, x, y, world.time)
                line = tracker.polyline[slot]
                if world.tick % every == 0 and line is not None and tracker.kind != "goto" and not tracker.done(slot):
                    tracker.sample(slot, line.distances([x], [y])[0])
            self.rules.after_step(world)
            if world.tick % every == 0:
                self.recorder.frame(
                    world.time, [(p.x, p.y, p.heading) for p in map(world.pose, range(len(self.labels)))]
                )
            if self._over():
                self._end_now()
                return
            if world.tick >= self.total_steps:
                break
        # at the control tick: each robot's wheels, still or not (a goto robot arrives by standing)
        for slot, drive in enumerate(world.drives):
            still = max(abs(w) for w in drive.wheels) <= STILL * drive.model.max_wheel_speed
            tracker.stand(slot, still, world.state[3 * slot], world.state[3 * slot + 1], world.time)
        if self._over():
            self._end_now()
            return
        self.ended = world.tick >= self.total_steps

    def _end_now(self):
        done = any(map(self.tracker.done, range(len(self.labels))))
        self.end_reason = "task_complete" if done else "all_stopped"
        self.ended = True


def play(level, teams, tmp_path, name, simulation_class):
    replay = tmp_path / f"{name}.replay"
    match = loop.Match(level, teams, seed=4, replay=replay, isolate=False)
    labels = [t.label for t in teams]
    match.simulation = simulation_class(level, labels, 4, recorder=match.recorder, defer=True)
    return match.run(), replay.read_bytes()


def same_both_ways(level, teams, tmp_path, monkeypatch):
    batched = play(level, teams, tmp_path, "batched", Simulation)
    single = play(level, teams, tmp_path, "single", StepByStep)
    assert batched[0] == single[0]
    assert batched[1] == single[1]
    return batched[0]


def test_collisions_and_speeding(tmp_path, monkeypatch):
    (tmp_path / "chaos.py").write_text(textwrap.dedent(CHAOS))
    level = variant("asabe-race", time_limit=20, rules__speed_limit=0.1, **exact_starts("asabe-race"))
    result = same_both_ways(level, [resolve(str(tmp_path / "chaos.py"))] * 4, tmp_path, monkeypatch)
    kinds = {f.kind for r in result.robots for f in r.fouls}
    assert {"robot_collision", "wall_collision", "speeding"} <= kinds


def test_leaving_an_open_field(tmp_path, monkeypatch):
    (tmp_path / "out.py").write_text(textwrap.dedent(OUT_AND_BACK))
    text = edited(
        MINI_LEVEL, {"field.walls": False, "time_limit": 30, "task.path": [[0.2, 0.5]], "robots.0.start": [1.6, 0.5, 0]}
    )
    level = parse_level(text.encode(), "open.yaml")
    result = same_both_ways(level, [resolve(str(tmp_path / "out.py"))], tmp_path, monkeypatch)
    # out past x = 2 m, back in, out again: two fouls
    assert [f.kind for f in result.robots[0].fouls] == ["leave_field", "leave_field"]


@pytest.mark.parametrize("spec", ["ref:bac", "ref:dead-reckoning"])
def test_waypoints_reached(tmp_path, monkeypatch, spec):
    # driving blind needs the start pose exactly; the laser reference finds its heading
    level = variant("asabe", time_limit=40, **(exact_starts("asabe") if spec == "ref:dead-reckoning" else {}))
    result = same_both_ways(level, [resolve(spec)], tmp_path, monkeypatch)
    assert result.robots[0].task.reached >= 5


def test_waypoints_weighed_by_the_path_followed(tmp_path, monkeypatch):
    # bac-line weighs each waypoint by its leg's distance from the line: the same samples per leg
    result = same_both_ways(variant("bac-line"), [resolve("ref:bac")], tmp_path, monkeypatch)
    task = result.robots[0].task
    assert task.reached == 10 and len(task.worth) == 10 and 0 < min(task.worth) <= max(task.worth) < 1


def test_robots_finishing_end_the_match_at_the_step(tmp_path, monkeypatch):
    # two short paths, each finished mid-period; two robots whose one waypoint is their start,
    # parked off robot 0's line to array B and robot 1's to O (with one of them hidden a robot
    # there sees two arrays alone: C, trimmed low, is too weak that far, and gives it no fix)
    level = variant(
        "asabe-race",
        time_limit=60,
        robots__0__path=[[0.5, 0.25], [0.6, 0.25]],
        robots__1__path=[[1.35, 0.97], [1.25, 0.97]],
        robots__2__start=[0.60, 0.55, 0],
        robots__2__path=[[0.60, 0.55]],
        robots__3__start=[1.23, 0.67, 180],
        robots__3__path=[[1.23, 0.67]],
    )
    result = same_both_ways(level, [resolve("ref:bac")] * 2 + [resolve("ref:idle")] * 2, tmp_path, monkeypatch)
    assert result.end_reason == "task_complete" and result.end_time < 30
    assert all(r.task.finished is not None for r in result.robots)
    assert result.end_time == max(r.task.finished for r in result.robots)


def test_goto(tmp_path, monkeypatch):
    # driving blind to the goal and standing there: it arrives at a control tick
    text = edited(MINI_LEVEL, {"task": {"kind": "goto", "radius": 0.2, "goal": [1.5, 0.5]}, "time_limit": 20})
    result = same_both_ways(
        parse_level(text.encode(), "goto.yaml"), [resolve("ref:dead-reckoning")], tmp_path, monkeypatch
    )
    assert result.robots[0].task.finished is not None and result.end_reason == "task_complete"


def test_a_lap_that_passes_its_final_point_first(tmp_path, monkeypatch):
    # back and forth: the final target is also the first, so each robot stands on it long
    # before it can finish; runs must not stop there, and the results must not change
    lap = [[0.60, 0.25], [0.90, 0.25], [0.60, 0.25], [0.90, 0.25], [0.60, 0.25]]
    level = variant("asabe-race", time_limit=40, robots__0__path=lap, robots__0__start=[0.45, 0.25, 0])
    teams = [resolve("ref:bac")] + [resolve("ref:idle")] * 3
    result = same_both_ways(level, teams, tmp_path, monkeypatch)
    assert result.robots[0].task.reached >= 3


def test_a_robot_with_far_targets_left_is_not_watched():
    level = variant(
        "asabe-race", robots__0__path=[[0.30, 0.25], [1.53, 0.25], [0.30, 0.25]], robots__0__start=[0.30, 0.25, 0]
    )
    match = Simulation(level, ["idle"] * 4)
    tracker = match.tracker
    tracker.update(0, 0.30, 0.25, 0.0)  # the first target, where the robot starts (also its last)
    assert tracker.next[0] == 1
    assert match._finish_line() is None or all(slot != 0 for slot, _, _ in match._finish_line().points)
    tracker.update(0, 1.53, 0.25, 1.0)  # now only the last target is left: watched wherever it is in reach
    match.world.state = (0.35, 0.25, 0.0, *match.world.state[3:])
    assert any(slot == 0 for slot, _, _ in match._finish_line().points)
