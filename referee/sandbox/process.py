"""A controller in its own process: a fresh interpreter running `robots.runner`, in a sandbox.

The process is spawned (exec'd, never a fork of the referee, so it holds no world state) inside
a kernel sandbox of its own (referee/sandbox/kernel.py: PID, mount, network, IPC namespaces, its own
uid or user namespace, the team's code copied in read-only). Where no sandbox can be made it
degrades, with a one-line warning, to a plain process in its own session, run as `nobody` when
the referee is root. It imports only `robots` and the team's code. The referee talks to it over
its stdin/stdout with the messages of `robots.protocol` and waits for each answer no longer
than the step's time allowance; whatever goes wrong becomes a typed `Fault`. Its stderr is a
pipe the referee caps (`log`); a root referee puts it in a control group of its own (`cgroup`).
"""

from __future__ import annotations

import functools
import io
import os
import select
import signal
import struct
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import robots
from arena.level import ControllerLimits
from referee.errors import LaserArenaWarning
from referee.sandbox import cgroup, forkserver, kernel
from referee.sandbox.bot import Fault, traceback_tail
from referee.sandbox.kernel import RUNNER_ENV
from referee.sandbox.log import TeamLog
from referee.sandbox.privacy import (
    check_readable_by_others,
    drop_to,
    is_root,
    share_team_files,
    slot_uid,
    switches_users,
)
from referee.sandbox.teams import Team
from robots import protocol
from robots.api import Brief, Command, Observation
from robots.loading import is_file_spec
from robots.protocol import PROTOCOL_VERSION, REPORTED, CommandMsg, FaultKind, FaultMsg, Loaded, Ready, Setup, Stop

ROBOTS_HOME = str(Path(robots.__file__).resolve().parent.parent)


@functools.cache
def _warn_unsandboxed(reason: str) -> None:
    """Say once per process, in one line, that controllers run without a kernel sandbox, why,
    and what would give them one (docs/security.md says what is then not enforced)."""
    warnings.warn(f"no kernel sandbox, controllers are not isolated: {reason}", LaserArenaWarning, stacklevel=1)


def isolation_unavailable() -> str | None:
    """Why controllers cannot run in processes of their own here (None: they can). The
    protocol waits on pipes with select(), which Windows offers for sockets only."""
    return "Windows has no select() on pipes" if sys.platform == "win32" else None


ENDING_TIME = 0.5  # seconds a controller whose output has ended may take to exit before it is killed
MAX_PROCS = 64  # processes and threads a slot may have at once (a controller needs one; no fork bomb)


def _joining(groups: list[int]) -> list[str]:
    """The runner's option to join the slot's control groups first (`groups`: descriptors of
    their `cgroup.procs`, opened here and inherited)."""
    return ["--join", ",".join(map(str, groups))] if groups else []


