"""Drawing one moment of a match with pygame-ce: the field to scale, walls and obstacles,
beacons by kind, robots with their heading, trails and estimate ghosts, laser beams and
hits, paths and waypoints, debug drawings, and a HUD. Works on any surface, headless too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pygame

from levels.model import Level

PALETTE = [(230, 80, 60), (60, 140, 230), (60, 180, 90), (220, 170, 40), (170, 90, 210), (40, 190, 190)]
BACKGROUND, FIELD, WALL, OBSTACLE = (24, 26, 30), (236, 232, 220), (70, 70, 76), (120, 110, 100)
BEACON = {
    "reflector": (210, 40, 40),
    "sensor_array": (30, 90, 200),
    "flash_detector": (200, 120, 20),
    "light": (250, 210, 40),
}
HUD_HEIGHT = 56  # the least: a title line, one line per robot, the timeline
HUD_TEXT, OVERLAY, OVERLAY_TEXT = (235, 235, 235), (16, 18, 24), (250, 250, 250)
# a beacon's name: dark on a white plate, legible on the field and on the dark margin alike
LABEL, LABEL_PLATE = (20, 20, 24), (255, 255, 255)


@dataclass(frozen=True)
class RobotView:
    """A robot as drawn: true pose, footprint, trail, the pose its controller reported."""

    slot: int
    x: float
    y: float
    heading: float
    length: float
    width: float
    trail: tuple[tuple[float, float], ...] = ()
    estimate: tuple[float, float, float] | None = None
    stopped: bool = False


@dataclass(frozen=True)
class Scene:
    """Everything to draw at one instant."""

    robots: tuple[RobotView, ...]
    beams: tuple[tuple[int, float, float, float, float], ...] = ()  # (slot, x0, y0, x1, y1)
    paths: tuple[tuple[tuple[float, float], ...], ...] = ()  # per slot
    drawings: tuple[tuple[int, dict], ...] = ()  # (slot, Drawing as a dict)
    hud: tuple[str, ...] = ()
    timeline: tuple[float, tuple[float, ...], float] | None = None  # (now, marks, duration)


def color(slot: int) -> tuple[int, int, int]:
    return PALETTE[slot % len(PALETTE)]


class Painter:
    """Draws scenes of one level onto surfaces of one size; the field keeps its aspect ratio."""

    def __init__(self, level: Level, size: tuple[int, int]):
        self.level = level
        self.size = size
        w, h = size
        f = level.field
        pygame.font.init()
        self.font = pygame.font.Font(None, max(16, h // 36))
        self.small = pygame.font.Font(None, max(13, h // 48))
        self.tag = pygame.font.Font(None, max(20, h // 28))  # a beacon's name
        self.line = self.font.get_linesize() + 2
        self.hud_height = max(HUD_HEIGHT, 6 + (1 + len(level.robots)) * self.line + 14)
        margin = max(12, min(w, h) // 30)
        self.scale = min((w - 2 * margin) / f.size[0], (h - self.hud_height - 2 * margin) / f.size[1])
        self.ox = (w - f.size[0] * self.scale) / 2 - f.xmin * self.scale
        self.oy = self.hud_height + (h - self.hud_height - f.size[1] * self.scale) / 2 + f.ymax * self.scale
        self.px = max(1, round(self.scale * 0.004))  # a line width that stays visible at any size

    def to_screen(self, x: float, y: float) -> tuple[int, int]:
        """Field metres to pixels (y up on the field, down on the screen)."""
        return round(self.ox + x * self.scale), round(self.oy - y * self.scale)

    def _len(self, metres: float, least: int = 2) -> int:
        return max(least, round(metres * self.scale))

    def draw(self, surface: pygame.Surface, scene: Scene) -> None:
        surface.fill(BACKGROUND)
        self._field(surface)
        for slot, path in enumerate(scene.paths):
            if len(path) > 1:
                pts = [self.to_screen(*p) for p in path]
                pygame.draw.lines(surface, _mix(color(slot), FIELD, 0.55), False, pts, self.px)
                for p in pts:
                    pygame.draw.circle(surface, _mix(color(slot), FIELD, 0.3), p, self.px + 2)
        for r in scene.robots:
            if len(r.trail) > 1:
                pygame.draw.lines(
                    surface, _mix(color(r.slot), FIELD, 0.35), False, [self.to_screen(*p) for p in r.trail], self.px
                )
        for slot, x0, y0, x1, y1 in scene.beams:
            pygame.draw.line(surface, color(slot), self.to_screen(x0, y0), self.to_screen(x1, y1), self.px)
            pygame.draw.circle(surface, color(slot), self.to_screen(x1, y1), self.px + 3)
        self._beacons(surface)
        for slot, d in scene.drawings:
            self._drawing(surface, slot, d)
        for r in scene.robots:
            self._robot(surface, r)
        self._hud(surface, scene)

    def _field(self, surface: pygame.Surface) -> None:
        f = self.level.field
        x0, y0 = self.to_screen(f.xmin, f.ymax)
        x1, y1 = self.to_screen(f.xmax, f.ymin)
        pygame.draw.rect(surface, FIELD, (x0, y0, x1 - x0, y1 - y0))
        if f.walls:
            pygame.draw.rect(surface, WALL, (x0, y0, x1 - x0, y1 - y0), max(2, self.px * 2))
        for ob in self.level.obstacles:
            if ob.kind == "circle":
                pygame.draw.circle(surface, OBSTACLE, self.to_screen(*ob.points[0]), self._len(ob.radius))
            else:
                pygame.draw.polygon(surface, OBSTACLE, [self.to_screen(*p) for p in ob.points])

    def _beacons(self, surface: pygame.Surface) -> None:
        kind = self.level.beacons.kind
        r = max(5, self._len(self.level.beacons.radius))
        for b in self.level.beacons.items:
            cx, cy = self.to_screen(b.x, b.y)
            fx, fy = math.cos(b.facing), -math.sin(b.facing)
            c = BEACON[kind]
            if kind == "light":
                pygame.draw.circle(surface, _mix(c, FIELD, 0.6), (cx, cy), r * 2)
                pygame.draw.circle(surface, c, (cx, cy), r)
            elif kind == "sensor_array":  # a bar across its facing direction
                px_, py_ = -fy * r * 1.6, fx * r * 1.6
                pygame.draw.line(surface, c, (cx - px_, cy - py_), (cx + px_, cy + py_), max(3, r // 2))
            elif kind == "flash_detector":
                pygame.draw.polygon(surface, c, [(cx, cy - r), (cx + r, cy), (cx, cy + r), (cx - r, cy)])
            else:  # a reflector: a triangle pointing where it faces
                pygame.draw.polygon(
                    surface,
                    c,
                    [
                        (cx + fx * r * 1.4, cy + fy * r * 1.4),
                        (cx - fy * r - fx * r * 0.6, cy + fx * r - fy * r * 0.6),
                        (cx + fy * r - fx * r * 0.6, cy - fx * r - fy * r * 0.6),
                    ],
                )
            self._label(surface, b.id, cx + r + 2, cy - r - 2)

    def _label(self, surface: pygame.Surface, text: str, x: int, bottom: int) -> None:
        """A beacon's name on a plate whose bottom-left corner is at (x, bottom), moved into
        the frame (below the HUD) where it would leave it."""
        label = self.tag.render(text, True, LABEL)
        w, h = label.get_width() + 6, label.get_height() + 2
        x, y = min(x, self.size[0] - w - 2), max(bottom - h, self.hud_height + 2)
        pygame.draw.rect(surface, LABEL_PLATE, (x, y, w, h))
        pygame.draw.rect(surface, LABEL, (x, y, w, h), 1)
        surface.blit(label, (x + 3, y + 1))

    def _box(self, x: float, y: float, h: float, length: float, width: float) -> list[tuple[int, int]]:
        c, s = math.cos(h), math.sin(h)
        return [
            self.to_screen(x + c * dx - s * dy, y + s * dx + c * dy)
            for dx, dy in (
                (length / 2, width / 2),
                (-length / 2, width / 2),
                (-length / 2, -width / 2),
                (length / 2, -width / 2),
            )
        ]

    def _robot(self, surface: pygame.Surface, r: RobotView) -> None:
        body = color(r.slot) if not r.stopped else (130, 130, 130)
        if r.estimate is not None:  # the ghost: where the controller believes it is
            ex, ey, eh = r.estimate
            pygame.draw.polygon(surface, _mix(body, FIELD, 0.6), self._box(ex, ey, eh, r.length, r.width), self.px)
            tip = self.to_screen(ex + math.cos(eh) * r.length * 0.6, ey + math.sin(eh) * r.length * 0.6)
            pygame.draw.line(surface, _mix(body, FIELD, 0.6), self.to_screen(ex, ey), tip, self.px)
        pygame.draw.polygon(surface, body, self._box(r.x, r.y, r.heading, r.length, r.width))
        tip = self.to_screen(r.x + math.cos(r.heading) * r.length * 0.6, r.y + math.sin(r.heading) * r.length * 0.6)
        pygame.draw.line(surface, (20, 20, 20), self.to_screen(r.x, r.y), tip, max(2, self.px))
        label = self.small.render(str(r.slot), True, (255, 255, 255))
        surface.blit(label, label.get_rect(center=self.to_screen(r.x, r.y)))

    def _drawing(self, surface: pygame.Surface, slot: int, d: dict) -> None:
        c = tuple(d.get("color", color(slot)))
        pts = [self.to_screen(*p) for p in d.get("points", [])]
        kind = d.get("kind")
        if kind == "line" and len(pts) > 1:
            pygame.draw.lines(surface, c, False, pts, self.px)
        elif kind == "circle" and pts:
            pygame.draw.circle(surface, c, pts[0], self._len(d.get("radius", 0.01)), self.px)
        elif kind == "text" and pts:
            surface.blit(self.small.render(str(d.get("text", ""))[:80], True, c), pts[0])
        else:
            for p in pts:
                pygame.draw.circle(surface, c, p, self.px + 2)

    def _hud(self, surface: pygame.Surface, scene: Scene) -> None:
        w, _ = self.size
        pygame.draw.rect(surface, (40, 42, 48), (0, 0, w, self.hud_height))
        for i, line in enumerate(scene.hud[: 1 + len(self.level.robots)]):
            c = HUD_TEXT if i == 0 else _mix(color(i - 1), HUD_TEXT, 0.45)  # a robot's line in its colour
            surface.blit(self.font.render(line, True, c), (10, 6 + i * self.line))
        if scene.timeline:
            now, marks, duration = scene.timeline
            y = self.hud_height - 6
            pygame.draw.line(surface, (110, 110, 120), (10, y), (w - 10, y), 3)
            span = max(duration, 1e-9)
            for m in marks:  # fouls
                x = 10 + (w - 20) * m / span
                pygame.draw.line(surface, (240, 80, 60), (x, y - 6), (x, y + 2), 2)
            pygame.draw.circle(surface, (250, 250, 250), (10 + (w - 20) * min(now, span) / span, y), 5)


def help_box(
    surface: pygame.Surface, title: str, rows: tuple[tuple[str, str], ...], font: pygame.font.Font
) -> pygame.Rect:
    """A dark box in the middle of the surface: a title, then (key, what it does) rows in two
    columns (the viewer's key help). Returns where it was drawn."""
    head = font.render(title, True, OVERLAY_TEXT)
    keys = [font.render(k, True, OVERLAY_TEXT) for k, _ in rows]
    texts = [font.render(t, True, OVERLAY_TEXT) for _, t in rows]
    column = max(k.get_width() for k in keys) + 24
    line = font.get_linesize() + 4
    box = pygame.Rect(
        0, 0, max(head.get_width(), column + max(t.get_width() for t in texts)) + 40, line * (len(rows) + 1) + 36
    )
    box.center = surface.get_rect().center
    shade = pygame.Surface(box.size, pygame.SRCALPHA)
    shade.fill((*OVERLAY, 225))
    surface.blit(shade, box.topleft)
    surface.blit(head, (box.left + 20, box.top + 15))
    for i, (k, t) in enumerate(zip(keys, texts)):
        y = box.top + 21 + line * (i + 1)
        surface.blit(k, (box.left + 20, y))
        surface.blit(t, (box.left + 20 + column, y))
    return box


def _mix(a: tuple[int, int, int], b: tuple[int, int, int], t: float) -> tuple[int, int, int]:
    """a blended towards b by t (0: a, 1: b)."""
    red, green, blue = (round(x + (y - x) * t) for x, y in zip(a, b))
    return red, green, blue
