"""A controller in its own process, in a sandbox, with the `Bot` interface (`bot`).

The process is started by `launch` (forked from a root referee's template, spawned in a bwrap
sandbox of its own, or, where no sandbox can be made, a plain process); it imports only
`robots` and the team's code. The referee talks to it over a framed `channel` with the
messages of `robots._host.protocol`, waits for each answer no longer than its time `allowance`
permits, and turns whatever goes wrong into a typed `Fault`. Its stderr is a pipe the referee
caps (`log`); a root referee puts it in a control group of its own (`cgroup`).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from levels.match import ControllerLimits
from referee.records.results import Fault
from referee.sandbox import cgroup, exits, forkserver, kernel
from referee.sandbox.allowance import Allowance
from referee.sandbox.bot import Reply
from referee.sandbox.channel import Channel, Trouble
from referee.sandbox.fault import fault, traceback_tail
from referee.sandbox.launch import MAX_PROCS, Launched, Plan, launch
from referee.sandbox.log import TeamLog
from referee.sandbox.teams import Team
from robots._host import protocol
from robots._host.loading import is_file_spec
from robots._host.protocol import (
    PROTOCOL_VERSION,
    REPORTED,
    CommandMsg,
    FaultKind,
    FaultMsg,
    Loaded,
    Ready,
    Setup,
    Stop,
)
from robots.api import Brief, Command, Observation

ENDING_TIME = 0.5  # seconds a controller whose output has ended may take to exit before it is killed
STOP_TIME = 0.5  # seconds a controller told the match is over may take to exit before it is killed


def isolation_unavailable() -> str | None:
    """Why controllers cannot run in processes of their own here (None: they can). The
    channel waits on pipes with select(), which Windows offers for sockets only."""
    return "Windows has no select() on pipes" if sys.platform == "win32" else None


def exit_status(proc: subprocess.Popen[bytes] | forkserver.Forked, timeout: float) -> int | None:
    """The exit status of `proc` as Popen gives it (negative: killed by that signal) once it
    has ended, waiting at most `timeout` seconds; None if it still runs. A spawned process is
    left unreaped: until `close` reaps it, its pid names it alone, so its process group can be
    signalled without hitting another's."""
    if isinstance(proc, forkserver.Forked) or proc.returncode is not None or not hasattr(os, "waitid"):
        try:
            return proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
    if not exits.ended(proc, timeout):
        return None
    try:
        status = os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:  # reaped already
        return proc.poll()
    if status is None:
        return None
    return -status.si_status if status.si_code in (os.CLD_KILLED, os.CLD_DUMPED) else status.si_status


