"""Replay recording: a header, the true poses at the level's record rate, and the result.

Format `laserarena-replay` version 0 (JSON lines, one object per line): the first line is
the header, then one `{"t": time, "p": [[x, y, heading], ...]}` frame per record period,
and the last line `{"result": ...}`. The replay issue turns this into the full versioned
format of docs/replay.md.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import IO

from arena.level import Level
from arena.world import World
from referee.canonical import dumps

FORMAT, VERSION = "laserarena-replay", 0


class ReplayWriter:
    """Writes one match's replay as it runs."""

    def __init__(self, path: str | Path, level: Level, seed: int, teams: list[str], software: str):
        # written to a private file (mode 0600) beside the target and moved into place only
        # when the match has ended, so no controller can read it while it runs
        self.path = Path(path)
        fd, self.partial = tempfile.mkstemp(dir=self.path.resolve().parent, prefix=".laserarena-", suffix=".part")
        self.file: IO[str] = os.fdopen(fd, "w", encoding="utf-8", newline="\n")
        self._write({"format": FORMAT, "version": VERSION, "software": software,
                     "level": {"name": level.name, "hash": level.hash}, "seed": seed, "teams": teams,
                     "record_rate": level.record_rate})

    def _write(self, obj: dict) -> None:
        self.file.write(dumps(obj, indent=None) + "\n")

    def frame(self, world: World) -> None:
        poses = [world.pose(s) for s in range(len(world.bodies))]
        self._write({"t": world.time, "p": [[p.x, p.y, p.heading] for p in poses]})

    def close(self, result: dict) -> None:
        self._write({"result": result})
        self.file.close()
        os.chmod(self.partial, 0o644)
        os.replace(self.partial, self.path)
