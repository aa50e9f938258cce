"""`laserarena watch LEVEL|REPLAY`: a live window.

A replay plays with pause (space), step (left / right while paused; a second otherwise),
seek (click the timeline, where fouls are marked; Home / End), and speed (up / down: x2, /2).
A level runs its match in the background, as fast as it can, while the window shows it in
real time (or faster, with up). Escape or q closes the window. h or ? shows the keys (they are
shown for a few seconds at the start); the HUD gives each robot's score so far, task progress
and the error of its latest estimate.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

from referee.errors import UserError

if TYPE_CHECKING:  # pygame is imported where the viewer opens its window
    import pygame

KEYS_HELP = "space pause   <- -> step/seek   up/down speed   click timeline to seek   h help   q quit"
KEYS = (
    ("space", "pause / play"),
    ("left, right", "a frame back / on when paused, else a second"),
    ("up, down", "speed x2, /2"),
    ("Home, End", "to the start, to the end"),
    ("click", "seek on the timeline (red ticks: fouls)"),
    ("h or ?", "show / hide this help"),
    ("q, Escape", "close"),
)
HELP_SECONDS = 4.0  # the help shows this long at the start


class Viewer:
    """The viewer's state and its reaction to keys and clicks, separate from the window so it
    can be driven and drawn headless: play time, pause, speed, the help overlay."""

    def __init__(self, scenes, size: tuple[int, int], speed: float = 1.0):
        from arena.draw import Painter

        self.scenes, self.size, self.speed = scenes, size, speed
        self.painter = Painter(scenes.level, size)
        self.t, self.paused = 0.0, False
        self.help_left = HELP_SECONDS  # s of wall time the start-up help still shows
        self.help_pinned = False
        self.help_rect: pygame.Rect | None = None  # where the help was last drawn

    @property
    def help_shown(self) -> bool:
        return self.help_pinned or self.help_left > 0

    def key(self, key: int, text: str = "") -> bool:
        """React to a key; False means close."""
        import pygame

        if key in (pygame.K_ESCAPE, pygame.K_q):
            return False
        if key == pygame.K_h or text == "?":
            shown = self.help_shown
            self.help_left, self.help_pinned = 0.0, not shown
        elif key == pygame.K_SPACE:
            self.paused = not self.paused
        elif key in (pygame.K_RIGHT, pygame.K_LEFT):
            sign = 1 if key == pygame.K_RIGHT else -1
            self.t += sign * (1.0 / self.scenes.rate if self.paused else 1.0)
        elif key == pygame.K_UP:
            self.speed = min(self.speed * 2, 64.0)
        elif key == pygame.K_DOWN:
            self.speed = max(self.speed / 2, 1 / 16)
        elif key == pygame.K_HOME:
            self.t = 0.0
        elif key == pygame.K_END:
            self.t = self.scenes.duration
        self.t = min(max(self.t, 0.0), self.scenes.duration)
        return True

    def click(self, pos: tuple[int, int]) -> None:
        """A click on the HUD seeks along the timeline."""
        if pos[1] < self.painter.hud_height:
            w = self.size[0]
            self.t = self.scenes.duration * min(1.0, max(0.0, (pos[0] - 10) / (w - 20)))

    def advance(self, wall: float) -> None:
        """`wall` seconds of real time passed: play on, count down the start-up help."""
        self.scenes.update()
        self.help_left = max(0.0, self.help_left - wall)
        if not self.paused:
            self.t += wall * self.speed
        self.t = min(max(self.t, 0.0), self.scenes.duration)

    def draw(self, surface) -> None:
        from arena.draw import help_box

        self.painter.draw(surface, self.scenes.at(self.t))
        self.help_rect = (
            help_box(surface, "LaserArena viewer: keys", KEYS, self.painter.font) if self.help_shown else None
        )


ELSEWHERE = "`laserarena render REPLAY --html page.html` makes a page any browser plays"


def no_display() -> str | None:
    """Why SDL has no display to open a window on (None: it may have one): on Linux and the
    BSDs, neither X11 nor Wayland is reachable and no SDL driver was chosen."""
    if not sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) or os.environ.get("SDL_VIDEODRIVER"):
        return None
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    return "no display (neither DISPLAY nor WAYLAND_DISPLAY is set)"


def watch(
    target: str,
    teams: list[str] | None = None,
    seed: int | None = None,
    size: tuple[int, int] = (960, 700),
    speed: float = 1.0,
    max_frames: int | None = None,
) -> int:
    """Open the window and play until closed (or `max_frames` drawn, for tests); returns frames
    drawn. UserError, before anything is played, where no window can be opened."""
    import pygame

    problem = no_display()
    if problem:
        raise UserError(f"watch: {problem}; {ELSEWHERE}")

    from referee.media.render import Scenes
    from referee.records.replay_reader import load
    from referee.records.replay_writer import MemoryRecorder

    live = None
    path = Path(target)
    if path.is_file() and path.suffix != ".yaml" and path.read_bytes()[:2] == b"\x1f\x8b":
        try:
            scenes = Scenes(load(path))
        except ValueError as e:
            raise UserError(str(e)) from None
    else:
        from levels.loader import find_level
        from referee.match.loop import Match
        from referee.match.views import replay_header
        from referee.sandbox.teams import controller_problem, fill_slots

        level = find_level(target, controllers=controller_problem)
        resolved = fill_slots(level, teams)
        recorder = MemoryRecorder(replay_header(level, resolved, level.seed if seed is None else seed, False, None))
        match = Match(level, resolved, seed=seed, recorder=recorder)
        live = threading.Thread(target=match.run, daemon=True)
        live.start()
        while not recorder.replay.frames:
            if not live.is_alive():  # the match ended before its first frame: nothing to show
                raise UserError(f"{target}: the match ended before its first frame")
            time.sleep(0.01)
        scenes = Scenes(recorder.replay)

    try:
        pygame.display.init()
    except pygame.error as e:
        raise UserError(f"watch: no window can be opened here ({e}); {ELSEWHERE}") from None
    pygame.display.set_caption(f"LaserArena — {target}")
    screen = pygame.display.set_mode(size)
    viewer = Viewer(scenes, size, speed)
    clock = pygame.time.Clock()
    frames = 0
    try:
        while True:
            for ev in pygame.event.get():
                if ev.type == pygame.QUIT or (ev.type == pygame.KEYDOWN and not viewer.key(ev.key, ev.unicode)):
                    return frames
                if ev.type == pygame.MOUSEBUTTONDOWN:
                    viewer.click(ev.pos)
            viewer.advance(clock.tick(60) / 1000.0)
            viewer.draw(screen)
            pygame.display.flip()
            frames += 1
            if max_frames is not None and frames >= max_frames:
                return frames
    finally:
        pygame.display.quit()
