"""`laserarena watch LEVEL|REPLAY`: a live window.

A replay plays with pause (space), step (left / right while paused; a second otherwise),
seek (click the timeline, where fouls are marked; Home / End), and speed (up / down: x2, /2).
A level runs its match in the background, as fast as it can, while the window shows it in
real time (or faster, with up). Escape or q closes the window.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from referee.errors import UserError

KEYS_HELP = "space pause   <- -> step/seek   up/down speed   click timeline to seek   q quit"


def watch(target: str, teams: list[str] | None = None, seed: int | None = None, size: tuple[int, int] = (960, 700),
          speed: float = 1.0, max_frames: int | None = None) -> int:
    """Open the window and play until closed (or `max_frames` drawn, for tests); returns frames drawn."""
    import pygame
    from arena.draw import Painter
    from referee.render import Scenes
    from referee.replay import MemoryRecorder, load

    live = None
    path = Path(target)
    if path.is_file() and path.suffix != ".yaml" and path.read_bytes()[:2] == b"\x1f\x8b":
        try:
            scenes = Scenes(load(path))
        except ValueError as e:
            raise UserError(str(e)) from None
    else:
        from referee.cli import find_level
        from referee.match import Match
        from referee.teams import resolve
        level = find_level(target)
        specs = list(teams or [])
        specs += [level.default_controller] * (len(level.robots) - len(specs))
        resolved = [resolve(s) for s in specs]
        recorder = MemoryRecorder(level, level.text, level.seed if seed is None else seed, False,
                                  [(t.label, t.spec) for t in resolved])
        match = Match(level, resolved, seed=seed, recorder=recorder)
        live = threading.Thread(target=match.run, daemon=True)
        live.start()
        while not recorder.replay.frames:
            time.sleep(0.01)
        scenes = Scenes(recorder.replay)

    pygame.display.init()
    pygame.display.set_caption(f"LaserArena — {target}")
    screen = pygame.display.set_mode(size)
    painter = Painter(scenes.level, size)
    clock = pygame.time.Clock()
    t, paused, frames = 0.0, False, 0
    step = 1.0 / scenes.rate
    try:
        while True:
            for ev in pygame.event.get():
                if ev.type == pygame.QUIT or (ev.type == pygame.KEYDOWN and ev.key in (pygame.K_ESCAPE, pygame.K_q)):
                    return frames
                if ev.type == pygame.KEYDOWN:
                    if ev.key == pygame.K_SPACE:
                        paused = not paused
                    elif ev.key in (pygame.K_RIGHT, pygame.K_LEFT):
                        sign = 1 if ev.key == pygame.K_RIGHT else -1
                        t += sign * (step if paused else 1.0)
                    elif ev.key == pygame.K_UP:
                        speed = min(speed * 2, 64.0)
                    elif ev.key == pygame.K_DOWN:
                        speed = max(speed / 2, 1 / 16)
                    elif ev.key == pygame.K_HOME:
                        t = 0.0
                    elif ev.key == pygame.K_END:
                        t = scenes.duration
                elif ev.type == pygame.MOUSEBUTTONDOWN and ev.pos[1] < 60:  # the timeline in the HUD
                    t = scenes.duration * min(1.0, max(0.0, (ev.pos[0] - 10) / (size[0] - 20)))
            scenes.update()
            dt = clock.tick(60) / 1000.0
            if not paused:
                t += dt * speed
            t = min(max(t, 0.0), scenes.duration)
            painter.draw(screen, scenes.at(t))
            pygame.display.flip()
            frames += 1
            if max_frames is not None and frames >= max_frames:
                return frames
    finally:
        pygame.display.quit()
