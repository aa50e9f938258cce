"""The tutorial's robot (`ref:tutorial`, the file `laserarena new` copies, the controllers
tutorial's last step) localizes and drives; whether it finishes the 'ASABE' letters is
tests/test_docs_run.py's, which plays the tutorial's copy."""

import ast
import sys

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots.controllers import tutorial

STATIC_STD = 0.0017  # m: Bac's Table 1, the static robot's position std with the real hardware's noise


def test_the_tutorials_robot_localizes_and_follows_the_line_when_ideal():
    # with no noise, the tracker must do better than Bac's hardware did with it
    static = play_match(load_level(levels.path("bac-static")), [resolve("ref:tutorial")], ideal=True)
    loc = static["robots"][0]["localization"]
    assert loc["position_rms"] < STATIC_STD and loc["fraction"] > 0.99
    line = play_match(load_level(levels.path("bac-line")), [resolve("ref:tutorial")], ideal=True)
    r = line["robots"][0]
    assert r["task"]["reached"] == 10 and r["localization"]["position_rms"] < STATIC_STD


def test_the_tutorials_robot_stays_one_file_on_the_public_api():
    # `laserarena new` copies this one file for a team: it may import the API, the toolkit and
    # the standard library only, all of which a team's sandbox has
    tree = ast.parse(open(tutorial.__file__).read())
    modules = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names} | {
        n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
    }
    allowed = {"robots.api", "robots.toolkit"}
    assert all(m.rpartition(".")[0] in allowed or m in allowed or m in sys.stdlib_module_names for m in modules), (
        modules
    )