class ProcessBot:
    """A controller running in a separate process. `slot` picks the controller's own uid (root
    referee); `sandboxed=False` skips the kernel sandbox, `forked=False` spawns a sandbox of its
    own where a root referee's template could fork it (both for the benchmarks that measure
    what they cost)."""

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
        self.cpus: list[int] | None = None  # the CPUs the controller may run on (None: the referee's)
        self.isolated = True
        self.allowance = Allowance(limits)
        self.started: Launched | None = None  # the process, once launched
        self._pipes: Channel | None = None  # its stdin and stdout, once launched
        self.sent = 0.0  # when the last observation was sent (time.monotonic)
        self.deadline = 0.0  # when its answer to it is late
        self.unsent = memoryview(b"")  # what its input has not taken yet of the last observation
        self.frame = bytearray()  # the step frame's buffer, reused every tick
        self.loaded = False  # the controller process has loaded the team's code
        self.team_log: TeamLog | None = None  # the team's output, read from its pipe
        self.group: cgroup.SlotGroup | None = None  # the slot's control group (root referee)
        self.told_to_end = False  # `stop` sent (`ask_to_end`)
        if sandboxed and forked:
            forkserver.start()  # a root referee's template imports while the match is being made

    @property
    def proc(self) -> subprocess.Popen[bytes] | forkserver.Forked | None:
        """The controller process, once launched."""
        return None if self.started is None else self.started.proc

    @property
    def channel(self) -> Channel:
        """The framed channel to the controller process (`launch` makes it)."""
        if self._pipes is None:
            raise RuntimeError("the controller process has not been launched")
        return self._pipes

    def pin(self, cpus: list[int]) -> None:
        """Before `launch`: the controller's process runs on `cpus` only."""
        self.cpus = list(cpus)

    def prepare(self) -> None:
        """What the slot needs before its process starts: the pipe its output comes by, and its
        control groups. A match prepares every slot before it starts any (`Fleet.launch`): a
        group made while another slot's process joins its own waited for that move's grace
        period (12-20 ms of every match's start)."""
        if self.team_log is None:  # the team's output: a pipe this process reads and caps (a file too with --logs)
            self.team_log = TeamLog(int(self.limits.log_bytes), self.log)
        if self.group is None and not isinstance(cgroup.available(), str):  # all the slot holds, within memory_mb
            self.group = cgroup.SlotGroup(int(self.limits.memory), MAX_PROCS)

    def launch(self) -> None:
        """Start the process (all bots are launched before any is set up: start-ups overlap)."""
        if self.started is not None:
            return
        self.prepare()
        assert self.team_log is not None
        groups = self.group.procs() if self.group else []
        plan = Plan(self.team, int(self.limits.memory), self.slot, self.sandboxed, self.forked, self.cpus)
        try:
            self.started = launch(plan, self.team_log.writer, groups)
        finally:
            self.team_log.handed_over()
            for fd in groups:
                os.close(fd)
        self._pipes = Channel(self.started.proc.stdin, self.started.proc.stdout)

    def setup(self, brief: Brief) -> Fault | None:
        self.launch()
        self.allowance.begin(brief.time_limit)
        deadline = time.monotonic() + self.limits.setup_time
        channel = self.channel
        unsent = channel.send(Setup(v=PROTOCOL_VERSION, brief=brief), self.limits.setup_time)
        if unsent and unsent is not Trouble.CRASH:
            return self._fault(0, 0.0, unsent, "setup")
        # a controller that ended before its brief could be written (its team's module failed to
        # load, say) told why first: what it wrote is read on, as from one that ended later
        reply = channel.receive(deadline - time.monotonic())
        if isinstance(reply, Loaded):
            self.loaded = True
            problem = protocol.api_problem(reply.api)
            if problem:
                self.close()
                return fault(0, 0.0, FaultKind.LOAD, problem)
            reply = channel.receive(deadline - time.monotonic())
        if isinstance(reply, Ready) and self.loaded:
            return self._fault(0, 0.0, Trouble.FLOOD, "setup") if self._flooded() else None
        return self._fault(0, 0.0, _trouble(reply), "setup")

    def step(self, obs: Observation) -> Command | Fault:
        """The controller's answer, a skipped tick (non-fatal Fault) or a fatal Fault, by the
        rules of its time `allowance`. (`exchange` does the same for several controllers at once.)"""
        sent = self.send(obs)
        if isinstance(sent, Fault):
            return sent
        if self.unsent:  # the rest of the observation, within the step's deadline
            unsent = self.channel.write(self.unsent, self.sent + self.limits.step_deadline - time.monotonic())
            self.unsent = memoryview(b"")
            if unsent:
                return self._unread(obs, unsent)
        reply = self.channel.receive(self.sent + self.limits.step_deadline - time.monotonic())
        return self.judge(obs, reply, time.monotonic() - self.sent)

    def send(self, obs: Observation) -> Fault | ProcessBot:
        """The first half of a step: wait out a skipped tick's late answer, start its clock
        (`sent`) and write `obs`, as much of it as its input takes at once (the rest is
        `unsent`, for `write_more`): a controller that leaves its input full waits for its own
        observation, on its own clock, and no other controller waits for it. A Fault if the
        controller is gone, else itself, to be waited on (`Awaited`)."""
        if self.allowance.pending is not None:
            fault = self._drain(obs)
            if fault:
                return fault
        self.unsent = memoryview(b"")  # (a view into the frame's buffer, which is written anew)
        self.sent = time.monotonic()
        try:
            data = protocol.step_frame(obs, self.frame)
        except BufferError:  # a view of an earlier frame is still alive somewhere: that one is left to it
            self.frame = bytearray()
            data = protocol.step_frame(obs, self.frame)
        self.deadline = self.sent + self.limits.step_deadline
        rest = self.channel.write_now(data)
        if isinstance(rest, Trouble):
            self.unsent = memoryview(b"")
            return self._fault(obs.tick, obs.time, rest, "step")
        self.unsent = rest
        return self

    # ---- Awaited: what `exchange` waits on ----

    def reader(self) -> int:
        return self.channel.fileno()

    def writer(self) -> int | None:
        return self.channel.stdin.fileno() if self.unsent else None

    def write_more(self) -> Trouble | None:
        rest = self.channel.write_now(self.unsent)
        if isinstance(rest, Trouble):
            return rest
        self.unsent = rest
        return None

    def read_more(self, since: float) -> bool:
        return self.channel.read(max(since, self.sent))

    def answered(self) -> bool:
        return self.channel.whole()

    def decoded(self) -> Reply:
        arrived = self.channel.arrived
        began = time.monotonic()
        got = self.channel.message()
        assert got is not None and arrived is not None
        return got, max(0.0, arrived - self.sent) + time.monotonic() - began

    def refuse(self, problem: str) -> None:
        self.channel.problem = problem

    def _unread(self, obs: Observation, trouble: Trouble) -> Fault:
        """The fault of an observation its input did not take by the step's deadline."""
        if trouble is Trouble.TIMEOUT:  # its input still full of observations: it answers without reading them
            self.channel.problem = "it does not read its observations"
            trouble = Trouble.PROTOCOL
        return self._fault(obs.tick, obs.time, trouble, "step")

    def _drain(self, obs: Observation) -> Fault | None:
        """Wait for the late answer to a skipped tick, charging the wait to the allowance."""
        start = time.monotonic()
        reply = self.channel.receive(self.allowance.late_wait())
        self.allowance.waited(time.monotonic() - start)
        if reply is Trouble.TIMEOUT:
            return self._fault(obs.tick, obs.time, Trouble.TIMEOUT, "step")
        if isinstance(reply, CommandMsg) and reply.tick == self.allowance.pending:
            self.allowance.pending = None  # too late: dropped, the tick was skipped
            return None
        return self._fault(obs.tick, obs.time, _trouble(reply), "step")

    def judge(self, obs: Observation, reply: protocol.Message | Trouble, took: float) -> Command | Fault:
        """The second half of a step: the answer `reply` (or trouble), `took` seconds after
        `send`, weighed against the allowance."""
        if self._flooded():  # all it wrote before this answer (or deadline) is counted by now
            return self._fault(obs.tick, obs.time, Trouble.FLOOD, "step")
        if reply is Trouble.TIMEOUT:
            if not self.allowance.skipped(obs.tick, took):
                return self._fault(obs.tick, obs.time, Trouble.TIMEOUT, "step")
            message = (
                f"no answer within step_deadline ({self.limits.step_deadline:g} s): tick skipped, the robot kept "
                f"its last command; keep step() within step_time ({self.limits.step_time:g} s)"
            )
            return fault(obs.tick, obs.time, FaultKind.SKIPPED_TICK, message)
        if not self.allowance.answered(took):
            return self._fault(obs.tick, obs.time, Trouble.TIMEOUT, "step")
        match reply:
            case CommandMsg(tick=tick, command=cmd) if tick == obs.tick:
                return self._command(obs, cmd)
            case CommandMsg(tick=tick):  # answered twice, or ahead
                self.channel.problem = f"an answer for tick {tick} when tick {obs.tick} was asked"
        return self._fault(obs.tick, obs.time, _trouble(reply), "step")

    def _command(self, obs: Observation, cmd: Command) -> Command | Fault:
        """The command of an answer in time (decoded within the schema's bounds), checked: a bad
        one ends the controller."""
        problem = protocol.command_problem(protocol.sendable(cmd))
        if problem:
            self.close()
            return fault(obs.tick, obs.time, FaultKind.BAD_COMMAND, problem)
        return cmd

    # ---- the fault rules ----------------------------------------------------------------------

    def _fault(self, tick: int, t: float, what: FaultMsg | Trouble, where: str) -> Fault:
        """The Fault of a failed exchange in `where` (setup or step); the process is ended."""
        if isinstance(what, FaultMsg):
            kind, message = self._reported(what, where)
        elif what is Trouble.FLOOD or what is Trouble.CRASH and self._flooded():
            kind = FaultKind.OUTPUT_FLOOD
            message = f"in {where}: wrote more than {self.limits.log_bytes} bytes of output"
        elif what is Trouble.CRASH:
            kind, message = self._crash(where)
        elif what is Trouble.TIMEOUT:
            kind, message = FaultKind.TIMEOUT, self.allowance.broken(where)
        elif what is Trouble.BAD_COMMAND:
            kind, message = FaultKind.BAD_COMMAND, self.channel.problem
        else:
            kind, message = FaultKind.PROTOCOL, f"in {where}: {self.channel.problem or 'malformed message'}"
        tail = self._traceback()
        self.close()
        return fault(tick, t, kind, message, traceback=tail)

    def _reported(self, msg: FaultMsg, where: str) -> tuple[FaultKind, str]:
        """The kind and message of a fault the controller reported of itself: a kind it may not
        report is a protocol fault; its sandbox's folders are left out of the message."""
        kind = FaultKind(msg.kind) if msg.kind in REPORTED else FaultKind.PROTOCOL
        message = msg.message[:500]
        if kind is FaultKind.LOAD:  # named as the team was given, not as the sandbox sees it
            message = message.replace(f"team {self._entry_seen()}", f"team {self.team.label}")
        return kind, protocol.one_line(self._own_paths(message)) or f"in {where}"

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
        folder = self.started.folder if self.started else None
        if folder is not None:
            text = text.replace(folder.name + os.sep, "")
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
        problem = getattr(self.proc, "problem", "")  # a forked slot that could not be made
        if problem:  # before the team's code ran: the sandbox's, said as it was
            return FaultKind.LOAD, f"team {self.team.label}: its sandbox could not be made: {problem}"
        if not self.loaded:
            return FaultKind.LOAD, f"team {self.team.label}: {how} while its code was loading"
        return FaultKind.CRASH, f"in {where}: {how}"

    def _ended(self) -> int | None:
        """The exit status of a controller whose output has ended (negative: killed by that
        signal; bwrap passes a signal on as 128 + its number), or None if it still runs
        ENDING_TIME later: it closed its channel and lives on (`close` then kills it)."""
        assert self.started is not None
        code = exit_status(self.started.proc, ENDING_TIME)
        if code is not None and self.started.in_sandbox and 128 < code < 128 + signal.NSIG:
            return -(code - 128)
        return code

    def _entry_seen(self) -> str:
        """The entry as the controller process was given it."""
        if not is_file_spec(self.team.entry):
            return self.team.entry
        folder = self.started.folder if self.started else None
        home = Path(folder.name) if folder else Path(kernel.TEAM_DIR)
        return f"{home}/{self.team.entry}"

    # ---- the end ------------------------------------------------------------------------------

    def ask_to_end(self) -> None:
        """Tell the controller the match is over, without waiting for it (`close` waits): a
        match that tells all its controllers first lets them end side by side."""
        if self.started is not None and not self.told_to_end and exit_status(self.started.proc, 0.0) is None:
            self.told_to_end = True
            self.channel.send(Stop(v=PROTOCOL_VERSION), 0.0)  # no wait: an input left full is no reason to stay

    def close(self) -> None:
        """End the process and everything it started: in a sandbox, its init is killed, which
        kills every process of its PID namespace; bwrap returns once they are all gone. Safe to
        call again (after a close an interrupt cut short too): a process reaped already is
        never signalled, since its pid may by then name another."""
        if self.started is not None and self.started.proc.returncode is None:
            self._end(self.started)
        if self._pipes is not None:
            self._pipes.close()
        started = self.started
        if started is not None and started.folder is not None:
            started.folder.cleanup()
            started.folder = None
        if self.team_log is not None:
            self.team_log.close()
            self.team_log = None
        if self.group is not None:
            self.group.close()
            self.group = None

    def _end(self, started: Launched) -> None:
        """End the process of `started` and reap it: asked first, then killed."""
        proc = started.proc
        if exit_status(proc, 0.0) is None:
            self.ask_to_end()
            exit_status(proc, STOP_TIME)
        if started.info is not None:
            init, started.info = kernel.init_pid(started.info), None
            if init is not None and exit_status(proc, 0.0) is None:
                try:
                    os.kill(init, signal.SIGKILL)
                except (ProcessLookupError, PermissionError):
                    pass
                exit_status(proc, 5.0)
        if isinstance(proc, forkserver.Forked):
            if proc.poll() is None:
                proc.kill()  # the template kills its init: the PID namespace goes with it
        elif proc.returncode is None:  # unreaped: its pid names its session alone
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # its whole session, children included
            except (ProcessLookupError, PermissionError):
                pass
        proc.wait()


def _trouble(reply: protocol.Message | Trouble) -> FaultMsg | Trouble:
    """What a reply that is not the one awaited says: a fault it reports, the channel's trouble,
    or, for any other message, a protocol fault."""
    return reply if isinstance(reply, (FaultMsg, Trouble)) else Trouble.PROTOCOL
