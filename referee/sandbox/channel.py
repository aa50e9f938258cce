"""The framed channel to a controller process: protocol messages over its stdin and stdout,
each write and each wait bounded by a deadline, and every read non-blocking: a controller that
takes back bytes from its own pipe (it may reopen it) stalls nothing but its own answer. An
answer is bounded in bytes from its header, before it is read (`protocol.answer_bound`), and
decoded once. What goes wrong is a `Trouble` (the fault kind it leads to): the caller, which
knows the allowances, judges it."""

from __future__ import annotations

import io
import os
import select
import struct
import time
from enum import StrEnum
from typing import IO

from robots._host import protocol


class Trouble(StrEnum):
    """Why no message came or went: the process ended (`crash`), the deadline passed
    (`timeout`), its bytes were no message (`protocol`) or a `command` message whose command
    fails its checks (`bad_command`; the channel's `problem` says why for both), or, found by
    its log rather than here, it wrote more output than it may (`flood`)."""

    CRASH = "crash"
    TIMEOUT = "timeout"
    PROTOCOL = "protocol"
    BAD_COMMAND = "bad_command"
    FLOOD = "flood"


HEAD = struct.Struct(">I")  # a frame's length
READ_SIZE = 1 << 16  # bytes asked of the pipe at once (a pipe holds 64 KiB)


class Channel:
    """A controller's input and output pipes, and what has been read of its output."""

    def __init__(self, stdin: IO[bytes] | None, stdout: IO[bytes] | None):
        if stdin is None or stdout is None:
            raise RuntimeError("the controller process has no pipes")
        self.stdin, self.stdout = stdin, stdout
        os.set_blocking(stdin.fileno(), False)  # once: `write` never blocks beyond its deadline
        os.set_blocking(stdout.fileno(), False)  # and `read` never blocks at all
        self.buf = bytearray()
        self.bound = protocol.answer_bound()  # the most bytes an answer may have
        self.arrived: float | None = None  # when the whole of the next frame had been read (`read`'s stamp)
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

    def write_now(self, data: bytes | bytearray | memoryview) -> memoryview | Trouble:
        """Write what the controller's input takes now of `data`, without waiting: the rest
        (empty once all is written), or `crash` (its input is closed: it ended)."""
        view = memoryview(data)
        try:
            while view:
                view = view[os.write(self.stdin.fileno(), view) :]
        except BlockingIOError:
            pass
        except OSError:
            return Trouble.CRASH
        return view if view else memoryview(b"")  # done: nothing holds the caller's buffer

    def whole(self) -> bool:
        """Whether the next frame can be judged now: it has been read whole, or its header
        alone says it is over the bound."""
        buf = self.buf
        if len(buf) < HEAD.size:
            return False
        (size,) = HEAD.unpack_from(buf)
        return size > self.bound or len(buf) >= HEAD.size + size

    def message(self) -> protocol.Message | Trouble | None:
        """The next whole message already read, decoded (`protocol`/`bad_command` for a malformed
        one), None if none yet."""
        if not self.whole():
            return None
        (size,) = HEAD.unpack_from(self.buf)
        if size > self.bound:
            self.problem = (
                f"a frame of {size} bytes is over the {self.bound}-byte bound of an answer (docs/protocol.md)"
            )
            return Trouble.PROTOCOL
        frame = self.buf[HEAD.size : HEAD.size + size]  # a copy: nothing decoded holds the buffer
        del self.buf[: HEAD.size + size]
        self.arrived = self.arrived if self.whole() else None
        try:
            return protocol.answer(frame)
        except protocol.CommandError as e:
            self.problem = str(e)
            return Trouble.BAD_COMMAND
        except protocol.ProtocolError as e:
            self.problem = str(e)
            return Trouble.PROTOCOL

    def read(self, stamp: float | None = None) -> bool:
        """Read what the controller's output holds now (one non-blocking read: call when select()
        says it is readable; nothing may be there, if the controller took it back); False at end
        of stream (the process ended). `stamp` (default now) is when the referee found it: a
        frame this read completes is timed to it (`arrived`)."""
        try:
            chunk = os.read(self.fileno(), READ_SIZE)
        except BlockingIOError:
            return True
        if not chunk:
            return False
        self.buf += chunk
        if self.arrived is None and self.whole():
            self.arrived = time.monotonic() if stamp is None else stamp
        return True

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
