"""Headings are reported in (-pi, pi]: the world, the referee's poses, placements and the team
side's toolkit all read a heading of -pi (or 3 pi) as pi, so two equal headings read alike."""

import math

import pytest

import levels
from arena.angles import wrap
from arena.world import World
from levels.loader import load_level
from levels.model import Pose
from robots.toolkit.angles import wrap as team_wrap


@pytest.mark.parametrize("f", [wrap, team_wrap], ids=["arena", "robots"])
@pytest.mark.parametrize(
    "angle, expected",
    [
        (-math.pi, math.pi),
        (3 * math.pi, math.pi),
        (math.pi, math.pi),
        (-3 * math.pi, math.pi),
        (0.5, 0.5),
        (-0.5, -0.5),
    ],
)
def test_a_heading_wraps_into_the_half_open_range(f, angle, expected):
    assert f(angle) == pytest.approx(expected, abs=1e-12)
    assert -math.pi < f(angle) <= math.pi


@pytest.mark.parametrize("f", [wrap, team_wrap], ids=["arena", "robots"])
def test_the_wrap_agrees_with_atan2_away_from_the_cut(f):
    for k in range(-40, 41):
        a = k * 0.37
        assert f(a) == pytest.approx(math.atan2(math.sin(a), math.cos(a)), abs=1e-12)


def test_a_robot_facing_minus_pi_reports_pi():
    world = World(load_level(levels.path("asabe")))
    pose = world.pose(0)
    world.place(0, Pose(pose.x, pose.y, -math.pi))
    assert world.pose(0).heading == math.pi
