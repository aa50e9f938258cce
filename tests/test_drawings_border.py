"""Debug drawings are checked at the border: the ones that cannot be drawn (unknown kind, not
finite, wrong sizes, too many in a tick, not a Drawing at all) are dropped with a typed warning
in the result, the controller goes on, and the replay's drawings render and play."""

from __future__ import annotations

import json

import pytest
from helpers import MINI_LEVEL, run_cli

from referee.records.replay_reader import load

BAD = """from robots.api import Command, Controller, Drawing


class Scribbler(Controller):
    def step(self, obs):
        good = Drawing("circle", ((1.0, 0.5),), 0.1)
        bad = [Drawing("banana", ((1.0, 0.5),)), Drawing("point", ((float("nan"), 0.5),)),
               Drawing("line", ((1.0, 0.5),)), Drawing("circle", ((1.0, 0.5),), -1.0), "not a drawing"]
        flood = [Drawing("point", ((0.1, 0.1),))] * 300 if obs.tick == 2 else []
        return Command(0.1, 0.1, None, tuple([good] + bad + flood))
"""


@pytest.mark.parametrize("extra", [[], ["--in-process"]])
def test_bad_drawings_are_dropped_with_warnings(shared_dir, extra):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    (shared_dir / "bot.py").write_text(BAD)
    (shared_dir / "bot.py").chmod(0o644)
    out = run_cli(
        "run", "level.yaml", "--team", "bot.py", "--json", "r.json", "--replay", "r.replay", *extra, cwd=shared_dir
    )
    assert out.returncode == 0, out.stderr
    robot = json.loads((shared_dir / "r.json").read_text())["robots"][0]
    assert robot["faults"] == [] and not robot["stopped"]
    ticks = round(4 / 0.05)  # the mini level: 4 s of 0.05 s control ticks (the first at t = 0)
    by_kind = {w["kind"]: (w["tick"], w["count"], w["message"]) for w in robot["warnings"]}
    # one warning per kind, however many drawings: the first tick, the count, the first example;
    # five bad drawings a tick, and at tick 2 one more standing for the 50 past the count cap
    assert by_kind["drawing_dropped"] == (0, 5 * ticks + 1, "kind 'banana' is not one of point, line, circle, text")
    # the flood's points fill the tick's record up to its byte budget; the rest are set aside
    tick, count, message = by_kind["drawing_over_tick"]
    assert (tick, message) == (2, "drawings past the 16384 bytes a tick may have") and 0 < count < 250
    assert set(by_kind) == {"drawing_dropped", "drawing_over_tick"}
    replay = load(shared_dir / "r.replay")
    kinds = {g["kind"] for d in replay.debug for g in d["d"]}
    assert kinds == {"circle", "point"}  # only what can be drawn reached the replay
    assert (
        run_cli("render", "r.replay", "--out", "frames", "--fps", "2", "--size", "320x240", cwd=shared_dir).returncode
        == 0
    )
    assert len(list((shared_dir / "frames").glob("*.png"))) >= 8
    watched = run_cli("watch", "r.replay", "--frames", "3", "--size", "320x240", cwd=shared_dir)
    assert watched.returncode == 0, watched.stderr
