"""Rendering real frames headless: pixels where robots and beacons must be; a decodable MP4."""

import math

import imageio_ffmpeg
import pygame
import pytest

import levels
from arena.draw import BEACON, FIELD, Painter, color
from levels.loader import load_level
from referee.match.loop import play_match
from referee.media.render import Scenes, render
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    path = tmp_path_factory.mktemp("r") / "race.replay"
    text = levels.path("asabe-race").read_text().replace("time_limit: 180", "time_limit: 6")
    from levels.loader import parse_level

    play_match(
        parse_level(text.encode(), "race6.yaml"), [resolve("ref:dead-reckoning")] * 4, replay=path, isolate=False
    )
    return path


def test_frame_shows_robots_and_beacons_where_they_are(replay, tmp_path):
    rep = load(replay)
    scenes = Scenes(rep)
    painter = Painter(scenes.level, (960, 640))
    surface = pygame.Surface((960, 640))
    t = 3.0
    painter.draw(surface, scenes.at(t))
    pygame.image.save(surface, str(tmp_path / "f.png"))
    frame = rep.frames[round(t * rep.header["record_rate"])][1]
    for slot, (x, y, h) in enumerate(frame):
        # a point inside the body, away from the heading tick and the slot label
        px, py = painter.to_screen(
            x - 0.03 * math.cos(h) + 0.025 * math.sin(h), y - 0.03 * math.sin(h) - 0.025 * math.cos(h)
        )
        assert tuple(surface.get_at((px, py)))[:3] == color(slot), slot
    for b in scenes.level.beacons.items:  # sensor arrays are drawn as bars through their centre
        assert tuple(surface.get_at(painter.to_screen(b.x, b.y)))[:3] == BEACON["sensor_array"]
    # a bare stretch of the field is field-coloured, and the field is to scale
    assert tuple(surface.get_at(painter.to_screen(0.915, 0.05)))[:3] == FIELD
    (x0, _), (x1, _) = painter.to_screen(0, 0), painter.to_screen(1.83, 0)
    (_, y0), (_, y1) = painter.to_screen(0, 0), painter.to_screen(0, 1.22)
    assert (x1 - x0) / (y0 - y1) == pytest.approx(1.83 / 1.22, rel=0.01)


def test_field_fits_any_size():
    for name in ("vannoy", "asabe"):  # 6.4 m tall, 1.8 m wide
        lv = load_level(levels.path(name))
        for size in ((960, 640), (640, 960), (320, 240)):
            p = Painter(lv, size)
            f = lv.field
            for x, y in ((f.xmin, f.ymin), (f.xmax, f.ymax)):
                sx, sy = p.to_screen(x, y)
                assert 0 <= sx < size[0] and 0 <= sy < size[1]


def test_mp4_decodes_to_the_right_frame_count(replay, tmp_path):
    out = tmp_path / "m.mp4"
    n = render(replay, out, fps=10, size=(480, 320), start=1.0, end=4.0, quiet=True)
    assert n == 31
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == n
    pngs = render(replay, tmp_path / "png", fps=5, size=(320, 240), start=0, end=1, quiet=True)
    assert pngs == 6 and len(list((tmp_path / "png").glob("frame_*.png"))) == 6


def test_watch_plays_a_replay_and_a_live_match_headless(replay):
    from referee.media.watch import watch

    assert watch(str(replay), max_frames=5, speed=8.0) == 5
    assert watch("bac-line", max_frames=5, speed=8.0) == 5


def test_bad_replays_and_arguments_are_one_line_errors(replay, tmp_path):
    from helpers import run_cli

    cut = tmp_path / "cut.replay"
    cut.write_bytes(replay.read_bytes()[: len(replay.read_bytes()) // 2])
    (tmp_path / "text.replay").write_text("not a replay")
    for args in (
        ["verify", str(tmp_path / "text.replay")],
        ["render", str(cut), "--out", str(tmp_path / "o.mp4")],
        ["render", str(replay), "--out", str(tmp_path / "o.mp4"), "--size", "12x"],
        ["render", str(tmp_path / "missing.replay"), "--out", str(tmp_path / "o.mp4")],
    ):
        proc = run_cli(*args)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, (args, proc.stderr)
        assert "Traceback" not in proc.stderr
    assert "truncated" in run_cli("render", str(cut), "--out", str(tmp_path / "o.mp4")).stderr
