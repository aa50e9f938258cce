"""Same level, seed and controllers: byte-identical result JSON and replay, in one process or two."""

import json

from helpers import run_cli

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.records.canonical import dumps
from referee.records.replay_reader import load
from referee.records.results import MatchResult
from referee.sandbox.teams import resolve


def test_two_processes_give_identical_bytes(tmp_path):
    outs = []
    for i in range(2):
        j, r = tmp_path / f"r{i}.json", tmp_path / f"r{i}.replay"
        proc = run_cli("run", "asabe-race", "--seed", "7", "--json", str(j), "--replay", str(r), "--quiet")
        assert proc.returncode == 0, proc.stderr
        outs.append((j.read_bytes(), r.read_bytes()))
    assert outs[0] == outs[1]
    # and the same bytes again inside this process
    level = load_level(levels.path("asabe-race"))
    replay = tmp_path / "here.replay"
    result = play_match(level, [resolve(level.default_controller) for _ in level.robots], seed=7, replay=replay)
    assert (dumps(result) + "\n").encode() == outs[0][0]
    assert replay.read_bytes() == outs[0][1]
    # the replay carries a frame per record period and ends with the same result
    rep = load(replay)
    assert rep.header["seed"] == 7 and rep.header["level"]["hash"] == level.hash
    assert rep.result == MatchResult.from_json(outs[0][0])
    # (a frame every record period from t = 0; a match may end between two)
    end_tick = round(rep.result.end_time * level.physics_rate)
    assert len(rep.frames) == end_tick // level.steps_per_record + 1
    assert rep.events and rep.estimates


def test_seed_is_recorded_and_defaults_to_the_level_seed(tmp_path):
    j = tmp_path / "r.json"
    assert run_cli("run", "bac-static", "--json", str(j), "--quiet").returncode == 0
    assert json.loads(j.read_text())["seed"] == load_level(levels.path("bac-static")).seed
