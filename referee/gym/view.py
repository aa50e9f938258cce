"""A picture of a running agent session, as an RGB array (the envs' `render()`)."""

from __future__ import annotations

import numpy as np

from arena.draw import Painter, RobotView, Scene


def frame(session, size: tuple[int, int]) -> np.ndarray:
    """The session's match now, drawn with the replay renderer's painter: (height, width, 3) uint8."""
    import pygame

    level, match = session.level, session.sim
    robots = []
    for slot, r in enumerate(level.robots):
        if match:
            now = match.report(slot)
            (x, y), heading, stopped = now.position, now.heading, now.stopped
        else:
            x, y, heading, stopped = r.start.x, r.start.y, r.start.heading, False
        robots.append(RobotView(slot, x, y, heading, r.model.length, r.model.width, stopped=stopped))
    paths = tuple(((r.start.x, r.start.y), *r.path) if r.path else () for r in level.robots)
    t = match.report(0).time if match else 0.0
    surface = pygame.Surface(size)
    Painter(level, size).draw(surface, Scene(tuple(robots), paths=paths, hud=(f"{level.name}   t = {t:6.2f} s",)))
    return np.transpose(pygame.surfarray.array3d(surface), (1, 0, 2)).copy()
