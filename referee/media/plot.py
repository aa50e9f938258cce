"""`laserarena plot REPLAY --out err.png`: each robot's localization error over the match.

Per robot, two panels over time: the position error (mm) and the heading error (deg) of the
estimate its controller reported, against the truth (referee/media/error_series.py). Ticks under
each panel mark the fixes (the times an estimate was reported); red lines the fouls, purple
lines the faults. Drawn with pygame-ce, headless. `error_figure()` gives the same figure,
and its data, from Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from arena.draw import color
from referee.errors import UserError
from referee.media.error_series import tracks
from referee.records.replay_reader import load

BACKGROUND, AXIS, GRID, TEXT = (255, 255, 255), (60, 60, 60), (225, 225, 225), (30, 30, 30)
FOUL, FAULT, FIX = (220, 50, 40), (150, 60, 200), (120, 120, 120)
PANEL_HEIGHT, MARGIN_LEFT, MARGIN_RIGHT, TITLE, GAP = 170, 70, 20, 50, 46


@dataclass(frozen=True)
class Panel:
    """Where one chart lies in the picture and what it spans: time t0..t1 across, 0..top up."""

    rect: tuple[int, int, int, int]  # left, top, width, height in pixels
    t1: float
    top: float

    def to_pixel(self, t: float, value: float) -> tuple[int, int]:
        """The pixel of a point (t, value) of the chart."""
        left, top, w, h = self.rect
        return (round(left + w * t / self.t1), round(top + h - h * value / self.top))


@dataclass(frozen=True)
class RobotErrors:
    """One robot's plotted series: times (s), position error (mm), heading error (deg), and the
    times of its fixes, fouls and faults."""

    slot: int
    team: str
    times: tuple[float, ...]
    position_mm: tuple[float, ...]
    heading_deg: tuple[float, ...]
    fouls: tuple[float, ...]
    faults: tuple[float, ...]
    position: Panel
    heading: Panel

    @property
    def fixes(self) -> tuple[float, ...]:
        """When the controller reported an estimate."""
        return self.times


@dataclass(frozen=True)
class ErrorFigure:
    """The figure: every robot's series and panels, and the picture's size."""

    robots: tuple[RobotErrors, ...]
    size: tuple[int, int]
    duration: float


def _top(values: tuple[float, ...]) -> float:
    """A round upper bound for a chart's axis: 1, 2 or 5 times a power of ten."""
    peak = max(values, default=0.0)
    if peak <= 0:
        return 1.0
    p = 10 ** math.floor(math.log10(peak))
    return next(m * p for m in (1, 2, 5, 10) if m * p >= peak)


def error_figure(replay: str | Path, out: str | Path | None = None, width: int = 960) -> ErrorFigure:
    """Compute every robot's error series from a replay; with `out`, also draw it to that PNG."""
    try:
        rep = load(replay)
    except (OSError, ValueError) as e:
        raise UserError.of(e) from None
    duration = max(rep.duration, 1e-9)
    teams = [t["label"] for t in rep.header["teams"]]
    robots = []
    plot_w = width - MARGIN_LEFT - MARGIN_RIGHT
    for track in tracks(rep):
        s = track.slot
        pos = tuple(1000 * v for v in track.position)
        hdg = tuple(math.degrees(v) for v in track.heading)
        y = (2 * s) * (PANEL_HEIGHT + GAP) + TITLE
        robots.append(
            RobotErrors(
                s,
                teams[s],
                tuple(track.times),
                pos,
                hdg,
                tuple(sorted(f["time"] for f in rep.fouls if f["r"] == s)),
                tuple(sorted(f["time"] for f in rep.faults if f["r"] == s)),
                Panel((MARGIN_LEFT, y, plot_w, PANEL_HEIGHT), duration, _top(pos)),
                Panel((MARGIN_LEFT, y + PANEL_HEIGHT + GAP, plot_w, PANEL_HEIGHT), duration, _top(hdg)),
            )
        )
    height = len(robots) * 2 * (PANEL_HEIGHT + GAP) + TITLE
    fig = ErrorFigure(tuple(robots), (width, height), duration)
    if out is not None:
        draw(fig, Path(out), f"{rep.header['level']['name']}  seed {rep.header['seed']}")
    return fig


def draw(fig: ErrorFigure, out: Path, title: str) -> None:
    """Draw the figure to a PNG file."""
    import pygame

    pygame.font.init()
    font = pygame.font.Font(None, 20)
    surface = pygame.Surface(fig.size)
    surface.fill(BACKGROUND)
    surface.blit(font.render(title, True, TEXT), (MARGIN_LEFT, 6))
    for r in fig.robots:
        for panel, values, unit in (
            (r.position, r.position_mm, "position error, mm"),
            (r.heading, r.heading_deg, "heading error, deg"),
        ):
            _axes(surface, font, panel, f"{r.slot} {r.team}: {unit}", fig.duration)
            left, top, w, h = panel.rect
            for times, c in ((r.fouls, FOUL), (r.faults, FAULT)):
                for t in times:
                    x = panel.to_pixel(t, 0)[0]
                    pygame.draw.line(surface, c, (x, top), (x, top + h), 1)
            for t in r.fixes:  # a tick under the axis per reported estimate
                x = panel.to_pixel(t, 0)[0]
                pygame.draw.line(surface, FIX, (x, top + h + 2), (x, top + h + 6), 1)
            pts = [panel.to_pixel(t, v) for t, v in zip(r.times, values)]
            if len(pts) > 1:
                pygame.draw.lines(surface, color(r.slot), False, pts, 2)
            elif pts:
                pygame.draw.circle(surface, color(r.slot), pts[0], 2)
            else:
                surface.blit(font.render("no estimates reported", True, FIX), (left + 10, top + h // 2))
    out.parent.mkdir(parents=True, exist_ok=True)
    pygame.image.save(surface, str(out))


def _axes(surface, font, panel: Panel, label: str, duration: float) -> None:
    import pygame

    left, top, w, h = panel.rect
    for k in range(5):  # horizontal grid at quarters of the axis, labelled
        y = top + h - h * k / 4
        pygame.draw.line(surface, GRID if k else AXIS, (left, y), (left + w, y), 1)
        text = font.render(f"{panel.top * k / 4:g}", True, TEXT)
        surface.blit(text, (left - 6 - text.get_width(), y - 7))
    pygame.draw.line(surface, AXIS, (left, top), (left, top + h), 1)
    step = _top((duration / 8,))
    t = 0.0
    while t <= duration + 1e-9:
        x = panel.to_pixel(t, 0)[0]
        text = font.render(f"{t:g} s", True, TEXT)
        surface.blit(text, (x - text.get_width() // 2, top + h + 8))
        t += step
    surface.blit(font.render(label, True, TEXT), (left + 4, top - 18))
