"""What a team's legal data and legal slowness can cost the organizer: debug drawings up to
every per-tick cap, every tick, leave at most the documented bytes in the replay; warnings of
any variety are one per kind in the result; a controller that thinks just under its step time
every tick is stopped at its think budget (docs/rules.md, docs/security.md)."""

import dataclasses
import gzip
import json
import math

from hostile.hostile_kit import FAST, assert_contained, assert_others_unharmed, hostile_match
from referee.match.drawings import MATCH_BYTES, TICK_BYTES
from referee.match.fleet import NO_LIMITS
from referee.records.canonical import dumps
from robots._host.protocol import MAX_DRAWINGS, MAX_POINTS, MAX_TEXT

# every drawing as large as the caps allow: the longest numbers, text of astral characters
# (12 bytes each as JSON escapes), as many drawings as a tick may have
FLOOD = f"""
P = [(-999000.123456789 - i, -999000.987654321 - i) for i in range({MAX_POINTS})]
class Flood(Controller):
    def step(self, obs):
        return Command(0.0, 0.0, None, tuple(Drawing("text", P, 999999.5, "\\U0001F600" * {MAX_TEXT}) for _ in range({MAX_DRAWINGS})))
"""

# a different text for every dropped drawing: as many reasons as drawings
VARIED = f"""
class Varied(Controller):
    def step(self, obs):
        return Command(0.0, 0.0, None, tuple(Drawing(f"kind{{obs.tick}}-{{i}}" + "x" * 100, ((0.0, 0.0),)) for i in range({MAX_DRAWINGS})))
"""

# just under its step time every tick: within every per-tick rule
SLOW = """
class Slow(Controller):
    def step(self, obs):
        time.sleep(0.04)
        return Command(0.0, 0.0)
"""

ROOMY = dataclasses.replace(FAST, step_time=2.0, step_deadline=4.0, overage_bank=30.0)  # no timeouts for the flood


def _dbg_lines(replay) -> list[bytes]:
    return [line for line in gzip.open(replay).read().splitlines() if b'"k":"dbg"' in line and b'"r":0,' in line]


def test_drawings_at_every_cap_every_tick_stay_within_the_match_budget(tmp_path):
    replay = tmp_path / "flood.replay"
    result = hostile_match(tmp_path, FLOOD, seconds=40.0, replay=replay, limits=ROOMY)
    assert_others_unharmed(result)
    robot = result["robots"][0]
    assert robot["faults"] == [] and not robot["stopped"]
    lines = _dbg_lines(replay)
    # each tick's record within its budget, the match's within its own, counted in the replay's bytes
    assert lines and max(len(line) + 1 for line in lines) <= TICK_BYTES
    assert sum(len(line) + 1 for line in lines) <= MATCH_BYTES
    assert len(lines) < 200  # the 200 ticks' floods would be more: the budget ran out
    kinds = {w["kind"]: w for w in robot["warnings"]}
    assert set(kinds) == {"drawing_over_tick", "drawing_over_match"}
    assert kinds["drawing_over_match"]["message"] == f"drawings past the {MATCH_BYTES} bytes a match may have"
    assert kinds["drawing_over_match"]["tick"] in (len(lines) - 1, len(lines))  # the tick cut short, or the next
    # the budgets are charged as the replay writes a drawing
    first = json.loads(lines[0])["d"][0]
    assert len(dumps(first, indent=None)) > 2 * MAX_TEXT * 6


def test_warnings_of_endless_variety_are_one_per_kind(tmp_path):
    result = hostile_match(tmp_path, VARIED)
    assert_others_unharmed(result)
    (warning,) = result["robots"][0]["warnings"]
    ticks = result["robots"][0]["localization"]["ticks"]
    assert warning["kind"] == "drawing_dropped" and warning["count"] == MAX_DRAWINGS * ticks
    assert warning["message"].startswith("kind 'kind0-0xxx") and len(warning["message"]) <= 203
    assert len(json.dumps(result.to_dict()["robots"][0]["warnings"])) < 400


def first_over(answer: float, budget: float = 0.3) -> int:
    """The tick whose answer takes answers of `answer` s each past `budget` s (ticks count from 0)."""
    return math.floor(budget / answer)


def test_thinking_just_under_the_step_time_every_tick_meets_the_think_budget(tmp_path):
    limits = dataclasses.replace(FAST, think_budget=0.05)  # 0.3 s over a 6 s match; Slow takes 0.04 s a tick
    result = hostile_match(tmp_path, SLOW, limits=limits)
    bad = assert_contained(
        result, "timeout", "think budget used up: answers took over the 0.3 s this match allows (think_budget 0.05 s"
    )
    # the answer to tick t is the (t+1)th. Each takes at least its 0.04 s sleep, so the 0.3 s are
    # used up by the 8th answer (tick 7) at the latest. The lower bound allows answers of twice
    # the sleep on a loaded machine: the budget charges what answers take, not a fixed sum per tick
    assert first_over(0.08) <= bad["faults"][0]["tick"] <= first_over(0.04)
    free = hostile_match(tmp_path, SLOW, limits=NO_LIMITS)  # --no-limits: no budget either
    assert result["robots"][0]["faults"] and free["robots"][0]["faults"] == []
