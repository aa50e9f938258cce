"""Recording a match as it runs: to a replay file (`ReplayWriter`, compressed in a thread of
its own) or into a `Replay` in memory for live viewing (`MemoryRecorder`), both `Recorder`s.

Replays are organizer files (0600): a graded one holds the match's noise key. What a match
writes is bounded by its level (frames, sensor events, one estimate a tick), by the drawing
budgets (referee.match.drawings) and by one record per foul and fault: far below
`MAX_REPLAY` for the built-in levels.
"""

from __future__ import annotations

import gzip
import io
import json
import os
import queue
import tempfile
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import IO, Any, Protocol

from referee.errors import ReplayError
from referee.records import replay_lines
from referee.records.canonical import DECIMALS, dumps
from referee.records.replay_format import Header, Replay
from referee.records.replay_lines import Detected, Frame
from referee.records.results import MatchResult

_QUEUED = 8  # chunks of records waiting for the compressor at most (then the match waits)
_CHUNK = 512  # lines in a chunk at least (but the last): where the writes fall, the same bytes


class Recorder(Protocol):
    """Where a match records what happens, in the order it is known."""

    def frame(self, time: float, poses: Sequence[Sequence[float]]) -> None:
        """Every robot's true pose at `time`."""

    def frames(self, frames: list[Frame]) -> None:
        """Frames, in order, each every robot's x, y and heading, then the time."""

    def events(self, robots: Sequence[Sequence[Detected]]) -> None:
        """The `e` records of every robot's detections (robot k's are `robots[k]`)."""

    def record(self, record_kind: str, **fields: Any) -> None:
        """A record of kind `record_kind` (est, dbg, trial, foul, fault, e) and its fields."""

    def close(self, result: MatchResult) -> None:
        """The match ended with `result`: the recording is complete."""

    def discard(self) -> None:
        """The match did not end: drop what was recorded."""


