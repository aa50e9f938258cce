"""Replays: everything that happened in a match, streamable, compact, re-simulatable.

Format `laserarena-replay` version 1 (docs/replay.md): gzip-compressed JSON lines (gzip's
timestamp fixed at 0, so the same match gives the same bytes). The first line is the header
(software, level name, hash and full text, seed, ideal, record rate, teams with controller
hashes); then records in the order they were known, each with a kind `k`:
`f` frame (true poses), `e` sensor event with its beam line, `est` estimate, `dbg` debug
drawings, `foul`, `fault`; the last line is the result. `load()` reads one back.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from arena.level import Level
from referee.errors import ReplayError
from referee.records.canonical import DECIMALS, dumps

FORMAT, VERSION = "laserarena-replay", 1
BEHAVIOUR = 6  # bump when a change alters simulation results (the golden-replay test says so)


def controller_hash(spec: str) -> str:
    """sha256 of a controller's source file (files and modules), or of the spec itself."""
    from robots.loading import is_file_spec
    path = Path(spec.partition(".py")[0] + ".py") if is_file_spec(spec) else None
    if path is None:
        import importlib.util
        from robots.controllers import REFERENCE
        module = (REFERENCE.get(spec[4:], "") if spec.startswith("ref:") else spec).partition(":")[0]
        found = importlib.util.find_spec(module) if module else None
        path = Path(found.origin) if found and found.origin else None
    data = path.read_bytes() if path and path.is_file() else spec.encode()
    return "sha256:" + hashlib.sha256(data).hexdigest()


class ReplayWriter:
    """Writes one match's replay as it runs: to a private file (0600) beside the target,
    moved into place only when the match has ended, so no controller can read it meanwhile."""

    def __init__(self, path: str | Path, level: Level, level_text: str, seed: int, ideal: bool,
                 teams: list[tuple[str, str]], software: str):
        self.path = Path(path)
        fd, self.partial = tempfile.mkstemp(dir=self.path.resolve().parent, prefix=".laserarena-", suffix=".part")
        raw = os.fdopen(fd, "wb")
        self.gz = gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=6)
        self.raw = raw
        self.file: IO[str] = io.TextIOWrapper(self.gz, encoding="utf-8", newline="\n")
        self._write({"format": FORMAT, "version": VERSION, "behaviour": BEHAVIOUR, "software": software,
                     "level": {"name": level.name, "hash": level.hash, "text": level_text},
                     "seed": seed, "ideal": ideal, "record_rate": level.record_rate,
                     "control_period": level.control_period,
                     "teams": [{"label": label, "spec": spec, "hash": controller_hash(spec)} for label, spec in teams]})

    def _write(self, obj: dict) -> None:
        self.file.write(dumps(obj, indent=None) + "\n")

    def _fast(self, obj: dict) -> None:
        """The hot records (frames, events, estimates): floats already rounded, flat values."""
        self.file.write(json.dumps(obj, sort_keys=True, separators=(",", ":")) + "\n")

    def frame(self, time: float, poses: list[tuple[float, float, float]]) -> None:
        self._fast({"k": "f", "t": round(time, DECIMALS), "p": [[round(v, DECIMALS) for v in p] for p in poses]})

    def record(self, record_kind: str, **fields) -> None:
        if record_kind in ("e", "est"):
            line, est = fields.get("line"), fields.get("e")
            fields["t"] = round(fields["t"], DECIMALS)
            if line is not None:
                fields["line"] = [round(v, DECIMALS) for v in line]
            if est is not None:
                fields["e"] = [round(v, DECIMALS) for v in est]
            self._fast({"k": record_kind, **fields})
        else:
            self._write({"k": record_kind, **fields})

    def close(self, result: dict) -> None:
        self._write({"k": "result", "result": result})
        self.file.close()  # closes the gzip stream and the file beneath
        self.raw.close()
        os.chmod(self.partial, 0o644)
        os.replace(self.partial, self.path)


class MemoryRecorder:
    """The ReplayWriter interface, recording into a `Replay` in memory (for live viewing)."""

    def __init__(self, level: Level, level_text: str, seed: int, ideal: bool, teams: list[tuple[str, str]]):
        self.replay = Replay({"format": FORMAT, "version": VERSION, "level": {"name": level.name, "hash": level.hash,
                              "text": level_text}, "seed": seed, "ideal": ideal, "record_rate": level.record_rate,
                              "control_period": level.control_period,
                              "teams": [{"label": label, "spec": spec} for label, spec in teams]})

    def frame(self, time: float, poses: list[tuple[float, float, float]]) -> None:
        self.replay.frames.append((time, [list(p) for p in poses]))

    def record(self, record_kind: str, **fields) -> None:
        lists = {"e": self.replay.events, "est": self.replay.estimates, "dbg": self.replay.debug,
                 "foul": self.replay.fouls, "fault": self.replay.faults}
        lists[record_kind].append({"k": record_kind, **fields})

    def close(self, result: dict) -> None:
        self.replay.result = result


@dataclass
class Replay:
    """A replay read back: the header, the frames, and the other records by kind."""

    header: dict
    frames: list[tuple[float, list[list[float]]]] = field(default_factory=list)
    events: list[dict] = field(default_factory=list)
    estimates: list[dict] = field(default_factory=list)
    debug: list[dict] = field(default_factory=list)
    fouls: list[dict] = field(default_factory=list)
    faults: list[dict] = field(default_factory=list)
    result: dict | None = None

    @property
    def duration(self) -> float:
        return self.frames[-1][0] if self.frames else 0.0


def records(path: str | Path):
    """Stream a replay's records (dicts), header first."""
    with gzip.open(path, "rt", encoding="utf-8") as f:
        for line in f:
            yield json.loads(line)


def load(path: str | Path) -> Replay:
    """Read a whole replay (ValueError if it is not one)."""
    it = records(path)
    try:
        header = next(it)
    except (OSError, EOFError, StopIteration, json.JSONDecodeError) as e:
        raise ReplayError(f"{path}: not a LaserArena replay ({e})") from None
    if header.get("format") != FORMAT:
        raise ReplayError(f"{path}: not a LaserArena replay")
    if header.get("version") != VERSION:
        raise ReplayError(f"{path}: replay format version {header.get('version')}, this is {VERSION}")
    rep = Replay(header)
    lists = {"e": rep.events, "est": rep.estimates, "dbg": rep.debug, "foul": rep.fouls, "fault": rep.faults}
    try:
        for rec in it:
            k = rec.get("k")
            if k == "f":
                rep.frames.append((rec["t"], rec["p"]))
            elif k == "result":
                rep.result = rec["result"]
            elif k in lists:
                lists[k].append(rec)
    except (OSError, EOFError, json.JSONDecodeError) as e:
        raise ReplayError(f"{path}: a truncated or damaged replay ({e})") from None
    if not rep.frames:
        raise ReplayError(f"{path}: a replay without frames")
    return rep
