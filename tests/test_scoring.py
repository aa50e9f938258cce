"""The localization score (docs/rules.md): each control tick earns q = 1 / (1 + hypot(d / position
scale, h / heading scale)) for an estimate off by d and h, 0 without one; Q is their mean. So an
estimate withheld never raises the score, a heading error always costs, and the time bonus is
worth no more than the localization quality that earned it."""

import math
import textwrap

import pytest
from helpers import MINI_LEVEL, edited, variant
from hypothesis import given, settings
from hypothesis import strategies as st

from levels.loader import parse_level
from levels.model import Pose
from referee.match.estimates import EstimateStats, tick_quality
from referee.match.loop import play_match
from referee.match.scoring import score
from referee.match.tasks import TaskTracker
from referee.sandbox.teams import Team, resolve
from robots.api import Command
from robots.controllers.bac import Bac

IN = 0.0254
TRUTH = Pose(1.0, 0.5, 0.3)

# an estimate's position error (m) and heading error (rad), or None: no estimate that tick
errors = st.lists(
    st.one_of(st.none(), st.tuples(st.floats(0, 2.0), st.floats(0, math.pi))),
    min_size=1,
    max_size=60,
)


def quality_of(ticks: list, position_scale: float = 0.01, heading_scale: float = 0.05) -> EstimateStats:
    """The stats of a robot at TRUTH reporting estimates off by each tick's (d, h) (along +x, turned)."""
    stats = EstimateStats(position_scale, heading_scale)
    for e in ticks:
        stats.add(TRUTH, None if e is None else (TRUTH.x + e[0], TRUTH.y, TRUTH.heading + e[1]))
    return stats


def test_the_worked_example_of_the_rules():
    # docs/rules.md: on simi (scales 0.259 in, 0.8 deg) an estimate 0.1 in and 0.4 deg off earns
    # 1 / (1 + sqrt(0.3861^2 + 0.5^2)) = 1 / 1.6317 = 0.6128 of the tick's points
    q = tick_quality(0.1 * IN, math.radians(0.4), 0.259 * IN, math.radians(0.8))
    assert q == pytest.approx(0.6128, abs=1e-4)
    # at the scale itself, in position or in heading, half the points
    assert tick_quality(0.01, 0.0, 0.01, 0.05) == tick_quality(0.0, 0.05, 0.01, 0.05) == 0.5


@settings(max_examples=300, deadline=None)
@given(errors, st.data())
def test_withholding_any_estimates_never_raises_the_quality(ticks, data):
    withheld = data.draw(st.lists(st.booleans(), min_size=len(ticks), max_size=len(ticks)))
    kept = [None if drop else e for e, drop in zip(ticks, withheld)]
    assert quality_of(kept).quality <= quality_of(ticks).quality


@settings(max_examples=300, deadline=None)
@given(errors, st.data(), st.floats(1e-3, math.pi / 2))
def test_a_heading_error_always_costs(ticks, data, extra):
    reported = [i for i, e in enumerate(ticks) if e is not None and e[1] + extra <= math.pi]
    if not reported:
        return
    i = data.draw(st.sampled_from(reported))
    d, h = ticks[i]
    turned = list(ticks)
    turned[i] = (d, h + extra)
    assert quality_of(turned).quality < quality_of(ticks).quality


@given(errors)
def test_quality_is_the_mean_tick_quality_and_stays_in_0_1(ticks):
    stats = quality_of(ticks)
    by_hand = sum(0.0 if e is None else 1 / (1 + math.hypot(e[0] / 0.01, e[1] / 0.05)) for e in ticks) / len(ticks)
    assert stats.quality == pytest.approx(by_hand, rel=1e-12, abs=1e-15)
    assert 0.0 <= stats.quality <= 1.0


def finished_tracker(finish: float) -> TaskTracker:
    level = parse_level(MINI_LEVEL.encode(), "mini.yaml")
    tracker = TaskTracker(level)
    tracker.update(0, 1.0, 0.5, finish / 2)
    tracker.update(0, 1.5, 0.5, finish)
    return tracker


@settings(max_examples=200, deadline=None)
@given(errors, st.data(), st.floats(0.05, 3.9))
def test_the_whole_score_never_rises_by_withholding_and_time_is_scaled_by_quality(ticks, data, finish):
    withheld = data.draw(st.lists(st.booleans(), min_size=len(ticks), max_size=len(ticks)))
    tracker = finished_tracker(finish)
    full = score(tracker, 0, quality_of(ticks), [], 4.0)
    less = score(tracker, 0, quality_of([None if w else e for e, w in zip(ticks, withheld)]), [], 4.0)
    assert less.total <= full.total
    q = quality_of(ticks).quality
    assert full.task == 100 and full.time == pytest.approx(20 * (1 - finish / 4.0) * q)
    assert full.localization == pytest.approx(25 * q)


