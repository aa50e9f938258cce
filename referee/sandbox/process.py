"""A controller in its own process: a fresh interpreter running `robots.runner`.

The process is spawned (exec'd, never a fork of the referee, so it holds no world state),
in its own session, with a minimal environment and an empty working folder; when the referee
is root it runs as `nobody`, with the team's file copied where that user can read it. It
imports only `robots` and the team's code. The referee talks to it over its stdin/stdout with the
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
from pathlib import Path

import robots
from arena.level import ControllerLimits
from referee.sandbox.bot import Fault
from referee.sandbox.privacy import check_readable_by_others, drop_to, share_team_file
from referee.sandbox.teams import Team
from robots import protocol
from robots.api import Brief, Command, Observation
from robots.loading import is_file_spec

FAULT_KINDS = {"exception", "memory", "bad_command"}  # what a controller may report of itself
ROBOTS_HOME = str(Path(robots.__file__).resolve().parent.parent)


class ProcessBot:
    """A controller running in a separate process, with the InProcessBot interface."""

    def __init__(self, team: Team, limits: ControllerLimits = ControllerLimits(), log: Path | None = None):
        if not team.spec:
            raise ValueError(f"team {team.label} has no spec a controller process can load")
        self.team, self.limits, self.log = team, limits, log
        self.proc: subprocess.Popen | None = None
        self.buf = b""
        self.bank = limits.overage_bank
        self.skips = 0  # consecutive skipped ticks
        self.pending: int | None = None  # tick of an observation still unanswered
        self.folder = tempfile.TemporaryDirectory(prefix="laserarena-team-")

    def _spawn(self) -> None:
        spec, user = self.team.spec, drop_to()
        as_user: dict = {}
        if user is not None:  # the referee is root: the controller runs as nobody
            check_readable_by_others(sys.executable, ROBOTS_HOME)
            os.chmod(self.folder.name, 0o755)
            if is_file_spec(spec):
                spec = share_team_file(spec, Path(self.folder.name))
            as_user = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[])
        env = {k: v for k, v in os.environ.items() if k in ("PATH", "LANG", "LC_ALL", "TZ")}
        # the child imports the very `robots` package this referee uses, installed or not,
        # and whatever else the referee was pointed at, so module specs load the same way
        path = os.pathsep.join([ROBOTS_HOME] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
        env.update(PYTHONPATH=path, PYTHONHASHSEED="0", PYTHONDONTWRITEBYTECODE="1", OPENBLAS_NUM_THREADS="1",
                   OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        log = self.log or Path(self.folder.name) / "team.log"  # kept only with --logs
        stderr = open(log, "wb")
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "robots.runner", spec, "--memory", str(int(self.limits.memory)),
                 "--log-cap", str(int(self.limits.log_bytes))],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, cwd=self.folder.name,
                env=env, start_new_session=True, close_fds=True, **as_user)
        finally:
            stderr.close()

    def _send(self, msg: dict) -> bool:
        try:
            protocol.write(self.proc.stdin, msg)
            return True
        except (BrokenPipeError, OSError):
            return False

    def _receive(self, timeout: float) -> dict | str:
        """The next message, or a fault kind: `timeout`, `crash` (the process ended), `protocol`."""
        deadline = time.monotonic() + timeout  # inf: wait for ever (--no-limits)
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
            ready, _, _ = select.select([fd], [], [], None if left == float("inf") else left)
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
            if code == -signal.SIGXFSZ:
                kind, message = "output_flood", f"in {where}: wrote more than {self.limits.log_bytes} bytes of output"
            else:
                kind = "crash"
                message = (f"in {where}: killed by {signal.Signals(-code).name}" if code < 0
                           else f"in {where}: exited with code {code}")
        elif what == "timeout":
            kind = "timeout"
            message = (f"in {where}: {self.skips} skipped ticks in a row" if self.skips >= self.limits.max_skips
                       else f"in {where}: overage bank exhausted" if where == "step"
                       else f"in {where}: no answer within {self.limits.setup_time:g} s")
        else:
            kind, message = "protocol", f"in {where}: malformed message"
        self.close()
        return Fault(tick, t, kind, message)

    def launch(self) -> None:
        """Start the process (all bots are launched before any is set up: start-ups overlap)."""
        if self.proc is None:
            self._spawn()

    def setup(self, brief: Brief) -> Fault | None:
        self.launch()
        if not self._send({"type": "setup", "brief": protocol.to_plain(brief)}):
            return self._fault(0, 0.0, "crash", "setup")
        reply = self._receive(self.limits.setup_time)
        if isinstance(reply, dict) and reply["type"] == "ready":
            return None
        return self._fault(0, 0.0, reply if not isinstance(reply, dict) or reply["type"] == "fault"
                           else "protocol", "setup")

    def _drain(self, obs: Observation) -> Fault | None:
        """Wait for the late answer to a skipped tick, charging the wait to the overage bank."""
        start = time.monotonic()
        reply = self._receive(max(self.bank, 0.0))
        self.bank -= time.monotonic() - start
        if reply == "timeout":
            return self._fault(obs.tick, obs.time, "timeout", "step")
        if isinstance(reply, dict) and reply["type"] == "command" and reply.get("tick") == self.pending:
            self.pending = None  # too late: dropped, the tick was skipped
            return None
        return self._fault(obs.tick, obs.time, reply if not isinstance(reply, dict) or reply["type"] == "fault"
                           else "protocol", "step")

    def step(self, obs: Observation) -> Command | Fault:
        """The controller's answer, a skipped tick (non-fatal Fault) or a fatal Fault.

        Within `step_time`: normal. Up to `step_deadline`: accepted, the excess drawn from the
        overage bank. Later: a skipped tick; the late answer is awaited (and charged) before the
        next observation. `max_skips` in a row, or an empty bank, disqualify the robot."""
        if self.pending is not None:
            fault = self._drain(obs)
            if fault:
                return fault
        if not self._send({"type": "step", "obs": protocol.to_plain(obs)}):
            return self._fault(obs.tick, obs.time, "crash", "step")
        start = time.monotonic()
        reply = self._receive(self.limits.step_deadline)
        took = time.monotonic() - start
        if reply == "timeout":
            self.pending = obs.tick
            self.bank -= self.limits.step_deadline - self.limits.step_time
            self.skips += 1
            if self.skips >= self.limits.max_skips or self.bank <= 0:
                return self._fault(obs.tick, obs.time, "timeout", "step")
            return Fault(obs.tick, obs.time, "skipped_tick",
                         f"no answer within {self.limits.step_deadline:g} s", fatal=False)
        self.skips = 0
        if took > self.limits.step_time:
            self.bank -= took - self.limits.step_time
            if self.bank <= 0:
                return self._fault(obs.tick, obs.time, "timeout", "step")
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
