"""`laserarena plot`: the error series equal a direct computation from the replay's records,
and the curves and marks are drawn where the chart's axes put them."""

import math

import pygame
import pytest
import yaml
from helpers import run_cli

import levels
from arena.draw import color
from levels.loader import parse_level
from referee.match.loop import play_match
from referee.media.plot import BACKGROUND, FAULT, FOUL, GRID, error_figure
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve

CRASH = """\
from robots.controllers.bac import Bac


class Crash(Bac):
    def step(self, observation):
        if observation.time >= 3.0:
            raise RuntimeError("boom")
        return super().step(observation)
"""


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    """Six seconds of the race: slot 0 crashes at 3 s, a speed limit makes fouls."""
    folder = tmp_path_factory.mktemp("plot")
    (folder / "crash.py").write_text(CRASH)
    d = yaml.safe_load(levels.path("asabe-race").read_text())
    d["time_limit"] = 6
    d["rules"] = {"speed_limit": 0.05}
    level = parse_level(yaml.safe_dump(d).encode(), "race6.yaml")
    path = folder / "race.replay"
    result = play_match(
        level, [resolve(str(folder / "crash.py"))] + [resolve("ref:bac")] * 3, replay=path, isolate=False
    )
    return path, result


def direct_errors(rep, slot):
    """Position (mm) and heading (deg) errors, each estimate against the frame recorded at its time."""
    frames = {round(t, 6): poses for t, poses in rep.frames}
    pos, hdg = [], []
    for e in rep.estimates:
        if e["r"] != slot:
            continue
        x, y, h = frames[round(e["t"], 6)][slot]  # control ticks fall on frames here (0.2 s = 6 / 30 s)
        ex, ey, eh = e["e"]
        pos.append(1000 * math.hypot(ex - x, ey - y))
        hdg.append(math.degrees(abs(math.atan2(math.sin(eh - h), math.cos(eh - h)))))
    return pos, hdg


def test_series_equal_a_direct_computation_and_the_referees_rms(replay):
    path, result = replay
    rep = load(path)
    fig = error_figure(path)
    assert len(fig.robots) == 4
    for r in fig.robots:
        pos, hdg = direct_errors(rep, r.slot)
        assert r.position_mm == pytest.approx(pos, abs=1e-9)
        assert r.heading_deg == pytest.approx(hdg, abs=1e-9)
        rms = math.sqrt(sum(v * v for v in pos) / len(pos))
        assert rms == pytest.approx(1000 * result["robots"][r.slot]["localization"]["position_rms"], abs=0.01)
    crashed = fig.robots[0]
    assert crashed.faults == (pytest.approx(3.0),) and max(crashed.fixes) < 3.0
    assert crashed.fouls == pytest.approx(sorted(f["time"] for f in result["robots"][0]["fouls"]), abs=1e-9)
    assert sum(len(r.fouls) for r in fig.robots) > 0


def test_curves_and_marks_are_where_the_axes_put_them(replay, tmp_path):
    path, _ = replay
    out = tmp_path / "err.png"
    fig = error_figure(path, out)
    image = pygame.image.load(str(out))
    assert image.get_size() == fig.size
    for r in fig.robots:
        for panel, values in ((r.position, r.position_mm), (r.heading, r.heading_deg)):
            marks = {panel.to_pixel(t, 0)[0] for t in r.fouls + r.faults}
            checked = 0
            for t, v in zip(r.times, values):
                x, y = panel.to_pixel(t, v)
                if any(abs(x - m) <= 1 for m in marks):
                    continue
                assert tuple(image.get_at((x, y)))[:3] == color(r.slot), (r.slot, t, v)
                checked += 1
            assert checked > 10
            left, top, w, h = panel.rect
            for times, c in ((r.faults, FAULT), (r.fouls, FOUL)):
                for t in times:
                    x = panel.to_pixel(t, 0)[0]
                    if c == FOUL and any(abs(x - panel.to_pixel(f, 0)[0]) <= 1 for f in r.faults):
                        continue
                    assert tuple(image.get_at((x, top + 1)))[:3] == c
            # above the highest point of the curve lies nothing but paper and grid
            peak = max(values)
            clear = [
                image.get_at((x, top + 2))[:3]
                for x in range(left + 2, left + w - 2, 7)
                if all(abs(x - m) > 1 for m in marks)
            ]
            if panel.to_pixel(0, peak)[1] > top + 4:
                assert set(clear) <= {BACKGROUND, GRID}


def test_cli_plot_writes_the_png_and_bad_input_is_one_line(replay, tmp_path):
    path, _ = replay
    proc = run_cli("plot", str(path), "--out", str(tmp_path / "e.png"))
    assert proc.returncode == 0, proc.stderr
    assert "0 crash.py" in proc.stdout
    image = pygame.image.load(str(tmp_path / "e.png"))  # a real PNG of the figure's size
    assert image.get_width() >= 400 and image.get_height() >= 300
    (tmp_path / "bad.replay").write_text("nope")
    for args in (["plot", str(tmp_path / "bad.replay")], ["plot", str(path), "--out", str(tmp_path / "no" / "e.png")]):
        proc = run_cli(*args)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_the_truth_is_never_interpolated_across_a_move_even_one_on_a_frame():
    from referee.media.error_series import truth_at

    # frames at 0, 1 and 2 s; the robot carried from (0, 0) to (3, 3) at 1 s, the frame at 1 s
    # still showing where it was, the next where it was put
    frames = [(0.0, [[0.0, 0.0, 0.0]]), (1.0, [[0.0, 0.0, 0.0]]), (2.0, [[3.0, 3.0, 0.0]])]
    times = [f[0] for f in frames]
    assert truth_at(frames, times, 0, 1.0, [1.0]) == (0.0, 0.0, 0.0)
    assert truth_at(frames, times, 0, 1.25, [1.0]) == (3.0, 3.0, 0.0)  # not (0.75, 0.75): after the move
    assert truth_at(frames, times, 0, 1.25, []) == (0.75, 0.75, 0.0)  # no move: the drive between frames
    # a move between two frames: before it the earlier frame, after it the later one
    assert truth_at(frames, times, 0, 1.4, [1.5]) == (0.0, 0.0, 0.0)
    assert truth_at(frames, times, 0, 1.6, [1.5]) == (3.0, 3.0, 0.0)
