"""A controller's output (its stderr, where its stdout goes too): a pipe the referee drains.

The team never holds a host file: its log is the read end of a pipe in this process, read on a
thread of its own so the controller never blocks on a full pipe. The first `cap` bytes are
kept (in the `--logs` file when there is one, and their tail for a fault's traceback); the
rest is counted and dropped. Whether a controller wrote more than `cap` is settled when each
of its answers is judged, after everything it wrote before answering has been read, so an
output flood is reported at the same tick on every run.
"""

from __future__ import annotations

import os
import select
import threading
from pathlib import Path

from referee.sandbox.fault import TRACEBACK_BYTES

JOIN_TIME = 1.0  # seconds `close` waits for the reading thread
PAUSE = 0.02  # seconds between two reads of the pipe by the reading thread


class TeamLog:
    """One controller's log: `writer` is the descriptor to hand it as stderr (closed here by
    `handed_over` once the process has it)."""

    def __init__(self, cap: int, path: Path | None = None):
        self.cap, self.total, self.kept = cap, 0, 0
        self.tail = bytearray()  # the last TRACEBACK_BYTES of what was kept
        self.file = open(path, "wb", buffering=0) if path else None  # live: a team may follow it as it plays
        self._read, self.writer = os.pipe()
        self._wake, self._woken = os.pipe()
        os.set_blocking(self._read, False)
        self._lock = threading.Lock()
        self._ended = False  # end of the stream seen, or closed
        self._thread = threading.Thread(target=self._drain, name="team-log", daemon=True)
        self._thread.start()

    def handed_over(self) -> None:
        """The controller holds the write end now: ours is closed, so its end is our end of file."""
        if self.writer >= 0:
            os.close(self.writer)
            self.writer = -1

    def _drain(self) -> None:
        """Read the pipe as it fills, at most once every PAUSE seconds: a controller that writes a
        byte at a time wakes this thread (and takes the referee's CPU) no more often than that;
        the pipe holds what comes meanwhile, and `flooded` reads to its end when it judges."""
        while True:
            select.select([self._read, self._wake], [], [])
            with self._lock:
                if self._ended or not self._take():
                    return
            select.select([self._wake], [], [], PAUSE)

    def _take(self) -> bool:
        """Read everything the pipe holds now (the caller holds the lock); False at its end."""
        while True:
            try:
                chunk = os.read(self._read, 1 << 16)
            except BlockingIOError:
                return True
            if not chunk:
                self._ended = True
                return False
            self.total += len(chunk)
            keep = chunk[: max(0, self.cap - self.kept)]
            if keep:
                self.kept += len(keep)
                if self.file is not None:
                    self.file.write(keep)
                self.tail += keep
                del self.tail[:-TRACEBACK_BYTES]

    def flooded(self) -> bool:
        """Whether the controller has written more than `cap` bytes, counting all it wrote
        before now (the pipe is read to its current end first)."""
        with self._lock:
            if not self._ended:
                self._take()
            return self.total > self.cap

    def text(self) -> str:
        """The tail of what was kept, for a fault's traceback."""
        with self._lock:
            if not self._ended:
                self._take()
            return self.tail.decode("utf-8", "replace")

    def close(self) -> None:
        """Stop reading (the controller has ended), close the pipe and the log file. Safe to
        call again, after a close that an interrupt cut short."""
        with self._lock:
            self._ended = True
        if self._woken >= 0:
            os.write(self._woken, b"x")
        self._thread.join(JOIN_TIME)
        self.handed_over()
        for name in ("_read", "_wake", "_woken"):
            fd = getattr(self, name)
            if fd >= 0:
                setattr(self, name, -1)
                os.close(fd)
        if self.file is not None:
            self.file.close()
