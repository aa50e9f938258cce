"""Render and encode speed at 960x640: drawing frames, encoding them to H.264, and both.

Run: python benchmarks/render.py
Target (issue 7): encoding at least 100 frames per second here.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import imageio_ffmpeg
import pygame

import levels
from arena.draw import Painter
from levels.loader import parse_level
from referee.match.loop import play_match
from referee.media.render import Scenes
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve

SIZE = (960, 640)


def measure(count: int = 600) -> dict:
    """Draw and encode frames per second at 960x640."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "race.replay"
        text = levels.path("asabe-race").read_text().replace("time_limit: 180", "time_limit: 20")
        play_match(
            parse_level(text.encode(), "race20.yaml"), [resolve("ref:dead-reckoning")] * 4, replay=path, isolate=False
        )
        scenes = Scenes(load(path))
        painter, surface = Painter(scenes.level, SIZE), pygame.Surface(SIZE)
        times = [k / 30 for k in range(count)]
        start = time.perf_counter()
        frames = []
        for t in times:
            painter.draw(surface, scenes.at(t))
            frames.append(pygame.image.tobytes(surface, "RGB"))
        draw_fps = len(times) / (time.perf_counter() - start)
        writer = imageio_ffmpeg.write_frames(
            str(Path(d) / "b.mp4"),
            SIZE,
            fps=30,
            codec="libx264",
            pix_fmt_in="rgb24",
            macro_block_size=16,
            quality=None,
            output_params=["-preset", "veryfast", "-crf", "26"],
        )
        writer.send(None)
        start = time.perf_counter()
        for f in frames:
            writer.send(f)
        writer.close()
        encode_fps = len(frames) / (time.perf_counter() - start)
    return {
        "frames": len(times),
        "draw_fps": draw_fps,
        "encode_fps": encode_fps,
        "both_fps": 1 / (1 / draw_fps + 1 / encode_fps),
    }


def main() -> None:
    m = measure()
    print(f"render at {SIZE[0]}x{SIZE[1]}, {m['frames']} frames of a four-robot race")
    print(f"  draw                 {m['draw_fps']:8.0f} frames/s")
    print(f"  encode (H.264)       {m['encode_fps']:8.0f} frames/s   (target >= 100)")
    print(f"  both, one after other{m['both_fps']:8.0f} frames/s")


if __name__ == "__main__":
    main()
