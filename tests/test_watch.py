"""The viewer, headless: the key help shows at the start, hides by itself and toggles with h
and ?; the HUD gives each robot's score so far, task progress and estimate error, checked
against the replay's records and the referee's result."""

import math
import os
import re
import subprocess
import sys

import pygame
import pytest
import yaml

import levels
from arena.draw import HUD_TEXT, OVERLAY_TEXT, _mix, color
from levels.loader import parse_level
from referee.match.loop import play_match
from referee.media.render import Scenes
from referee.media.watch import HELP_SECONDS, KEYS, Viewer
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve

SIZE = (960, 700)


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    os.environ["SDL_VIDEODRIVER"] = "dummy"  # the test's choice, never the code's
    d = yaml.safe_load(levels.path("asabe-race").read_text())
    d["time_limit"] = 12
    d["rules"]["speed_limit"] = 0.05  # ref:bac drives faster: speeding fouls to score
    path = tmp_path_factory.mktemp("watch") / "race.replay"
    result = play_match(
        parse_level(yaml.safe_dump(d).encode(), "race12.yaml"), [resolve("ref:bac")] * 4, replay=path, isolate=False
    )
    return path, result


def count(surface, rect, rgb) -> int:
    return sum(
        1
        for x in range(rect.left, rect.right)
        for y in range(rect.top, rect.bottom)
        if tuple(surface.get_at((x, y)))[:3] == rgb
    )


def test_help_shows_at_start_hides_by_itself_and_toggles(replay):
    viewer = Viewer(Scenes(load(replay[0])), SIZE)
    surface = pygame.Surface(SIZE)
    viewer.draw(surface)
    box = viewer.help_rect
    assert box is not None and box.width > 200 and box.height > 20 * len(KEYS)
    assert count(surface, box, OVERLAY_TEXT) > 200  # the key text is drawn in it
    viewer.advance(HELP_SECONDS / 2)
    assert viewer.help_shown
    viewer.advance(HELP_SECONDS)  # the start-up help goes by itself
    bare = pygame.Surface(SIZE)
    viewer.draw(bare)
    assert viewer.help_rect is None and count(bare, box, OVERLAY_TEXT) < count(surface, box, OVERLAY_TEXT) / 4
    viewer.key(0, "?")
    viewer.draw(surface)
    assert viewer.help_rect == box
    viewer.advance(60.0)  # pinned: stays
    assert viewer.help_shown
    viewer.key(pygame.K_h)
    assert not viewer.help_shown
    assert viewer.key(pygame.K_q) is False


def direct_standing(rep, result, slot, t):
    """Score so far, waypoints reached and latest estimate error, from the records (docs/rules.md):
    each tick's quality 1 / (1 + hypot(d / position_scale, h / heading_scale)), 0 without an
    estimate, summed over the ticks so far and divided by the match's ticks (Q is the mean over
    them all), with the scales of the level the replay carries."""
    rules = yaml.safe_load(rep.header["level"]["text"])["rules"]
    position_scale, heading_scale = rules["position_scale"], math.radians(rules["heading_scale"])
    robot = result["robots"][slot]
    reached = sum(1 for r in robot["task"]["reached_at"] if r <= t)
    frames = {round(ft, 6): poses for ft, poses in rep.frames}
    errors = []
    for e in rep.estimates:
        if e["r"] == slot and e["t"] <= t + 1e-9:
            x, y, h = frames[round(e["t"], 6)][slot]
            errors.append(
                (
                    math.hypot(e["e"][0] - x, e["e"][1] - y),
                    abs(math.atan2(math.sin(e["e"][2] - h), math.cos(e["e"][2] - h))),
                )
            )
    ticks = robot["localization"]["ticks"]  # Q is the mean over the match's ticks: each tick earns its share
    quality = sum(1 / (1 + math.hypot(d / position_scale, h / heading_scale)) for d, h in errors) / ticks
    score = (
        100 * reached / robot["task"]["total"]
        + 25 * quality
        - sum(f["penalty"] for f in robot["fouls"] if f["time"] <= t)
    )
    return score, reached, errors[-1]