class ProcessBot:
    """A controller running in a separate process, with the InProcessBot interface.
    `slot` picks the controller's own uid (root referee); `sandboxed=False` skips the kernel
    sandbox, `forked=False` spawns a sandbox of its own where a root referee's template could fork
    it (both for the benchmarks that measure what they cost)."""

    def __init__(
        self,
        team: Team,
        limits: ControllerLimits = ControllerLimits(),
        log: Path | None = None,
        slot: int = 0,
        sandboxed: bool = True,
        forked: bool = True,
    ):
        if not team.entry:
            raise ValueError(f"team {team.label} has no code a controller process can load (run it in-process)")
        self.team, self.limits, self.log, self.slot = team, limits, log, slot
        self.sandboxed, self.forked = sandboxed, forked
        self.proc: subprocess.Popen[bytes] | forkserver.Forked | None = None
        self.buf = b""
        self.problem = ""  # what was wrong with the last malformed frame (a ProtocolError's text)
        self.bank = limits.overage_bank
        self.thinking = 0.0  # s of answer time so far this match (steps, and waits for late answers)
        self.think_limit = float("inf")  # the match's think budget in s, known at setup (brief.time_limit)
        self.skips = 0  # consecutive skipped ticks
        self.pending: int | None = None  # tick of an observation still unanswered
        self.sent = 0.0  # when the last observation was sent (time.monotonic)
        self.frame = bytearray()  # the step frame's buffer, reused every tick
        self.loaded = False  # the controller process has loaded the team's code
        self.folder: tempfile.TemporaryDirectory | None = None  # the team's files, without a sandbox
        self.info: int | None = None  # bwrap's info descriptor (kernel.init_pid)
        self.team_log: TeamLog | None = None  # the team's output, read from its pipe
        self.group: cgroup.SlotGroup | None = None  # the slot's control group (root referee)
        self.in_sandbox = False
        self.cpus: list[int] | None = None  # the CPUs the controller may run on (None: the referee's)
        self.told_to_end = False  # `stop` sent (`ask_to_end`)
        if sandboxed and forked:
            forkserver.start()  # a root referee's template imports while the match is being made

    def _spawn(self) -> None:
        reason = kernel.unavailable() if self.sandboxed else None
        if reason:
            _warn_unsandboxed(
                reason
                + (
                    "; controllers run as root: root cannot become nobody here"
                    if is_root() and drop_to() is None
                    else ""
                )
            )
        # the team's output: a pipe this process reads and caps (kept in a file of its own with --logs)
        self.team_log = TeamLog(int(self.limits.log_bytes), self.log)
        limits = ["--memory", str(int(self.limits.memory))]
        place = cgroup.available()
        if not isinstance(place, str):  # everything the slot holds, its tmpfs and pipes too, within memory_mb
            self.group = cgroup.SlotGroup(place, int(self.limits.memory), MAX_PROCS)
        groups = self.group.procs() if self.group else []
        try:
            if self.sandboxed and not reason:
                self._spawn_sandboxed(limits, self.team_log.writer, groups)
            else:
                self._spawn_plain(limits, self.team_log.writer, groups)
        finally:
            self.team_log.handed_over()
            for fd in groups:
                os.close(fd)

    def _spawn_sandboxed(self, limits: list[str], stderr: int, groups: list[int]) -> None:
        entry = self.team.entry
        if is_file_spec(entry):
            entry = f"{kernel.TEAM_DIR}/{entry}"
        limits = [*limits, "--path", kernel.TEAM_DIR]
        uid = slot_uid(self.slot) if switches_users() else None
        if uid is not None:  # a uid of its own: the kernel can count this slot's processes alone
            limits = [*limits, "--max-procs", str(MAX_PROCS)]
        self.in_sandbox = True
        server = forkserver.server() if uid is not None and self.forked else None
        if server is not None:  # forked from the template, into namespaces of its own
            config = {"uid": uid, "argv": [entry, *limits], **({"cpus": self.cpus} if self.cpus else {})}
            self.proc = self._forked(server, config, stderr, groups)
            return
        launch = kernel.launch(
            [kernel.PYTHON, "-s", "-m", "robots.runner", entry, *limits], self.team.files, kernel.SANDBOX_ENV, uid
        )
        self.info = launch.info
        try:
            self.proc = subprocess.Popen(
                [*launch.argv, *_joining(groups)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=stderr,
                env={"PATH": os.environ.get("PATH", "/usr/bin:/bin")},
                start_new_session=True,
                close_fds=True,
                pass_fds=(*launch.pass_fds, *groups),
            )
        finally:
            for fd in launch.pass_fds:
                os.close(fd)

    def _forked(self, server: forkserver.ForkServer, config: dict, stderr: int, groups: list[int]) -> forkserver.Forked:
        """A controller forked by `server`, with pipes as Popen makes them (the child's ends handed over)."""
        stdin_r, stdin_w = os.pipe()
        stdout_r, stdout_w = os.pipe()
        try:
            monitor = server.spawn(config, self.team.files, (stdin_r, stdout_w, stderr), groups)
        except BaseException:
            os.close(stdin_w)
            os.close(stdout_r)
            raise
        finally:
            os.close(stdin_r)
            os.close(stdout_w)
        return forkserver.Forked(monitor, open(stdin_w, "wb"), open(stdout_r, "rb"))

    def _spawn_plain(self, limits: list[str], stderr: int, groups: list[int]) -> None:
        user, as_user = drop_to(), dict[str, Any]()
        self.folder = tempfile.TemporaryDirectory(prefix="laserarena-team-")
        share_team_files(self.team.files, Path(self.folder.name))
        entry = self.team.entry
        if is_file_spec(entry):
            entry = str(Path(self.folder.name) / entry)
        if user is not None:  # the referee is root: the controller runs as nobody
            check_readable_by_others(sys.executable, ROBOTS_HOME)
            os.chmod(self.folder.name, 0o755)
            as_user = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[])
        env = {k: v for k, v in os.environ.items() if k in ("PATH", "LANG", "LC_ALL", "TZ")}
        # the child imports the very `robots` package this referee uses, installed or not, and
        # finds a module team in the copy of its package (the runner adds it once its limits are set)
        path = os.pathsep.join([ROBOTS_HOME] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
        env.update(RUNNER_ENV, PYTHONPATH=path)
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-s",
                "-m",
                "robots.runner",
                entry,
                *limits,
                "--path",
                self.folder.name,
                *_joining(groups),
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=stderr,
            cwd=self.folder.name,
            env=env,
            start_new_session=True,
            close_fds=True,
            pass_fds=groups,
            **as_user,
        )

    def _process(self) -> subprocess.Popen[bytes] | forkserver.Forked:
        """The controller process, started by `launch`."""
        if self.proc is None:
            raise RuntimeError("the controller process has not been launched")
        return self.proc

    def _pipes(self) -> tuple[IO[bytes], IO[bytes]]:
        """The controller's stdin and stdout (`launch` pipes both)."""
        stdin, stdout = self._process().stdin, self._process().stdout
        if stdin is None or stdout is None:
            raise RuntimeError("the controller process has no pipes")
        return stdin, stdout

    def _send(self, msg: protocol.Message, timeout: float) -> str | None:
        """Send one message within `timeout` seconds (`_write`)."""
        frame = io.BytesIO()
        protocol.write(frame, msg)
        return self._write(frame.getbuffer(), timeout)

    def _write(self, data: bytes | bytearray | memoryview, timeout: float) -> str | None:
        """Write `data` to the controller's input within `timeout` seconds (inf: no bound),
        never blocking beyond it: None once written, else a fault kind, `crash` (its input is
        closed: it ended) or `timeout` (it leaves its input unread and the pipe stays full)."""
        fd = self._pipes()[0].fileno()
        view, deadline = memoryview(data), time.monotonic() + timeout
        try:
            os.set_blocking(fd, False)
            while view:
                try:
                    view = view[os.write(fd, view) :]
                    continue
                except BlockingIOError:
                    pass
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([], [fd], [], None if left == float("inf") else left)[1]:
                    return "timeout"
        except OSError:
            return "crash"
        return None

    def _frame(self) -> protocol.Message | str | None:
        """The next whole message already read, `protocol` for a malformed one, None if none yet."""
        if len(self.buf) < 4:
            return None
        (size,) = struct.unpack(">I", self.buf[:4])
        if size > protocol.MAX_FRAME:
            self.problem = f"a frame of {size} bytes is over the {protocol.MAX_FRAME} limit"
            return "protocol"
        if len(self.buf) < 4 + size:
            return None
        frame, self.buf = self.buf[4 : 4 + size], self.buf[4 + size :]
        try:
            return protocol.parse(frame)
        except protocol.ProtocolError as e:
            self.problem = str(e)
            return "protocol"

    def _read(self) -> bool:
        """Read what the controller has written (one read; call when its stdout is readable);
        False at end of stream (the process ended)."""
        chunk = os.read(self._pipes()[1].fileno(), 1 << 16)
        self.buf += chunk
        return bool(chunk)

    def _receive(self, timeout: float) -> protocol.Message | str:
        """The next message, or a fault kind: `timeout`, `crash` (the process ended), `protocol`."""
        deadline = time.monotonic() + timeout  # inf: wait for ever (--no-limits)
        fd = self._pipes()[1].fileno()
        while True:
            got = self._frame()
            if got is not None:
                return got
            left = deadline - time.monotonic()
            if left <= 0:
                return "timeout"
            ready, _, _ = select.select([fd], [], [], None if left == float("inf") else left)
            if ready and not self._read():
                return "crash"

    def _fault(self, tick: int, t: float, what: str | protocol.Message, where: str) -> Fault:
        """A Fault from a failed exchange; the process is ended."""
        kind: FaultKind
        if isinstance(what, FaultMsg):
            kind = FaultKind(what.kind) if what.kind in REPORTED else FaultKind.PROTOCOL
            message = what.message[:500]
            if kind is FaultKind.LOAD:  # named as the team was given, not as the sandbox sees it
                message = message.replace(f"team {self._entry_seen()}", f"team {self.team.label}")
            message = " ".join(self._own_paths(message).split()) or f"in {where}"
        elif what == "flood" or what == "crash" and self._flooded():
            kind, message = (
                FaultKind.OUTPUT_FLOOD,
                f"in {where}: wrote more than {self.limits.log_bytes} bytes of output",
            )
        elif what == "crash":
            kind, message = self._crash(where)
        elif what == "timeout":
            kind = FaultKind.TIMEOUT
            message = (
                f"in {where}: {self.skips} skipped ticks in a row"
                if self.skips >= self.limits.max_skips
                else f"in {where}: think budget of {self.think_limit:g} s used up "
                f"({self.limits.think_budget:g} s per simulated second)"
                if self.thinking > self.think_limit
                else f"in {where}: overage bank exhausted"
                if where == "step"
                else f"in {where}: no answer within {self.limits.setup_time:g} s"
            )
        else:
            kind, message = FaultKind.PROTOCOL, f"in {where}: {self.problem or 'malformed message'}"
        tail = self._traceback()
        self.close()
        return Fault(tick, t, kind, message, traceback=tail)

    def _traceback(self) -> str | None:
        """The tail of the last traceback in the team's log, its sandbox folder left out so
        results stay byte-identical."""
        if self.team_log is None:
            return None
        return traceback_tail(self._own_paths(self.team_log.text()))

    def _own_paths(self, text: str) -> str:
        """`text` with the folder the team's files were put in (the sandbox's /team, or a
        temporary folder without a sandbox) left out: the team's own relative paths, the same
        on every machine and run."""
        if self.folder is not None:
            text = text.replace(self.folder.name + os.sep, "")
        return text.replace(kernel.TEAM_DIR + "/", "")

    def _flooded(self) -> bool:
        """Whether the controller has written more output than `log_kb` allows."""
        return self.team_log is not None and self.team_log.flooded()

    def _crash(self, where: str) -> tuple[FaultKind, str]:
        """The fault kind and message once the controller's output has ended."""
        code = self._ended()
        if code is None:
            return (
                FaultKind.PROTOCOL if self.loaded else FaultKind.LOAD
            ), f"in {where}: closed its output and did not exit"
        how = f"killed by {signal.Signals(-code).name}" if code < 0 else f"exited with code {code}"
        if code == -signal.SIGKILL and self.group is not None and self.group.oom_kills():
            how = f"killed for holding more than its {self.limits.memory / 2**20:g} MiB of memory (files in memory included)"
            return (FaultKind.MEMORY if self.loaded else FaultKind.LOAD), (
                f"in {where}: {how}" if self.loaded else f"team {self.team.label}: {how}"
            )
        problem = getattr(self._process(), "problem", "")  # a forked slot's monitor that failed
        if problem:  # before the team's code ran: the sandbox's, said as it was
            return FaultKind.LOAD, f"team {self.team.label}: its sandbox could not be made: {problem}"
        if not self.loaded:
            return FaultKind.LOAD, f"team {self.team.label}: {how} while its code was loading"
        return FaultKind.CRASH, f"in {where}: {how}"

    def _ended(self) -> int | None:
        """The status (`_status`) of a controller whose output has ended, or None if it still
        runs ENDING_TIME later: it closed its channel and lives on (`close` then kills it)."""
        try:
            self._process().wait(timeout=ENDING_TIME)
        except subprocess.TimeoutExpired:
            return None
        return self._status()

    def _status(self) -> int:
        """The controller's exit status as Popen gives it (negative: killed by that signal); bwrap
        passes a signal on as 128 + its number."""
        code = self._process().wait()  # ended already: its status
        if self.in_sandbox and 128 < code < 128 + signal.NSIG:
            return -(code - 128)
        return code

    def _entry_seen(self) -> str:
        """The entry as the controller process was given it."""
        if not is_file_spec(self.team.entry):
            return self.team.entry
        home = Path(self.folder.name) if self.folder else Path(kernel.TEAM_DIR)
        return f"{home}/{self.team.entry}"

    def launch(self) -> None:
        """Start the process (all bots are launched before any is set up: start-ups overlap)."""
        if self.proc is None:
            self._spawn()

    def setup(self, brief: Brief) -> Fault | None:
        self.launch()
        self.think_limit = self.limits.think_budget * brief.time_limit
        deadline = time.monotonic() + self.limits.setup_time
        unsent = self._send(Setup(v=PROTOCOL_VERSION, brief=brief), self.limits.setup_time)
        if unsent:
            return self._fault(0, 0.0, unsent, "setup")
        reply = self._receive(deadline - time.monotonic())
        if isinstance(reply, Loaded):
            self.loaded = True
            problem = protocol.api_problem(reply.api)
            if problem:
                self.close()
                return Fault(0, 0.0, FaultKind.LOAD, problem)
            reply = self._receive(deadline - time.monotonic())
        if isinstance(reply, Ready) and self.loaded:
            return self._fault(0, 0.0, "flood", "setup") if self._flooded() else None
        return self._fault(0, 0.0, _trouble(reply), "setup")

    def _drain(self, obs: Observation) -> Fault | None:
        """Wait for the late answer to a skipped tick, charging the wait to the overage bank."""
        start = time.monotonic()
        reply = self._receive(max(min(self.bank, self.think_limit - self.thinking), 0.0))
        self.bank -= time.monotonic() - start
        self.thinking += time.monotonic() - start
        if reply == "timeout":
            return self._fault(obs.tick, obs.time, "timeout", "step")
        if isinstance(reply, CommandMsg) and reply.tick == self.pending:
            self.pending = None  # too late: dropped, the tick was skipped
            return None
        return self._fault(obs.tick, obs.time, _trouble(reply), "step")

    def step(self, obs: Observation) -> Command | Fault:
        """The controller's answer, a skipped tick (non-fatal Fault) or a fatal Fault.

        Within `step_time`: normal. Up to `step_deadline`: accepted, the excess drawn from the
        overage bank. Later: a skipped tick; the late answer is awaited (and charged) before the
        next observation. `max_skips` in a row, an empty bank, or answers that together take
        longer than the think budget disqualify the robot.
        (`exchange` does the same for several controllers at once.)"""
        fault = self.send(obs)
        if fault:
            return fault
        reply = self._receive(self.limits.step_deadline)
        return self.judge(obs, reply, time.monotonic() - self.sent)

    def send(self, obs: Observation) -> Fault | None:
        """The first half of a step: wait out a skipped tick's late answer, send `obs` and start
        its clock (`sent`). A Fault if the controller is gone."""
        if self.pending is not None:
            fault = self._drain(obs)
            if fault:
                return fault
        unsent = self._write(protocol.step_frame(obs, self.frame), self.limits.step_deadline)
        if unsent == "timeout":  # its input still full of observations: it answers without reading them
            self.problem = "it does not read its observations"
            return self._fault(obs.tick, obs.time, "protocol", "step")
        if unsent:
            return self._fault(obs.tick, obs.time, unsent, "step")
        self.sent = time.monotonic()
        return None

    def judge(self, obs: Observation, reply: protocol.Message | str, took: float) -> Command | Fault:
        """The second half of a step: the answer `reply` (or fault kind), `took` seconds after
        `send`, weighed against the allowances."""
        if self._flooded():  # all it wrote before this answer (or deadline) is counted by now
            return self._fault(obs.tick, obs.time, "flood", "step")
        self.thinking += took
        if reply == "timeout":
            self.pending = obs.tick
            self.bank -= self.limits.step_deadline - self.limits.step_time
            self.skips += 1
            if self.skips >= self.limits.max_skips or self.bank <= 0 or self.thinking > self.think_limit:
                return self._fault(obs.tick, obs.time, "timeout", "step")
            return Fault(
                obs.tick,
                obs.time,
                FaultKind.SKIPPED_TICK,
                f"no answer within {self.limits.step_deadline:g} s",
                fatal=False,
            )
        self.skips = 0
        if took > self.limits.step_time:
            self.bank -= took - self.limits.step_time
            if self.bank <= 0:
                return self._fault(obs.tick, obs.time, "timeout", "step")
        if self.thinking > self.think_limit:
            return self._fault(obs.tick, obs.time, "timeout", "step")
        if isinstance(reply, CommandMsg) and reply.tick == obs.tick:
            try:
                cmd = protocol.decoded(reply.command, Command)
            except protocol.ProtocolError as e:
                self.close()
                return Fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, str(e))
            problem = protocol.command_problem(protocol.sendable(cmd))
            if problem:
                self.close()
                return Fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, problem)
            return cmd
        if isinstance(reply, CommandMsg):  # answered twice, or ahead
            self.problem = f"an answer for tick {reply.tick} when tick {obs.tick} was asked"
        return self._fault(obs.tick, obs.time, _trouble(reply), "step")

    def ask_to_end(self) -> None:
        """Tell the controller the match is over, without waiting for it (`close` waits): a
        match that tells all its controllers first lets them end side by side."""
        if self.proc is not None and not self.told_to_end and self.proc.poll() is None:
            self.told_to_end = True
            self._send(Stop(v=PROTOCOL_VERSION), 0.0)  # no wait: an input left full is no reason to stay

    def close(self) -> None:
        """End the process and everything it started: in a sandbox, its init is killed, which
        kills every process of its PID namespace; bwrap returns once they are all gone."""
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.ask_to_end()
            try:
                self.proc.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                pass
        if self.info is not None:
            init, self.info = kernel.init_pid(self.info), None
            if init is not None and self.proc.poll() is None:
                try:
                    os.kill(init, signal.SIGKILL)
                except (ProcessLookupError, PermissionError):
                    pass
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    pass
        if isinstance(self.proc, forkserver.Forked):
            if self.proc.poll() is None:
                self.proc.kill()  # its monitor kills its init: the PID namespace goes with it
        else:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)  # its whole session, children included
            except (ProcessLookupError, PermissionError):
                pass
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass
        if self.folder is not None:
            self.folder.cleanup()
            self.folder = None
        if self.team_log is not None:
            self.team_log.close()
            self.team_log = None
        if self.group is not None:
            self.group.close()
            self.group = None


