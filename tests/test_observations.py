"""Events reach controllers at the next control tick, in time order, and reveal no pose;
the Vannoy worked example's timings come out of the `vannoy` level."""

import dataclasses
import json
import textwrap

import pytest
from helpers import edited, run_cli

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots.api import Observation, SensorEvent

RECORDER = """
    import json
    from robots.api import Command, Controller

    class Recorder(Controller):
        def setup(self, brief):
            self.log = []
        def step(self, obs):
            self.log.append([obs.time, [[e.time, e.kind, e.beacon, e.angle] for e in obs.events]])
            if abs(obs.time - 12.0) < 1e-9:  # into its log: the one thing a sandbox lets out
                print("RECORDED", json.dumps(self.log), flush=True)
            return Command(0.0, 0.0)
"""


def test_a_detection_becomes_the_event_its_class_would_build():
    from arena.sensing.events import Detection
    from referee.match.views import to_event

    d = Detection(2, 1.25, "hit", "B", 0.5, (3, 4), 1, (0.0, 1.0, 2.0, 3.0))
    event = to_event(d)
    built = SensorEvent(1.25, "hit", "B", 0.5, (3, 4))
    assert event == built and vars(event) == vars(built) and repr(event) == repr(built)
    with pytest.raises(dataclasses.FrozenInstanceError):
        event.time = 2.0  # type: ignore[misc]


def test_vannoy_ideal_reflections_match_the_seed(tmp_path):
    team = tmp_path / "recorder.py"
    team.write_text(textwrap.dedent(RECORDER))
    # the worked example's robot, set down exactly at (8, 5) ft, compass 230 deg
    (tmp_path / "example.yaml").write_text(edited("vannoy", {"robots.0.placement": None}))
    proc = run_cli(
        "run",
        str(tmp_path / "example.yaml"),
        "--ideal",
        "--team",
        str(team),
        "--json",
        str(tmp_path / "r.json"),
        "--logs",
        str(tmp_path / "logs"),
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "r.json").read_text())["ideal"] is True
    recorded = (tmp_path / "logs" / "slot0.log").read_text().split("RECORDED ", 1)[1].splitlines()[0]
    events = [e for _, evs in json.loads(recorded) for e in evs]
    clicks = [e[0] for e in events if e[1] == "index"]
    assert clicks[:2] == pytest.approx([4.0, 8.0])
    for click in clicks[:2]:
        after = [e[0] - click for e in events if e[1] == "hit" and click < e[0] < click + 4.0]
        # seed table 1: "1.0556, 2.3628, 2.8508 s after the click", to its 0.1 ms rounding
        assert after == pytest.approx([1.0556, 2.3628, 2.8508], abs=2e-4)
    assert all(e[2] is None for e in events)  # reflections are unlabelled


def test_events_arrive_at_the_next_tick_in_order(tmp_path):
    log = []

    class Spy:
        def setup(self, brief):
            pass

        def step(self, obs):
            log.append(obs)
            from robots.api import Command

            return Command(0.05, 0.1)

    from referee.sandbox.teams import Team

    level = load_level(levels.path("asabe"))
    play_match(level, [Team("spy", spec="", code_hash="", factory=Spy)], ideal=False, isolate=False)
    assert len(log) > 100
    for prev, obs in zip(log, log[1:]):
        times = [e.time for e in obs.events]
        assert times == sorted(times)
        assert all(prev.time < t <= obs.time + 1e-9 for t in times)
    assert sum(len(o.events) for o in log) > 1000
    # nothing in what a controller receives names a pose
    names = {f.name for f in dataclasses.fields(Observation)} | {f.name for f in dataclasses.fields(SensorEvent)}
    assert names == {"tick", "time", "events", "trial", "kind", "beacon", "angle", "samples"}


def test_shared_crosstalk_level_runs(tmp_path, write_level):
    text = edited("asabe-race", {"beacons.crosstalk": "shared"})
    result = play_match(load_level(write_level(text)), [resolve("ref:dead-reckoning")] * 4)
    assert len(result["robots"]) == 4
