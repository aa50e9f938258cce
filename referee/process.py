"""A controller in its own process: a fresh interpreter running `robots.runner`.

The process is spawned (exec'd, never a fork of the referee, so it holds no world state),
in its own session, with a minimal environment and an empty working folder. It imports only
`robots` and the team's code. The referee talks to it over its stdin/stdout with the
messages of `robots.protocol` and waits for each answer no longer than the step's time
allowance; whatever goes wrong becomes a typed `Fault`.
"""

from __future__ import annotations

import os
import select
import signal
import struct
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from referee.bot import Fault
import robots
from referee.teams import Team
from robots import protocol
from robots.api import Brief, Command, Observation

FAULT_KINDS = {"exception", "memory", "bad_command"}  # what a controller may report of itself
ROBOTS_HOME = str(Path(robots.__file__).resolve().parent.parent)


@dataclass(frozen=True)
class Limits:
    """Resource limits of one controller process."""

    setup_time: float = 10.0  # s (wall) for start-up, import and setup()
    step_time: float = 1.0  # s (wall) to answer one observation
    memory: int = 2 << 30  # bytes of address space


class ProcessBot:
    """A controller running in a separate process, with the InProcessBot interface."""

    def __init__(self, team: Team, limits: Limits = Limits(), log: Path | None = None):
        if not team.spec:
            raise ValueError(f"team {team.label} has no spec a controller process can load")
        self.team, self.limits, self.log = team, limits, log
        self.proc: subprocess.Popen | None = None
        self.buf = b""
        self.folder = tempfile.TemporaryDirectory(prefix="laserarena-team-")

    def _spawn(self) -> None:
        env = {k: v for k, v in os.environ.items() if k in ("PATH", "LANG", "LC_ALL", "TZ")}
        # the child imports the very `robots` package this referee uses, installed or not
        env.update(PYTHONPATH=ROBOTS_HOME, PYTHONHASHSEED="0", PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        stderr = open(self.log, "ab") if self.log else subprocess.DEVNULL
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "robots.runner", self.team.spec, "--memory", str(self.limits.memory)],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, cwd=self.folder.name,
                env=env, start_new_session=True, close_fds=True)
        finally:
            if self.log:
                stderr.close()

    def _send(self, msg: dict) -> bool:
        try:
            protocol.write(self.proc.stdin, msg)
            return True
        except (BrokenPipeError, OSError):
            return False

    def _receive(self, timeout: float) -> dict | str:
        """The next message, or a fault kind: `timeout`, `crash` (the process ended), `protocol`."""
        deadline = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while True:
            if len(self.buf) >= 4:
                (size,) = struct.unpack(">I", self.buf[:4])
                if size > protocol.MAX_FRAME:
                    return "protocol"
                if len(self.buf) >= 4 + size:
                    frame, self.buf = self.buf[4:4 + size], self.buf[4 + size:]
                    try:
                        return protocol.parse(frame)
                    except protocol.ProtocolError:
                        return "protocol"
            left = deadline - time.monotonic()
            if left <= 0:
                return "timeout"
            ready, _, _ = select.select([fd], [], [], left)
            if ready:
                chunk = os.read(fd, 1 << 16)
                if not chunk:
                    return "crash"
                self.buf += chunk

    def _fault(self, tick: int, t: float, what: str | dict, where: str) -> Fault:
        """A Fault from a failed exchange; the process is ended."""
        if isinstance(what, dict):
            kind = what.get("kind") if what.get("kind") in FAULT_KINDS else "protocol"
            message = str(what.get("message", ""))[:500]
            message = " ".join(message.split()) or f"in {where}"
        elif what == "crash":
            self.proc.wait()
            code = self.proc.returncode
            kind = "crash"
            message = (f"in {where}: killed by {signal.Signals(-code).name}" if code < 0
                       else f"in {where}: exited with code {code}")
        elif what == "timeout":
            kind, message = "timeout", f"in {where}: no answer within the time allowed"
        else:
            kind, message = "protocol", f"in {where}: malformed message"
        self.close()
        return Fault(tick, t, kind, message)

    def setup(self, brief: Brief) -> Fault | None:
        self._spawn()
        if not self._send({"type": "setup", "brief": protocol.to_plain(brief)}):
            return self._fault(0, 0.0, "crash", "setup")
        reply = self._receive(self.limits.setup_time)
        if isinstance(reply, dict) and reply["type"] == "ready":
            return None
        return self._fault(0, 0.0, reply if not isinstance(reply, dict) or reply["type"] == "fault"
                           else "protocol", "setup")

    def step(self, obs: Observation) -> Command | Fault:
        if not self._send({"type": "step", "obs": protocol.to_plain(obs)}):
            return self._fault(obs.tick, obs.time, "crash", "step")
        reply = self._receive(self.limits.step_time)
        if isinstance(reply, dict) and reply["type"] == "command" and reply.get("tick") == obs.tick:
            try:
                cmd = protocol.command_from(reply.get("command"))
            except protocol.ProtocolError as e:
                self.close()
                return Fault(obs.tick, obs.time, "bad_command", str(e))
            problem = protocol.command_problem(cmd)
            if problem:
                self.close()
                return Fault(obs.tick, obs.time, "bad_command", problem)
            return cmd
        if isinstance(reply, dict) and reply["type"] != "fault":
            reply = "protocol"
        return self._fault(obs.tick, obs.time, reply, "step")

    def close(self) -> None:
        """End the process and everything it started."""
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self._send({"type": "stop"})
            try:
                self.proc.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)  # its whole session, children included
        except (ProcessLookupError, PermissionError):
            pass
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            try:
                stream.close()
            except OSError:
                pass
        self.folder.cleanup()