def _trouble(reply: protocol.Message | str) -> FaultMsg | str:
    """What a reply that is not the one awaited says: a fault it reports, the trouble met, or,
    for any other message, a protocol fault."""
    return reply if isinstance(reply, (FaultMsg, str)) else "protocol"


def exchange(
    bots: list[Any], observations: list[Observation | None], meanwhile: Callable[[], None] | None = None
) -> list[Command | Fault | None]:
    """Every bot's answer to its observation (None where it has none), as `step` gives it. All
    observations go out before any answer is awaited, so controller processes compute at the
    same time, while this process does `meanwhile` (work of its own that needs no answer).
    Each answer is timed from its own sending to its own arrival; one that arrived while the
    referee was busy with `meanwhile`, to when that work began."""
    out: list[Command | Fault | None] = [None] * len(bots)
    waiting: dict[int, ProcessBot] = {}
    for slot, (bot, obs) in enumerate(zip(bots, observations)):
        if obs is None:
            continue
        if not isinstance(bot, ProcessBot):
            out[slot] = bot.step(obs)  # a controller in this process answers at once
        elif fault := bot.send(obs):
            out[slot] = fault
        else:
            waiting[slot] = bot
    replies: dict[int, tuple[protocol.Message | str, float]] = {}
    if meanwhile is not None and waiting:
        began = time.monotonic()
        meanwhile()
        # an answer that came in while the referee was busy is timed to when the referee began:
        # the referee, not the controller, kept it waiting; later answers are timed as always
        readers = {bot._pipes()[1].fileno(): slot for slot, bot in waiting.items()}
        for fd in select.select(list(readers), [], [], 0)[0]:
            slot = readers[fd]
            bot = waiting[slot]
            got = bot._frame() if bot._read() else "crash"
            if got is not None:
                replies[slot] = (got, max(0.0, began - bot.sent))
                del waiting[slot]
    while waiting:
        now = time.monotonic()
        for slot, bot in list(waiting.items()):
            got = bot._frame()
            if got is None and now - bot.sent >= bot.limits.step_deadline:
                got = "timeout"
            if got is not None:
                replies[slot] = (got, now - bot.sent)
                del waiting[slot]
        if not waiting:
            break
        left = min(bot.sent + bot.limits.step_deadline for bot in waiting.values()) - time.monotonic()
        readers = {bot._pipes()[1].fileno(): slot for slot, bot in waiting.items()}
        ready, _, _ = select.select(list(readers), [], [], None if left == float("inf") else max(left, 0.0))
        for fd in ready:
            slot = readers[fd]
            if not waiting[slot]._read():
                replies[slot] = ("crash", time.monotonic() - waiting[slot].sent)
                del waiting[slot]
    for slot in sorted(replies):
        obs = observations[slot]
        assert obs is not None
        out[slot] = bots[slot].judge(obs, *replies[slot])
    return out