def test_hud_shows_each_robots_standing_so_far(replay):
    path, result = replay
    rep = load(path)
    scenes = Scenes(rep)
    all_reached = [t for r in result["robots"] for t in r["task"]["reached_at"]]
    foul_times = [f["time"] for r in result["robots"] for f in r["fouls"]]
    assert foul_times, "the speed limit should have called fouls"
    checked = 0
    for t in (2.0, 5.0, 8.0, 11.0):
        if any(abs(t - r) < 0.2 for r in all_reached):
            continue  # progress is tracked on frames: keep away from the moment a waypoint is reached
        hud = scenes.at(t).hud
        assert len(hud) == 1 + 4 and f"t = {t:6.2f} s" in hud[0]
        for slot in range(4):
            score, reached, (pos, hdg) = direct_standing(rep, result, slot, t)
            line = hud[1 + slot]
            got = re.search(r"score\s+(-?[\d.]+)\s+(\d+)/(\d+) waypoints\s+err (\d+) mm (\d+) deg", line)
            assert got, line
            assert float(got[1]) == pytest.approx(score, abs=0.051)
            assert int(got[2]) == reached and int(got[3]) == 6
            assert int(got[4]) == round(1000 * pos) and int(got[5]) == round(math.degrees(hdg))
            checked += 1
    assert checked >= 8
    final = scenes.at(scenes.duration).hud  # at the end: the referee's own final scores
    for slot, r in enumerate(result["robots"]):
        assert f"final score {r['score']['total']:.1f}" in final[1 + slot]


def test_hud_lines_are_drawn_in_each_robots_colour(replay):
    viewer = Viewer(Scenes(load(replay[0])), SIZE)
    viewer.help_left = 0.0
    viewer.t = 5.0
    surface = pygame.Surface(SIZE)
    viewer.draw(surface)
    line = viewer.painter.line
    for i in range(5):
        band = pygame.Rect(10, 6 + i * line, SIZE[0] // 2, line - 2)
        rgb = HUD_TEXT if i == 0 else _mix(color(i - 1), HUD_TEXT, 0.45)
        assert count(surface, band, rgb) > 30, i
    field_top = viewer.painter.to_screen(0, viewer.scenes.level.field.ymax)[1]
    assert field_top > viewer.painter.hud_height  # the field lies below the HUD


def test_without_a_display_watch_says_so_in_one_line_and_plays_nothing(tmp_path):
    # no X11, no Wayland, no SDL driver chosen (a server over ssh): one line, exit 2, at once
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")}
    out = subprocess.run(
        [sys.executable, "-m", "referee", "watch", "asabe"], capture_output=True, text=True, timeout=120, env=env
    )
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.splitlines() == [
        "laserarena: watch: no display (neither DISPLAY nor WAYLAND_DISPLAY is set); "
        "`laserarena render REPLAY --html page.html` makes a page any browser plays"
    ]


def test_a_match_that_dies_before_its_first_frame_is_an_error_not_a_wait(monkeypatch):
    import threading

    from referee.errors import UserError
    from referee.match.loop import Match
    from referee.media.watch import watch

    def broken(self):
        raise RuntimeError("the match thread failed at once")

    monkeypatch.setattr(Match, "run", broken)
    outcome: list[BaseException] = []

    def play():
        try:
            watch("bac-line", teams=["ref:idle"], max_frames=1)
        except BaseException as e:
            outcome.append(e)

    monkeypatch.setattr(threading, "excepthook", lambda args: None)  # the match thread's own report
    waiting = threading.Thread(target=play, daemon=True)
    waiting.start()
    waiting.join(60)
    assert not waiting.is_alive(), "watch waited for a frame that never comes"
    assert len(outcome) == 1 and isinstance(outcome[0], UserError)
    assert "ended before its first frame" in str(outcome[0])
