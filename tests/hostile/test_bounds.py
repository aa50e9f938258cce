"""What a slot may cost the host, whatever it calls: its log is a pipe the referee caps, the
kernel's ring and namespaces are closed to it, everything it holds in memory (files of its
private /tmp and /dev/shm, memfds, pipes) counts against its `memory_mb`, and it sees the
standard library, `robots`, numpy and msgspec, nothing else that is installed. Root referee
(the slot's control group and uid are root's to make)."""

import dataclasses
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from hostile.hostile_kit import (
    FAST,
    HONEST,
    assert_contained,
    assert_ended_for_memory,
    hostile_match,
    short_race,
    team_file,
)
from referee.match.loop import Match
from referee.sandbox import cgroup, kernel
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve
from referee.sandbox.uids import slot_uid

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="control groups and slot uids are a root referee's")


def test_its_log_is_a_pipe_and_the_kernels_ring_is_closed(tmp_path):
    # an io_uring would submit fallocate (or any call) where the seccomp filter never looks
    result = hostile_match(
        tmp_path,
        """
import ctypes, errno, platform, stat
class Ringer(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        params = ctypes.create_string_buffer(120)
        ring = libc.syscall(425, 8, params)  # io_uring_setup, the same number on both arches
        ring_errno = ctypes.get_errno()
        pipe = stat.S_ISFIFO(os.fstat(2).st_mode)
        ok = ring == -1 and ring_errno == errno.ENOSYS and pipe
        raise RuntimeError(("contained: " if ok else "LEAK: ") + repr((ring, ring_errno, pipe)))
""",
    )
    assert_contained(result)


def test_no_namespace_and_no_mount_of_its_own(tmp_path):
    # a user namespace of its own would let it mount a tmpfs of its own choosing: memory no
    # limit of its slot saw; clone with a CLONE_NEW* flag is the same door
    result = hostile_match(
        tmp_path,
        """
import ctypes, errno, platform
CLONE_NEWUSER, CLONE_NEWNS, SIGCHLD = 0x10000000, 0x00020000, 17
class Unsharer(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        got = []
        for what, call in (
            ("unshare", lambda: libc.unshare(CLONE_NEWUSER | CLONE_NEWNS)),
            ("clone", lambda: libc.syscall({"x86_64": 56, "aarch64": 220}[platform.machine()], CLONE_NEWUSER | SIGCHLD, 0, 0, 0, 0)),
            ("mount", lambda: libc.mount(b"none", b"/tmp", b"tmpfs", 0, b"size=1g")),
        ):
            if call() != -1 or ctypes.get_errno() != errno.EPERM:
                got.append(what)
        if os.fork() == 0:  # a plain fork still works
            os._exit(0)
        os.wait()
        raise RuntimeError(("contained: " if not got else "LEAK: ") + repr(got))
""",
    )
    assert_contained(result)


@pytest.mark.parametrize("forked", [True, False])  # from the template, or a sandbox spawned for it
def test_memory_in_its_files_counts_against_its_limit(tmp_path, forked):
    # its private /tmp and /dev/shm, memfds and pipe buffers are memory no mapping holds: the
    # slot's control group counts them, and the kernel ends the slot that holds too much
    assert not isinstance(cgroup.available(), str), cgroup.available()
    assert_ended_for_memory(_on_path(tmp_path, FILLER, forked), 160)


FILLER = """
import fcntl, resource
class Filler(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        block, held = b"x" * (1 << 20), []
        for folder in ("/tmp", "/dev/shm"):
            with open(f"{folder}/fill", "wb") as f:
                try:
                    while True:
                        f.write(block)
                except OSError:
                    pass
        resource.setrlimit(resource.RLIMIT_NOFILE, (resource.getrlimit(resource.RLIMIT_NOFILE)[1],) * 2)
        for _ in range(4096):
            r, w = os.pipe()
            os.set_blocking(w, False)
            try:
                while os.write(w, block):
                    pass
            except BlockingIOError:
                pass
            held.append((r, w))
            fd = os.memfd_create("fill")
            os.write(fd, block)
            held.append(fd)
        raise RuntimeError(f"LEAK: still running with {len(held)} fills held")
"""


def _on_path(tmp_path, body: str, forked: bool, memory: int = 160 << 20) -> dict:
    """A short race, its slot 0 `body`, the slot forked from the template or spawned."""
    limits = dataclasses.replace(FAST, memory=memory)
    teams = [resolve(team_file(tmp_path, body))] + [resolve(HONEST)] * 3
    match = Match(short_race(), teams, seed=2, limits=limits)
    match.fleet.bots = [ProcessBot(team, limits, slot=i, forked=forked) for i, team in enumerate(match.teams)]
    return match.run().to_dict()