class ReplayWriter:
    """Writes one match's replay as it runs: to a private file (0600) beside the target,
    moved into place only when the match has ended, so no controller can read it meanwhile."""

    def __init__(self, path: str | Path, header: Header):
        self.path = Path(path)
        fd, self.partial = tempfile.mkstemp(dir=self.path.resolve().parent, prefix=".laserarena-", suffix=".part")
        raw = os.fdopen(fd, "wb")
        self.gz = gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=6)
        self.raw = raw
        self.file: IO[str] = io.TextIOWrapper(self.gz, encoding="utf-8", newline="\n")
        self._lines: list[str] = []  # records not yet handed to the compressor, a few lines each
        self._count = 0  # how many lines they hold: a chunk is handed on at _CHUNK lines or more
        # the compressor's own thread: zlib lets go of the GIL, so it compresses while the
        # match runs on (the same chunks in the same order: the same bytes)
        self._chunks: queue.Queue[str | None] = queue.Queue(maxsize=_QUEUED)
        self._failure: BaseException | None = None
        self._compressor: threading.Thread | None = None  # started with the first chunk
        self._write(header.to_dict())

    def _write(self, obj: dict[str, Any]) -> None:
        self._lines.append(dumps(obj, indent=None) + "\n")
        self._count += 1

    def _add(self, text: str, lines: int) -> None:
        """Hot records' `lines` lines at once, then on to the compressor if a chunk is full."""
        self._lines.append(text)
        self._count += lines
        if self._count >= _CHUNK:
            self._flush()

    def _hot(self, line: str | None, record: Callable[[], dict[str, Any]]) -> None:
        """A hot record (frame, event, estimate), formatted by hand (`replay_lines`), or where
        that cannot (None: a value was not a finite float, an int, a string or None) by JSON's
        encoder from `record()`."""
        if line is None:
            line = json.dumps(record(), sort_keys=True, separators=(",", ":"))
        self._add(line + "\n", 1)

    def _flush(self) -> None:
        """Hand the records so far to the compressor's thread (its failure, if any, is raised here)."""
        if self._failure is not None:
            raise self._failure
        if self._compressor is None:
            self._compressor = threading.Thread(target=self._compress, name="replay-compressor", daemon=True)
            self._compressor.start()
        self._chunks.put("".join(self._lines))
        self._lines.clear()
        self._count = 0

    def _compress(self) -> None:
        while (chunk := self._chunks.get()) is not None:
            if self._failure is None:
                try:
                    self.file.write(chunk)
                except BaseException as e:  # a full disk: raised in the match's thread, at its next flush
                    self._failure = e

    def _finish(self) -> None:
        """Let the compressor's thread write what it was given, and end it."""
        if self._compressor is not None and self._compressor.is_alive():
            self._chunks.put(None)
            self._compressor.join()

    def frame(self, time: float, poses: Sequence[Sequence[float]]) -> None:
        line: str | None
        try:
            line = replay_lines.frame_line(time, poses)
        except TypeError:
            line = None
        rounded = replay_lines.rounded
        self._hot(line, lambda: {"k": "f", "t": round(time, DECIMALS), "p": [rounded(p) for p in poses]})

    def frames(self, frames: list[Frame]) -> None:
        """Frames (every robot's x, y and heading, then the time), their numbers formatted at once."""
        try:
            text = replay_lines.frame_lines(frames)
        except (TypeError, ValueError):  # a value the encoder must write: one frame at a time
            for frame in frames:
                self.frame(frame[-1], replay_lines.frame_poses(frame))
            return
        self._add(text, len(frames))

    def events(self, robots: Sequence[Sequence[Detected]]) -> None:
        """The `e` records of every robot's detections (arena.sensing.events.Detection; robot
        k's are `robots[k]`), at once; handed on a robot at a time, as chunks always were."""
        try:
            texts = replay_lines.event_lines(robots)
        except (TypeError, ValueError):  # a value the encoder must write: one record at a time
            for slot, detections in enumerate(robots):
                for d in detections:
                    self.record("e", t=d.time, r=slot, s=d.source, kind=d.kind, b=d.beacon, line=d.beam)
            return
        for text, detections in zip(texts, robots):
            if detections:
                self._add(text, len(detections))

    def record(self, record_kind: str, **fields: Any) -> None:
        if record_kind not in ("e", "est"):
            self._write({"k": record_kind, **fields})
            return
        text: str | None
        try:
            text = replay_lines.event_line(fields) if record_kind == "e" else replay_lines.estimate_line(fields)
        except (TypeError, KeyError):
            text = None

        def rounded() -> dict[str, Any]:
            line, est = fields.get("line"), fields.get("e")
            fields["t"] = round(fields["t"], DECIMALS)
            if line is not None:
                fields["line"] = replay_lines.rounded(line)
            if est is not None:
                fields["e"] = replay_lines.rounded(est)
            return {"k": record_kind, **fields}

        self._hot(text, rounded)

    def discard(self) -> None:
        """Drop the unfinished replay (the match did not end): no `.part` file is left behind."""
        self._failure = self._failure or ReplayError("discarded")  # nothing more is compressed
        try:
            self._finish()
            self.file.close()
            self.raw.close()
        except (OSError, ValueError):
            pass
        finally:  # even if a second interrupt cuts the wait for the compressor short
            Path(self.partial).unlink(missing_ok=True)

    def close(self, result: MatchResult) -> None:
        self._write({"k": "result", "result": result})
        self._flush()
        self._finish()
        if self._failure is not None:
            raise self._failure
        self.file.close()  # closes the gzip stream and the file beneath
        self.raw.close()
        os.replace(self.partial, self.path)  # still 0600 (mkstemp): an organizer file


class MemoryRecorder:
    """Records into a `Replay` in memory (for live viewing): `replay` grows as the match runs."""

    def __init__(self, header: Header):
        self.replay = Replay(header.to_dict())

    def frame(self, time: float, poses: Sequence[Sequence[float]]) -> None:
        self.replay.frames.append((time, [list(p) for p in poses]))

    def frames(self, frames: list[Frame]) -> None:
        for frame in frames:
            self.replay.frames.append((frame[-1], replay_lines.frame_poses(frame)))

    def events(self, robots: Sequence[Sequence[Detected]]) -> None:
        for slot, detections in enumerate(robots):
            for d in detections:
                self.record("e", t=d.time, r=slot, s=d.source, kind=d.kind, b=d.beacon, line=d.beam)

    def record(self, record_kind: str, **fields: Any) -> None:
        lists = {
            "e": self.replay.events,
            "est": self.replay.estimates,
            "dbg": self.replay.debug,
            "foul": self.replay.fouls,
            "fault": self.replay.faults,
            "trial": self.replay.trials,
        }
        lists[record_kind].append({"k": record_kind, **fields})

    def close(self, result: MatchResult) -> None:
        self.replay.result = result

    def discard(self) -> None:
        """Nothing to drop: the replay in memory stays as far as the match got."""