LOCALIZE = edited(MINI_LEVEL, {"task": {"kind": "localize"}, "time_limit": 6, "robots.0.placement": {"position": 0.05}})

GUESSER = """
    from robots.api import Command, Controller

    class Guesser(Controller):
        # reports the announced start, and on odd ticks (or none) a guess 3 cm off: which of its
        # estimates it sends is its own choice, and withholding them must not pay
        WITHHOLD = {withhold}

        def setup(self, brief):
            self.start = brief.start.pose

        def step(self, obs):
            x, y, h = self.start
            if obs.tick % 2:
                return Command(0.0, 0.0, estimate=None if self.WITHHOLD else (x + 0.03, y, h))
            return Command(0.0, 0.0, estimate=(x, y, h))
"""


def test_a_match_scores_withheld_guesses_no_higher(tmp_path):
    level = parse_level(LOCALIZE.encode(), "localize.yaml")
    totals = {}
    for withhold in (False, True):
        path = tmp_path / f"guesser{withhold}.py"
        path.write_text(textwrap.dedent(GUESSER.format(withhold=withhold)))
        for seed in (1, 2, 3):
            r = play_match(level, [resolve(str(path))], seed=seed, isolate=False)["robots"][0]
            totals[withhold, seed] = r["score"]["total"]
    assert all(totals[True, s] < totals[False, s] for s in (1, 2, 3)), totals


QUITTER = """
    from robots.api import Command, Controller

    class Quitter(Controller):
        # reports the announced start (it knows it within 0.1 in and 1 deg) for the first trial,
        # then {how}, so that the match, whose only robot is stopped, ends at once
        def setup(self, brief):
            self.start = brief.start.pose

        def step(self, obs):
            if obs.trial >= 1 and {quit}:
                {action}
            return Command(0.0, 0.0, estimate=self.start)
"""


def test_faulting_to_end_a_match_early_never_pays(tmp_path):
    level = variant("simi", time_limit=6)  # ten trials of 0.6 s: the first is the announced start
    teams = {}
    for name, how, action in (
        ("reporter", "goes on reporting it", "pass"),
        ("raiser", "raises", "raise RuntimeError('I only knew the first trial')"),
        ("nan", "sends a command that is not one", "return Command(float('nan'), 0.0)"),
    ):
        path = tmp_path / f"{name}.py"
        path.write_text(textwrap.dedent(QUITTER.format(how=how, quit=name != "reporter", action=action)))
        teams[name] = resolve(str(path))
    for seed in (1, 2, 3):
        reporter = play_match(level, [teams["reporter"]], seed=seed, isolate=False)["robots"][0]
        for name in ("raiser", "nan"):
            result = play_match(level, [teams[name]], seed=seed, isolate=False)
            quitter = result["robots"][0]
            assert result["end_reason"] == "all_stopped" and result["end_time"] < 1.0
            assert quitter["stopped"] and quitter["localization"]["ticks"] == level.control_ticks == 120
            # it earned the first trial's quality and nothing after: no more than reporting on
            assert quitter["localization"]["quality"] <= reporter["localization"]["quality"]
            assert quitter["score"]["total"] < reporter["score"]["total"]


class Turned(Bac):
    """ref:bac with its reported heading turned by 20 degrees: the same driving, a worse estimate."""

    def step(self, observation):
        out = super().step(observation)
        if out.estimate is None:
            return out
        x, y, h = out.estimate
        return Command(out.left, out.right, estimate=(x, y, h + math.radians(20)))


@pytest.mark.parametrize("level", ["bac-static", "asabe"])
def test_a_heading_turned_by_20_degrees_costs_at_least_5_points(level):
    lv = variant(level, time_limit=40)  # asabe: the first strokes of the letters
    ref = play_match(lv, [resolve("ref:bac")], seed=5, isolate=False)["robots"][0]
    turned = play_match(lv, [Team("turned", "turned", "sha256:0", factory=Turned)], seed=5, isolate=False)["robots"][0]
    assert turned["final_pose"] == ref["final_pose"]  # the same match, driven alike
    assert turned["score"]["total"] <= ref["score"]["total"] - 5
