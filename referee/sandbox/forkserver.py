"""Controllers forked from a sandboxed template instead of spawned one by one (root referee).

A `ForkServer` runs `robots._host.template` as root inside a bubblewrap sandbox holding only the
shared read-only system view (referee/sandbox/kernel.py `template_launch`); with the
interpreter, msgspec, numpy and `robots` already imported there, a controller start is a fork
plus the slot's own namespaces, mounts and uid (robots/_host/template.py) instead of a new bwrap, a
new interpreter and its imports. One template per referee thread, reused by every match that
thread runs (its state never changes: it reads nothing of a team). Where it cannot be made or
fails its probe, `server()` says None and ProcessBot spawns a bwrap sandbox per controller.
docs/decisions/0020-controllers-forked-from-a-sandboxed-template.md says why.
"""

from __future__ import annotations

import atexit
import functools
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import IO

from referee.interrupts import steady
from referee.sandbox import cgroup, exits, kernel
from referee.sandbox.privacy import switches_users
from referee.sandbox.uids import slot_uid
from robots._host import forking

READY_TIME = 30.0  # seconds the template may take to import and answer (a loaded machine)


class Forked:
    """One controller forked by the template: its pipes and the socket the template watches it
    by, with the part of `subprocess.Popen`'s interface ProcessBot uses. `returncode` follows
    bwrap: the exit code, or 128 + the signal that killed it."""

    pid = None  # in a PID namespace the referee cannot name: ended through the template

    def __init__(self, watch: socket.socket, stdin: IO[bytes] | None, stdout: IO[bytes] | None):
        self.watch, self.stdin, self.stdout = watch, stdin, stdout
        self.returncode: int | None = None
        self.cpu = 0.0  # CPU seconds of the controller, once ended (for benchmarks)
        self.problem = ""  # what its slot could not do, if it failed before the controller ran

    def _take(self, message: bytes) -> None:
        if message[:1] == forking.ENDED and len(message) == 1 + forking.STATUS.size:
            self.returncode, self.cpu = forking.STATUS.unpack(message[1:])
        else:  # a slot that could not be made (its reason), or a template gone without a word: killed
            self.problem = message[1:].decode(errors="replace")
            self.returncode = 1 if message[:1] == forking.FAILED else 128 + signal.SIGKILL
        self.watch.close()

    def wait(self, timeout: float | None = None) -> int:
        """The exit status, waiting at most `timeout` seconds (subprocess.TimeoutExpired)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.returncode is None:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not select.select([self.watch], [], [], left)[0]:
                raise subprocess.TimeoutExpired("controller", timeout or 0.0)
            try:
                self._take(self.watch.recv(512))
            except OSError:
                self._take(b"")
        return self.returncode

    def poll(self) -> int | None:
        """The exit status if the controller has ended, else None."""
        try:
            return self.wait(0)
        except subprocess.TimeoutExpired:
            return None

    def kill(self) -> None:
        """Have the template kill the controller (its PID namespace goes with it)."""
        try:
            self.watch.send(forking.KILL)
        except OSError:
            pass  # the template is gone: so is the controller


class ForkServer:
    """The template process of this thread and the socket it takes requests on."""

    def __init__(self) -> None:
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        command = [kernel.python(), "-s", "-m", "robots._host.template", str(theirs.fileno())]
        launch = kernel.template_launch(command, kernel.SANDBOX_ENV)
        try:
            self.proc = subprocess.Popen(
                launch.argv,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
                close_fds=True,
                pass_fds=(*launch.pass_fds, theirs.fileno()),
            )
        finally:
            for fd in launch.pass_fds:
                os.close(fd)
            theirs.close()
        self.info = launch.info  # kept open: bwrap writes the template's pid there, and would fail on a closed pipe
        self.pid: int | None = None  # the template's host pid, once read from `info`
        self.control, self.lock, self.ready = ours, threading.Lock(), False
        self.probe = self._probe()

    def _probe(self) -> Forked | None:
        """Ask for a probe slot (one that runs no controller) now: the template forks it as soon as
        it has imported, so its check is done by the time the first match wants a slot. None if
        the template is gone already."""
        null = os.open(os.devnull, os.O_RDWR)
        try:
            return Forked(self.spawn({"probe": 1, "uid": slot_uid(0), "argv": []}, (), (null, null, null)), None, None)
        except OSError:
            return None
        finally:
            os.close(null)

    def booting(self) -> bool:
        """Whether it still imports or tries its probe slot (`wait_ready` would wait); False
        once it serves, or has failed."""
        if self.ready:
            return False
        if self.probe is not None and self.probe.poll() is None:
            return True
        return not select.select([self.control], [], [], 0)[0]

    def wait_ready(self) -> str | None:
        """Wait for the template's imports and its probe slot's end; why it cannot serve, or None."""
        if self.ready:
            return None
        if (
            not select.select([self.control], [], [], READY_TIME)[0]
            or self.control.recv(16) != forking.READY
            or not self.probe
        ):
            return "the controller template did not start"
        try:
            status = self.probe.wait(READY_TIME)
        except subprocess.TimeoutExpired:
            self.probe.kill()
            return "a slot forked from the controller template did not start"
        if status != 0:
            return f"a slot cannot be forked from the controller template: {self.probe.problem or status}"
        self.ready = True
        return None

    def spawn(
        self,
        config: dict,
        files: tuple[tuple[str, bytes], ...],
        stdio: tuple[int, int, int],
        groups: list[int] | tuple[int, ...] = (),
    ) -> socket.socket:
        """Fork a controller and return the socket the template watches it by (its status
        comes there; `k` has it killed): `config` (uid, runner argv), the team's `files`,
        `stdio` (the child's fds 0-2) and `groups` (the `cgroup.procs` of its control groups,
        which it joins) go on a socket of their own to the forked child, never to the template."""
        bundle = os.memfd_create("team", 0)
        sizes = []
        for rel, data in files:
            os.write(bundle, data)
            sizes.append((rel, len(data)))
        watch, its_watch = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        settings, its_settings = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            with self.lock:
                socket.send_fds(self.control, [forking.FORK], [its_watch.fileno(), its_settings.fileno()])
            message = json.dumps({**config, "files": sizes}).encode()
            socket.send_fds(settings, [message], [*stdio, bundle, *groups])
        except OSError:
            watch.close()
            raise
        finally:
            for sock in (its_watch, its_settings, settings):
                sock.close()
            os.close(bundle)
        return watch

    def cpu(self) -> float:
        """CPU seconds the template process has used so far (its forks are charged here): to
        the nanosecond from the scheduler's own count where the kernel keeps it, else in clock
        ticks (a start costs less than one)."""
        if self.pid is None:
            self.pid = kernel.init_pid(os.dup(self.info))
        try:
            return int(Path(f"/proc/{self.pid}/schedstat").read_text().split()[0]) / 1e9
        except FileNotFoundError:
            fields = Path(f"/proc/{self.pid}/stat").read_text().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def close(self) -> None:
        """End the template: its PID namespace, and every slot still in it, with it."""
        if self.probe:
            self.probe.watch.close()
        self.control.close()
        os.close(self.info)
        if not exits.ended(self.proc, 1.0):  # seen as it ends: a poll's steps took 3 ms of every run's exit
            self.proc.kill()
        self.proc.wait()


_local = threading.local()
_all: list[ForkServer] = []


@atexit.register
def _close_all() -> None:
    """The templates ended at exit; the referee leaves its control groups meanwhile (the
    kernel's wait for that move overlaps their exits)."""
    cgroup.leave_soon()
    for s in _all:
        s.close()


@functools.cache
def unavailable() -> str | None:
    """Why controllers cannot be forked from a template here (None: they can be tried). The
    template's probe slot tries the sandbox itself (`ForkServer.wait_ready`), so a spawned
    sandbox's trial (`kernel.unavailable`) runs only where the template fails."""
    if sys.platform != "linux" or not hasattr(os, "pidfd_open"):
        return "no pidfd on this system"
    if not switches_users():
        return "a template forks slots of their own uid: the referee must be root"
    return kernel.missing()


def start() -> None:
    """Start this thread's template without waiting for it (it imports while the match is made)."""
    if unavailable() is not None:
        return
    current = getattr(_local, "server", None)
    if current is None or _local.pid != os.getpid() or not current.alive():
        cgroup.available()  # the referee in its own group first: the template and its forks are its work
        with steady():  # started and recorded for `_close_all`, or a Ctrl-C would orphan it
            _local.server, _local.pid = ForkServer(), os.getpid()
            _all.append(_local.server)


def booting() -> bool:
    """Whether this thread's template, started, still boots (ForkServer.booting)."""
    current = getattr(_local, "server", None)
    return current is not None and _local.pid == os.getpid() and current.booting()


def server() -> ForkServer | None:
    """This thread's ready template, started if need be; None where none can serve."""
    if unavailable() is not None or getattr(_local, "failed", None) == os.getpid():
        return None
    start()
    problem = _local.server.wait_ready()
    if problem:
        _local.failed = os.getpid()
        return None
    return _local.server
