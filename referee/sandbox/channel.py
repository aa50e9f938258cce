"""The framed channel to a controller process: protocol messages over its stdin and stdout,
each write and each wait bounded by a deadline, never blocking beyond it. What goes wrong is a
`Trouble` (the fault kind it leads to): the caller, which knows the allowances, judges it."""

from __future__ import annotations

import io
import os
import select
import struct
import time
from enum import StrEnum
from typing import IO

from robots import protocol


class Trouble(StrEnum):
    """Why no message came or went: the process ended (`crash`), the deadline passed
    (`timeout`), its bytes were no message (`protocol`; the channel's `problem` says why), or,
    found by its log rather than here, it wrote more output than it may (`flood`)."""

    CRASH = "crash"
    TIMEOUT = "timeout"
    PROTOCOL = "protocol"
    FLOOD = "flood"


class Channel:
    """A controller's input and output pipes, and what has been read of its output."""

    def __init__(self, stdin: IO[bytes] | None, stdout: IO[bytes] | None):
        if stdin is None or stdout is None:
            raise RuntimeError("the controller process has no pipes")
        self.stdin, self.stdout = stdin, stdout
        os.set_blocking(stdin.fileno(), False)  # once: `write` never blocks beyond its deadline
        self.buf = b""
        self.problem = ""  # what was wrong with the last malformed frame (a ProtocolError's text)

    def fileno(self) -> int:
        """The controller's output, to wait on with select()."""
        return self.stdout.fileno()

    def send(self, msg: protocol.Message, timeout: float) -> Trouble | None:
        """Send one message within `timeout` seconds (`write`)."""
        frame = io.BytesIO()
        protocol.write(frame, msg)
        return self.write(frame.getbuffer(), timeout)

    def write(self, data: bytes | bytearray | memoryview, timeout: float) -> Trouble | None:
        """Write `data` to the controller's input within `timeout` seconds (inf: no bound),
        never blocking beyond it: None once written, else `crash` (its input is closed: it
        ended) or `timeout` (it leaves its input unread and the pipe stays full)."""
        fd = self.stdin.fileno()
        view, deadline = memoryview(data), time.monotonic() + timeout
        try:
            while view:
                try:
                    view = view[os.write(fd, view) :]
                    continue
                except BlockingIOError:
                    pass
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([], [fd], [], None if left == float("inf") else left)[1]:
                    return Trouble.TIMEOUT
        except OSError:
            return Trouble.CRASH
        return None

    def message(self) -> protocol.Message | Trouble | None:
        """The next whole message already read, `protocol` for a malformed one, None if none yet."""
        if len(self.buf) < 4:
            return None
        (size,) = struct.unpack(">I", self.buf[:4])
        if size > protocol.MAX_FRAME:
            self.problem = f"a frame of {size} bytes is over the {protocol.MAX_FRAME} limit"
            return Trouble.PROTOCOL
        if len(self.buf) < 4 + size:
            return None
        frame, self.buf = self.buf[4 : 4 + size], self.buf[4 + size :]
        try:
            return protocol.parse(frame)
        except protocol.ProtocolError as e:
            self.problem = str(e)
            return Trouble.PROTOCOL

    def read(self) -> bool:
        """Read what the controller has written (one read; call when its output is readable);
        False at end of stream (the process ended)."""
        chunk = os.read(self.fileno(), 1 << 16)
        self.buf += chunk
        return bool(chunk)

    def receive(self, timeout: float) -> protocol.Message | Trouble:
        """The next message within `timeout` seconds (inf: wait for ever, --no-limits), or the trouble."""
        deadline = time.monotonic() + timeout
        fd = self.fileno()
        while True:
            got = self.message()
            if got is not None:
                return got
            left = deadline - time.monotonic()
            if left <= 0:
                return Trouble.TIMEOUT
            ready, _, _ = select.select([fd], [], [], None if left == float("inf") else left)
            if ready and not self.read():
                return Trouble.CRASH

    def close(self) -> None:
        """Close both pipes (the process has ended)."""
        for stream in (self.stdin, self.stdout):
            try:
                stream.close()
            except OSError:
                pass
