"""Replays to pictures: scenes at any instant, PNG frames or an H.264 MP4, headless.

`Scenes` turns a replay into `arena.draw.Scene`s (the viewer uses it too); `render` writes
them at a frame rate over a time range, to a folder of PNGs or an MP4 (imageio-ffmpeg, which
ships its own ffmpeg), with a progress bar.
"""

from __future__ import annotations

import bisect
from pathlib import Path

import pygame

from arena.draw import Painter, RobotView, Scene
from levels.loader import parse_level
from levels.model import Level
from referee.errors import UserError
from referee.media.standings import Standings
from referee.records.replay_format import Replay
from referee.records.replay_reader import load
from referee.terminal import Progress

TRAIL = 8.0  # s of trail behind each robot
BEAM_WINDOW = 0.06  # s: hits this recent are drawn as beams


class Scenes:
    """Scenes of one replay at any time; `update()` takes in records added since (live play)."""

    def __init__(self, rep: Replay):
        self.rep = rep
        h = rep.header
        self.level = parse_level(h["level"]["text"].encode(), h["level"]["name"])
        self.rate = h["record_rate"]
        self.paths = paths(self.level)
        self.teams = [t["label"] for t in rep.header["teams"]]
        self.event_times: list[float] = []
        self.events: list[dict] = []
        self.estimates: dict[int, tuple[list, list]] = {}
        self.debug: dict[int, tuple[list, list]] = {}
        self.seen = {"e": 0, "est": 0, "dbg": 0}
        self.standings = Standings(self.level, rep)
        self.update()

    @property
    def duration(self) -> float:
        return self.rep.duration

    def update(self) -> None:
        rep = self.rep
        for e in rep.events[self.seen["e"] :]:
            if e.get("line"):
                i = bisect.bisect_right(self.event_times, e["t"])
                self.event_times.insert(i, e["t"])
                self.events.insert(i, e)
        for name, source, target, key in (
            ("est", rep.estimates, self.estimates, "e"),
            ("dbg", rep.debug, self.debug, "d"),
        ):
            for rec in source[self.seen[name] :]:
                times, values = target.setdefault(rec["r"], ([], []))
                times.append(rec["t"])
                values.append(rec[key])
        self.seen = {"e": len(rep.events), "est": len(rep.estimates), "dbg": len(rep.debug)}
        self.stopped_at = {f["r"]: f["time"] for f in rep.faults if f["kind"] != "skipped_tick"}
        self.foul_times = tuple(sorted(f["time"] for f in rep.fouls))
        self.standings.update()

    def at(self, t: float) -> Scene:
        frames = self.rep.frames
        i = int(min(max(round(t * self.rate), 0), len(frames) - 1))
        first = max(0, i - int(TRAIL * self.rate))
        robots = []
        for slot, r in enumerate(self.level.robots):
            x, y, h = frames[i][1][slot]
            trail = tuple((f[1][slot][0], f[1][slot][1]) for f in frames[first : i + 1 : 2])
            robots.append(
                RobotView(
                    slot,
                    float(x),
                    float(y),
                    float(h),
                    r.model.length,
                    r.model.width,
                    trail,
                    _latest(self.estimates.get(slot), t),
                    self.stopped_at.get(slot, 1e18) <= t,
                )
            )
        lo = bisect.bisect_right(self.event_times, t - BEAM_WINDOW)
        hi = bisect.bisect_right(self.event_times, t)
        beams = tuple((e["s"] if e["s"] >= 0 else e["r"], *e["line"]) for e in self.events[lo:hi])
        drawings = tuple((slot, d) for slot in self.debug for d in (_latest(self.debug[slot], t) or []))
        fouls = sum(1 for f in self.foul_times if f <= t)
        hud = (
            f"{self.level.name}  seed {self.rep.header['seed']}   t = {t:6.2f} s / {self.duration:.1f} s"
            f"   fouls {fouls}",
            *self._standings(t),
        )
        return Scene(tuple(robots), beams, self.paths, drawings, hud, (t, self.foul_times, self.duration))

    def _standings(self, t: float) -> tuple[str, ...]:
        """One line per robot; at the end of a finished replay, the referee's own scores."""
        result = self.rep.result
        if result and t >= self.duration - 1e-9:
            return tuple(f"{r.slot} {r.team}   final score {r.score.total:.1f}" for r in result.robots)
        return tuple(self.standings.line(slot, team, t) for slot, team in enumerate(self.teams))


def paths(level: Level) -> tuple[tuple[tuple[float, float], ...], ...]:
    """Each slot's drawn path: from its start through its waypoints, or straight to the goal."""
    if level.task.goal is not None:
        g = level.task.goal
        return tuple(((r.start.x, r.start.y), (g.x, g.y)) for r in level.robots)
    return tuple(((r.start.x, r.start.y), *r.path) if r.path else () for r in level.robots)


def _latest(series: tuple[list, list] | None, t: float):
    if not series:
        return None
    i = bisect.bisect_right(series[0], t) - 1
    return series[1][i] if i >= 0 else None


def render(
    replay: Path,
    out: Path,
    fps: int = 30,
    size: tuple[int, int] = (960, 640),
    start: float = 0.0,
    end: float | None = None,
    quiet: bool = False,
) -> int:
    """Write frames (a folder of PNGs, or an .mp4); return how many."""
    try:
        scenes = Scenes(load(replay))
    except (OSError, ValueError) as e:
        raise UserError.of(e) from None
    end = scenes.duration if end is None else min(end, scenes.duration)
    if fps <= 0 or size[0] < 64 or size[1] < 64 or end < start:
        raise UserError("render: need fps > 0, a size of at least 64x64 and --from <= --to")
    times = [start + k / fps for k in range(int(round((end - start) * fps)) + 1)]
    painter = Painter(scenes.level, size)
    surface = pygame.Surface(size)
    mp4 = out.suffix.lower() == ".mp4"
    if mp4:
        import imageio_ffmpeg

        writer = imageio_ffmpeg.write_frames(
            str(out),
            size,
            fps=fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            macro_block_size=16,
            quality=None,
            output_params=["-preset", "veryfast", "-crf", "26"],
        )
        writer.send(None)
    else:
        out.mkdir(parents=True, exist_ok=True)
    progress = Progress(len(times), "frame", quiet)
    try:
        for k, t in enumerate(times):
            painter.draw(surface, scenes.at(t))
            if mp4:
                writer.send(pygame.image.tobytes(surface, "RGB"))
            else:
                pygame.image.save(surface, str(out / f"frame_{k:05d}.png"))
            progress.tick()
    finally:
        progress.close()
        if mp4:
            writer.close()
    return len(times)
