"""A replay as one self-contained web page: `write_viewer` inlines the page template
(referee/web/), the replay's own bytes (base64; the browser un-gzips them), the drawing
geometry of its level and of every built-in level, arena/draw.py's colours and pygame's
default font, so the page opens from file:// with no server and no network.
"""

from __future__ import annotations

import base64
import json
import os
import re
from pathlib import Path

import levels
from arena import draw
from levels.loader import LevelError, load_level, parse_level
from levels.model import Level
from referee.errors import UserError
from referee.match import scoring
from referee.match.tasks import TaskTracker
from referee.media import render
from referee.records.replay_reader import load

WEB = Path(__file__).with_name("web")
# a line of HUD-like text: the page sizes its font so that this line is as wide as pygame draws it
SAMPLE = "asabe-race  seed 12   t =   3.07 s / 180.0 s   fouls 4   0 ref:bac: 81.5   1 team_b.py   O A B C"


def level_geometry(level: Level) -> dict:
    """What the page needs to draw a level as arena/draw.py does (SI units, radians)."""
    f = level.field
    tracker = TaskTracker(level)
    return {
        "name": level.name,
        "field": {"origin": list(f.origin), "size": list(f.size), "walls": f.walls},
        "obstacles": [
            {"kind": o.kind, "points": [list(p) for p in o.points], "radius": o.radius} for o in level.obstacles
        ],
        "beacons": {
            "kind": level.beacons.kind,
            "radius": level.beacons.radius,
            "items": [{"id": b.id, "x": b.x, "y": b.y, "facing": b.facing} for b in level.beacons.items],
        },
        "robots": [{"length": r.model.length, "width": r.model.width} for r in level.robots],
        "paths": [[list(p) for p in path] for path in render.paths(level)],
        "task": {
            "kind": level.task.kind,
            "radius": level.task.radius,
            "goal": None if level.task.goal is None else [level.task.goal.x, level.task.goal.y],
        },
        # what the HUD's standings need (referee/media/standings.py): each slot's targets and the
        # localization scales (the starts are each replay's first frame)
        "targets": [[list(p) for p in tracker.targets(r.slot)] for r in level.robots],
        "position_scale": level.rules.position_scale,
        "heading_scale": level.rules.heading_scale,
        "time_limit": level.time_limit,
        "control_period": level.control_period,
        "control_ticks": level.control_ticks,
    }


def _style() -> dict:
    """arena/draw.py's colours and sizes, referee/media/render.py's time windows and the scoring
    constants, so the page and the pygame frames are drawn from one definition."""
    return {
        "palette": draw.PALETTE,
        "background": draw.BACKGROUND,
        "field": draw.FIELD,
        "wall": draw.WALL,
        "obstacle": draw.OBSTACLE,
        "beacon": draw.BEACON,
        "hud_height": draw.HUD_HEIGHT,
        "hud_text": draw.HUD_TEXT,
        "label": draw.LABEL,
        "label_plate": draw.LABEL_PLATE,
        "trail": render.TRAIL,
        "beam_window": render.BEAM_WINDOW,
        "points": {
            "task": scoring.TASK_POINTS,
            "time": scoring.TIME_POINTS,
            "localization": scoring.LOCALIZATION_POINTS,
            "localize_task": scoring.LOCALIZE_TASK_POINTS,
        },
    }


def _font() -> str:
    """pygame's default font (FreeSansBold, shipped with pygame-ce) as base64, or '' if absent."""
    import pygame

    path = Path(pygame.__file__).with_name(pygame.font.get_default_font())
    return base64.b64encode(path.read_bytes()).decode("ascii") if path.is_file() else ""


def _fonts(level: Level, size: tuple[int, int]) -> dict:
    """The sizes and metrics of arena/draw.py's three fonts on a frame of `size` (they depend
    on its height only), so the page places text where pygame does."""
    painter = draw.Painter(level, size)
    return {
        key: {
            "size": f.point_size,
            "ascent": f.get_ascent(),
            "height": f.get_height(),
            "linesize": f.get_linesize(),
            "sample": SAMPLE,
            "sample_width": f.size(SAMPLE)[0],
        }
        for key, f in (("big", painter.font), ("small", painter.small), ("tag", painter.tag))
    }


def page(replay_bytes: bytes, name: str, known: dict[str, dict], fonts: dict, size: tuple[int, int]) -> str:
    """The page's HTML for one replay's bytes (`name` is its title); `known` maps level
    hashes to `level_geometry` (the page draws replays of those levels)."""
    data = {
        "size": list(size),
        "style": _style(),
        "fonts": fonts,
        "levels": known,
        "name": name,
        "replay": base64.b64encode(replay_bytes).decode("ascii"),
    }
    blob = inline_json(data)
    html = (WEB / "viewer.html").read_text(encoding="utf-8")
    script = (WEB / "viewer.js").read_text(encoding="utf-8").replace("</", "<\\/")
    font = _font()
    css_font = f"@font-face {{ font-family: 'LaserArenaSans'; src: url(data:font/ttf;base64,{font}); }}" if font else ""
    parts = {"/*FONT*/": css_font, "/*DATA*/": blob, "/*SCRIPT*/": script, "<!--TITLE-->": _escape(name)}
    # one pass, so a placeholder's text inside inserted data is never replaced again
    return re.sub("|".join(re.escape(k) for k in parts), lambda m: parts[m.group(0)], html)


def write_viewer(replay_path: str | Path, out_path: str | Path, size: tuple[int, int] = (960, 640)) -> None:
    """Write a web page that plays the replay at `replay_path` (UserError on a bad replay)."""
    replay_path, out_path = Path(replay_path), Path(out_path)
    try:
        header = load(replay_path, keep=False).header  # the whole replay is checked, not only its header
        raw = replay_path.read_bytes()
    except (OSError, ValueError) as e:
        raise UserError.of(e) from None
    try:
        level = parse_level(header["level"]["text"].encode(), header["level"]["name"])
    except (KeyError, TypeError, LevelError) as e:
        raise UserError(f"{replay_path}: the level in its header does not load ({e})") from None
    if size[0] < 64 or size[1] < 64:
        raise UserError("render: need a size of at least 64x64")
    if not out_path.resolve().parent.is_dir():
        raise UserError(f"{out_path}: the folder does not exist")
    known = {
        lv.hash: level_geometry(lv)
        for lv in (load_level(levels.path(n), display=f"levels/{n}.yaml") for n in levels.names())
    }
    known[header["level"].get("hash", level.hash)] = level_geometry(level)
    html = page(raw, replay_path.name, known, _fonts(level, size), size)
    tmp = out_path.with_name(f".{out_path.name}.part")
    tmp.write_text(html, encoding="utf-8")
    os.replace(tmp, out_path)


def inline_json(data: object) -> str:
    """`data` as JSON safe inside a <script> element: `<`, `>` and `&` as \\u escapes, so no
    text of a level or team (`</script>`, `<!--`) can end the element or change how it is read."""
    text = json.dumps(data, separators=(",", ":"))
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