@pytest.mark.parametrize("forked", [True, False])
def test_no_ip_socket_on_either_path(tmp_path, forked):
    # TCP buffers over its own loopback are memory cgroup v1 counts apart from the slot's
    # (601 MiB held with memory_mb 256, seen): a sandbox makes no socket but AF_UNIX
    result = _on_path(
        tmp_path,
        """
import errno, socket
class Caller(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        made = []
        for family, kind in ((socket.AF_INET, socket.SOCK_STREAM), (socket.AF_INET6, socket.SOCK_DGRAM),
                             (socket.AF_NETLINK, socket.SOCK_RAW), (socket.AF_PACKET, socket.SOCK_RAW)):
            try:
                socket.socket(family, kind).close()
                made.append(family)
            except OSError as e:
                if e.errno != errno.EAFNOSUPPORT:
                    made.append((family, e.errno))
        socket.socketpair()  # AF_UNIX: the one family left
        raise RuntimeError(("contained: " if not made else "LEAK: ") + repr(made))
""",
        forked,
    )
    assert_contained(result)


@pytest.mark.parametrize("forked", [True, False])
def test_socket_buffers_count_against_its_limit(tmp_path, forked):
    # AF_UNIX socket pairs filled to their send buffers: memory no mapping holds, counted by
    # the slot's group; the kernel ends the slot that holds too much
    result = _on_path(
        tmp_path,
        """
import resource, socket
class Filler(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        resource.setrlimit(resource.RLIMIT_NOFILE, (resource.getrlimit(resource.RLIMIT_NOFILE)[1],) * 2)
        block, held, total = b"x" * 65536, [], 0
        for _ in range(8192):
            a, b = socket.socketpair()
            a.setblocking(False)
            try:
                while True:
                    total += a.send(block)
            except BlockingIOError:
                pass
            held.append((a, b))
        raise RuntimeError(f"LEAK: still running with {total >> 20} MiB in {len(held)} socket pairs")
""",
        forked,
    )
    assert_ended_for_memory(result, 160)


def test_installed_packages_are_out_of_sight(tmp_path):
    # another installed team, the referee, the level files, any package of the host's: not on
    # its path, not in its folders; only what docs/controllers.md lists may be imported
    site = sysconfig.get_paths()["purelib"]
    result = hostile_match(
        tmp_path,
        f"""
import importlib
class Looker(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        seen = []
        for name in ("referee", "arena", "levels", "pymunk", "pygame", "yaml", "hostile_kit"):
            try:
                importlib.import_module(name)
                seen.append(name)
            except ImportError:
                pass
        import numpy, msgspec, robots.toolkit
        listing = sorted(os.listdir({site!r})) if os.path.isdir({site!r}) else []
        lib = sorted(os.listdir("/laserarena"))
        ok = not seen and not listing and lib == ["msgspec", "numpy", "numpy.libs", "robots"]
        raise RuntimeError(("contained: " if ok else "LEAK: ") + repr((seen, listing[:5], lib)))
""",
    )
    assert_contained(result)


def test_a_spawned_sandbox_sees_no_installed_package_either():
    # where the template cannot serve, a root referee spawns a bwrap sandbox per controller:
    # the same view, and no team folder on the path before the runner puts it there
    probe = (
        "import importlib.util, sys; "
        "print(sorted(n for n in ('pymunk', 'yaml', 'referee', 'numpy', 'msgspec', 'robots') if importlib.util.find_spec(n)), "
        "'/team' in sys.path)"
    )
    launch = kernel.launch([kernel.python(), "-s", "-c", probe], (), kernel.SANDBOX_ENV, slot_uid(7))
    try:
        done = subprocess.run(launch.argv, pass_fds=launch.pass_fds, capture_output=True, text=True, timeout=60)
    finally:
        for fd in (*launch.pass_fds, launch.info):
            os.close(fd)
    assert done.stdout.split("]") == ["['msgspec', 'numpy', 'robots'", " False\n"], done.stderr


def test_the_runner_sets_its_limits_before_the_team_can_replace_anything(tmp_path):
    # a team folder holding `resource.py`, `sitecustomize.py`, `usercustomize.py` and a
    # `robots` package: none of them is what the runner imports, and the limits hold
    team = tmp_path / "team"
    (team / "robots").mkdir(parents=True)
    for name in ("resource.py", "sitecustomize.py", "usercustomize.py", "robots/__init__.py"):
        (team / name).write_text("import sys; print('SHADOW', __name__, file=sys.stderr); raise SystemExit(9)\n")
    (team / "ctl.py").write_text(
        "import resource, sys, robots\n"
        "from robots.api import Controller, Command\n"
        "print('AS', resource.getrlimit(resource.RLIMIT_AS)[0], robots.__file__, file=sys.stderr)\n"
        "class C(Controller):\n    def step(self, obs):\n        return Command(0, 0)\n"
    )
    done = subprocess.run(
        [sys.executable, "-s", "-m", "robots._host.runner", str(team / "ctl.py"), "--path", str(team)]
        + ["--memory", str(1 << 30)],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        timeout=60,
        env={**os.environ, "PYTHONSAFEPATH": "1"},
    )
    log = done.stderr.decode()
    assert "SHADOW" not in log and done.returncode == 0, log
    limit, robots_file = log.split("AS ")[1].split()[:2]
    assert int(limit) == 1 << 30
    assert Path(robots_file).parent.parent != team
