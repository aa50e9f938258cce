"""Typed result records: attribute and JSON-name access, a schema that cannot drift, real
results that validate against it (with an independent validator) and round-trip byte for byte."""

import json
import textwrap
from pathlib import Path

import jsonschema
import pytest
from helpers import MINI_LEVEL, edited, variant

from levels.loader import parse_level
from referee.match.loop import play_match
from referee.records.canonical import dumps
from referee.records.result_schema import SCHEMA_FILE, schema_text
from referee.records.results import MatchResult
from referee.sandbox.teams import resolve

SCHEMA = Path(__file__).resolve().parent.parent / "docs" / "schema" / SCHEMA_FILE


def test_the_committed_schema_is_the_generated_one():
    assert SCHEMA.read_text() == schema_text(), "run: python -m referee.records.result_schema docs/schema"


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Real results of every task kind, with fouls (a robot driving into a wall) and a fault."""
    folder = tmp_path_factory.mktemp("teams")
    crash = folder / "crash.py"
    crash.write_text(
        textwrap.dedent("""
        from robots.api import Command, Controller

        class Crash(Controller):
            def step(self, obs):
                if obs.tick == 5:
                    raise RuntimeError("boom")
                return Command(0.17, 0.17)
    """)
    )
    waypoints = parse_level(edited(MINI_LEVEL, {"time_limit": 8}).encode(), "mini.yaml")
    return [
        play_match(waypoints, [resolve(str(crash))], isolate=False),
        play_match(waypoints, [resolve("ref:dead-reckoning")], isolate=False),
        play_match(variant("bac-static", time_limit=3), [resolve("ref:bac")], isolate=False),
        play_match(variant("vannoy", time_limit=5), [resolve("ref:vannoy")], isolate=False),
        play_match(variant("asabe-race", time_limit=4), [resolve("ref:bac")] * 4, isolate=False),
    ]


def test_the_results_cover_every_optional_part(results):
    kinds = {r.robots[0].task.kind for r in results}
    assert kinds == {"waypoints", "localize", "goto", "race"}
    assert any(r.robots[0].faults for r in results) and any(r.robots[0].task.get("cross_track") for r in results)
    assert "final_distance" in results[3].robots[0].task and "reached" not in results[3].robots[0].task


def test_real_results_validate_against_the_schema(results):
    validator = jsonschema.Draft202012Validator(json.loads(SCHEMA.read_text()))
    for result in results:
        validator.validate(json.loads(dumps(result)))


def test_results_round_trip_byte_for_byte(results):
    for result in results:
        text = dumps(result)
        back = MatchResult.from_json(text)
        assert back == MatchResult.from_dict(json.loads(text))
        assert dumps(back) == text == dumps(result.to_dict())


def test_attribute_and_json_name_access_agree(results):
    r = results[0]
    robot = r.robots[0]
    assert robot.score.total == r["robots"][0]["score"]["total"]
    assert robot.faults[0].kind == robot["faults"][0]["kind"] == "exception"
    assert robot.score.total == pytest.approx(
        robot.score.task + robot.score.time + robot.score.localization - robot.score.penalties
    )
    with pytest.raises(KeyError):
        results[2].robots[0].task["reached"]  # a localize task has no waypoints
    assert results[2].robots[0].task.get("reached", "none") == "none"
    with pytest.raises(AttributeError):
        robot.slot = 3  # frozen


def test_a_damaged_result_is_refused_by_the_types():
    good = {
        "format": "laserarena-result",
        "version": 2,
        "software": "x",
        "level": {"name": "l", "hash": "h"},
        "seed": 1,
        "ideal": False,
        "end_time": 1.0,
        "end_reason": "time_limit",
        "robots": [],
    }
    MatchResult.from_dict(good)
    with pytest.raises(Exception, match="seed"):
        MatchResult.from_dict({**good, "seed": "one"})
