"""The controller template: `python -m robots._host.template`, a fork server for controller processes.

Started by a root referee inside a bubblewrap sandbox that holds only the shared read-only
system view (no team's code, no /team content, its own PID namespace, no network). It imports
what every controller start would import (`robots._host.runner`, msgspec) and preloads numpy and the
reference controllers, then forks one controller per request. A request is one datagram on
the control socket (its descriptor number is the one argument) carrying two sockets of the
slot's own: the one the referee watches the slot by and the one its configuration comes on.
The template never reads anything of a team: the forked child reads its configuration itself.

How it works, in detail: docs/internals.md, `robots/_host/template.py`.
"""

from __future__ import annotations

import ctypes
import gc
import importlib.abc
import importlib.machinery
import json
import os
import resource  # noqa: F401 (the runner sets its limits with it: imported once here, not in each controller)
import select
import signal
import socket
import sys
from collections.abc import Callable
from types import ModuleType
from typing import Any, NoReturn

import robots._host.runner
from robots._host import forking, protocol, seccomp
from robots.controllers import REFERENCE

REFERENCE_MODULES = sorted({spec.split(":")[0].rsplit(".", 1)[1] for spec in REFERENCE.values()})

TEAM_DIR, TMP_SIZE = "/team", 64 << 20  # as referee/sandbox/kernel.py makes them for a spawned sandbox
# imported once here, registered in a controller on its first import of one of them: numpy (not
# numpy.random, whose Cython types a fresh controller would not hold) and the reference controllers
PRELOAD = ("numpy", "numpy.linalg", *(f"robots.controllers.{m}" for m in REFERENCE_MODULES))

CLONE_NEWNS, CLONE_NEWCGROUP, CLONE_NEWUTS = 0x00020000, 0x02000000, 0x04000000
CLONE_NEWIPC, CLONE_NEWPID, CLONE_NEWNET = 0x08000000, 0x20000000, 0x40000000
# each slot's own namespaces (and its cgroup namespace, where the kernel has them)
SLOT_NAMESPACES = CLONE_NEWNS | CLONE_NEWNET | CLONE_NEWIPC | CLONE_NEWUTS
MS_RDONLY, MS_NOSUID, MS_NODEV, MS_NOEXEC = 1, 2, 4, 8
MS_REMOUNT, MS_BIND, MS_REC, MS_PRIVATE = 32, 4096, 16384, 1 << 18
MOUNT_FLAGS = {"nosuid": MS_NOSUID, "nodev": MS_NODEV, "noexec": MS_NOEXEC, "noatime": 1024, "nodiratime": 2048}
PR_SET_PDEATHSIG, PR_SET_DUMPABLE, PR_CAPBSET_DROP = 1, 4, 24
PR_SET_NO_NEW_PRIVS, PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL = 38, 47, 4
CAP_VERSION_3 = 0x20080522
PROC_READ_ONLY = ("sys", "sysrq-trigger", "irq", "bus")  # as bwrap leaves them in a new /proc
PTYS = 16  # pseudo-terminals a slot may hold at once: the kernel's pool for every devpts but the host's is shared

_libc = ctypes.CDLL(None, use_errno=True)
_libc.prctl.argtypes = (ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong)
with open("/proc/sys/kernel/cap_last_cap") as _last:
    LAST_CAP = int(_last.read())  # the kernel's last capability: the bounding set is emptied up to it


def _check(result: int, what: str) -> None:
    if result != 0:
        code = ctypes.get_errno()
        raise OSError(code, f"{what}: {os.strerror(code)}")


def _mount(source: str | None, target: str, fstype: str | None, flags: int, data: str | None = None) -> None:
    _check(
        _libc.mount(
            source and source.encode(),
            target.encode(),
            fstype and fstype.encode(),
            ctypes.c_ulong(flags),
            data and data.encode(),
        ),
        f"mount {target}",
    )


def _prctl(option: int, arg: int, arg3: int = 0) -> None:
    if _libc.prctl(option, arg, arg3, 0, 0) != 0:
        _check(-1, f"prctl {option}")


def _tmpfs(target: str) -> None:
    """A private, sticky, world-writable tmpfs of TMP_SIZE bytes (memory) at `target`."""
    _mount("tmpfs", target, "tmpfs", MS_NOSUID | MS_NODEV, f"mode=1777,size={TMP_SIZE}")


def _read_only_everywhere(writable: tuple[str, ...]) -> None:
    """Remount read-only every mount of this namespace but `writable` (shared ones from the
    template included: whatever one slot could write there another could read), keeping
    each one's nosuid, nodev and noexec."""
    with open("/proc/self/mountinfo") as info:
        mounts = [(line.split()[4], line.split()[5].split(",")) for line in info]
    for point, options in mounts:
        if "ro" in options or point in writable or point == "/proc" or point.startswith("/proc/"):
            continue
        kept = sum(flag for name, flag in MOUNT_FLAGS.items() if name in options)
        try:
            _mount(None, point, None, MS_REMOUNT | MS_BIND | MS_RDONLY | kept)
        except FileNotFoundError:
            pass  # a mount point under another mount that covers it: out of reach anyway


def _team(bundle: int, files: list[tuple[str, int]]) -> None:
    """The team's files, read from one memfd, on a fresh tmpfs at TEAM_DIR made read-only."""
    _mount("tmpfs", TEAM_DIR, "tmpfs", MS_NOSUID | MS_NODEV, "mode=0755")
    offset = 0
    for rel, size in files:
        if rel.startswith("/") or ".." in rel.split("/"):
            raise ValueError(f"a team file outside {TEAM_DIR}: {rel}")
        target = f"{TEAM_DIR}/{rel}"
        os.makedirs(os.path.dirname(target), mode=0o755, exist_ok=True)
        out = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o444)
        try:
            done = 0
            while done < size:
                sent = os.sendfile(out, bundle, offset + done, size - done)
                if not sent:
                    raise ValueError(f"the team's files end before {rel}")
                done += sent
        finally:
            os.close(out)
        offset += size
    _mount(None, TEAM_DIR, None, MS_REMOUNT | MS_RDONLY | MS_NOSUID | MS_NODEV)


def _drop_privileges(uid: int) -> None:
    """Root -> the slot's uid and group, no supplementary groups, no capabilities (bounding,
    ambient and inheritable sets emptied), no-new-privs: what `setpriv` does before an exec."""
    for cap in range(LAST_CAP + 1):
        _prctl(PR_CAPBSET_DROP, cap)
    _prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL)
    os.setgroups([])
    os.setresgid(uid, uid, uid)
    os.setresuid(uid, uid, uid)
    header = (ctypes.c_uint32 * 2)(CAP_VERSION_3, 0)
    data = (ctypes.c_uint32 * 6)()  # effective, permitted, inheritable: all empty
    _check(_libc.capset(header, data), "capset")
    _prctl(PR_SET_NO_NEW_PRIVS, 1)
    _prctl(PR_SET_DUMPABLE, 1)  # as after an exec: its own processes may inspect each other


def _controller(config: dict[str, Any], stdio: list[int], groups: list[int]) -> NoReturn:
    """The slot's init, its namespaces and mounts made (`_slot`): its control groups, its
    /proc, its descriptors, its uid, then the runner. Never returns."""
    code = 1
    try:
        for fd in groups:  # joined while still root: all it and its children hold is counted there
            os.write(fd, b"0")
        os.setsid()
        _mount("proc", "/proc", "proc", MS_NOSUID | MS_NODEV | MS_NOEXEC)
        for name in PROC_READ_ONLY:
            path = f"/proc/{name}"
            if os.path.exists(path):
                _mount(path, path, None, MS_BIND | MS_REC)
                _mount(None, path, None, MS_REMOUNT | MS_BIND | MS_RDONLY | MS_NOSUID | MS_NODEV | MS_NOEXEC)
        for target, fd in enumerate(stdio):
            os.dup2(fd, target)
        os.closerange(3, 1 << 20)  # nothing of the template's or the referee's
        _drop_privileges(int(config["uid"]))
        seccomp.install()  # the filter prepared before the fork (`serve`)
        _prctl(PR_SET_PDEATHSIG, signal.SIGKILL)  # after the uid change, which clears it
        if config.get("probe"):  # the referee's check that a slot can be made here
            os._exit(0)
        os.chdir("/tmp")
        # /team is new; every other folder the template's finders cached is the same read-only one
        sys.path_importer_cache.pop(TEAM_DIR, None)
        sys.argv = [robots._host.runner.__file__, *config["argv"]]
        code = robots._host.runner.main(config["argv"])
    except BaseException:
        import traceback

        traceback.print_exc()
    finally:
        os._exit(code)


def _close_all_but(keep: set[int]) -> None:
    """Close every descriptor of this process but `keep`: nothing of the template's (its other
    slots' sockets and pidfds, its own PID namespace) is the slot's."""
    low = 0
    for fd in sorted(keep):
        os.closerange(low, fd)
        low = fd + 1
    os.closerange(low, 1 << 20)


def own_namespaces() -> None:
    """Leave the template's mount, network, IPC and UTS namespaces for new ones of this process's
    own, and its cgroup namespace where the kernel has them (bwrap's --unshare-cgroup-try)."""
    _check(_libc.unshare(SLOT_NAMESPACES), "unshare")
    _libc.unshare(CLONE_NEWCGROUP)


def _slot(watch: socket.socket, config: socket.socket) -> NoReturn:
    """The forked child for one slot, the init of its new PID namespace (still root, in the
    template's sandbox): its configuration, namespaces and mounts, then the controller. Never
    returns; what fails before the team's code runs is said on `watch` (`e` and the reason)."""
    try:
        _prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
        message, fds, _, _ = socket.recv_fds(config, 1 << 20, 8)
        config.close()
        settings = json.loads(message)
        _close_all_but({watch.fileno(), *fds})
        stdio, bundle, groups = fds[:3], fds[3], fds[4:]
        own_namespaces()
        _mount(None, "/", None, MS_REC | MS_PRIVATE)
        _tmpfs("/tmp")
        _tmpfs("/dev/shm")
        _mount("devpts", "/dev/pts", "devpts", MS_NOSUID | MS_NOEXEC, f"newinstance,ptmxmode=0666,mode=620,max={PTYS}")
        _team(bundle, [(rel, int(size)) for rel, size in settings["files"]])
        os.close(bundle)
        _read_only_everywhere(("/tmp", "/dev/shm", "/dev/pts"))
        if settings.get("cpus"):  # the referee's CPU, shared with it (referee/sandbox/affinity.py)
            os.sched_setaffinity(0, [int(c) for c in settings["cpus"]])
    except BaseException as e:
        try:
            watch.send(forking.FAILED + protocol.describe(e)[:400].encode())
        finally:
            os._exit(1)
    watch.close()
    _controller(settings, stdio, groups)


def fork_init(child: Callable[[], NoReturn], own_pids: int) -> int:
    """Fork a process that runs `child` (which never returns) as the init of a new PID
    namespace; this process's later children stay in its own (`own_pids`, restored at once).
    The child's pid."""
    _check(_libc.unshare(CLONE_NEWPID), "unshare")
    pid = -1
    try:
        pid = os.fork()
        if pid == 0:
            child()
    finally:
        if pid != 0 and _libc.setns(own_pids, CLONE_NEWPID) != 0:
            os._exit(1)  # its next slots would be born in this one's namespace: the template ends
    return pid


class _Watched:
    """A slot the template forked: its pid and pidfd, and the socket to the referee."""

    def __init__(self, pid: int, watch: socket.socket):
        self.pid, self.pidfd, self.watch = pid, os.pidfd_open(pid), watch
        self.listening = True  # the referee may still say `k` or close its end

    def heard(self) -> None:
        """The referee's word (`k`) or its end closed: kill the controller, its namespace with it."""
        try:
            word = self.watch.recv(16)
        except OSError:
            word = b""
        if word in (b"", forking.KILL):
            try:
                signal.pidfd_send_signal(self.pidfd, signal.SIGKILL)
            except ProcessLookupError:
                pass  # ended and reaped meanwhile: nothing left to kill
        if not word:
            self.listening = False

    def ended(self) -> None:
        """Reap the controller; send its status (bwrap's convention) and the CPU seconds it used."""
        _, status, usage = os.wait4(self.pid, 0)
        os.close(self.pidfd)
        code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else 128 + os.WTERMSIG(status)
        try:
            self.watch.send(forking.ENDED + forking.STATUS.pack(code, usage.ru_utime + usage.ru_stime))
        except OSError:
            pass  # the referee is gone
        self.watch.close()


class _Preloaded(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Modules the template imported for its children, kept out of `sys.modules` until the
    controller imports one: then they are all registered, as a fresh interpreter would have
    imported them (a controller that never imports numpy sees no numpy)."""

    def __init__(self, stash: dict[str, ModuleType]):
        self.stash = stash
        self.specs = {name: module.__spec__ for name, module in stash.items()}

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        if name not in self.stash:
            return None
        return importlib.machinery.ModuleSpec(name, self, is_package=hasattr(self.stash[name], "__path__"))

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return self.stash[spec.name]

    def exec_module(self, module: ModuleType) -> None:
        module.__spec__ = self.specs[module.__name__]
        for name, other in self.stash.items():
            sys.modules.setdefault(name, other)
        self.stash.clear()
        sys.meta_path.remove(self)


def _preload() -> None:
    """Import PRELOAD, then take what they added out of sys.modules behind a `_Preloaded`."""
    before = set(sys.modules)
    for name in PRELOAD:
        try:
            __import__(name)
        except ImportError:
            continue
    stash = {name: sys.modules.pop(name) for name in set(sys.modules) - before}
    if stash:
        sys.meta_path.insert(0, _Preloaded(stash))


def prepare() -> None:
    """What the template does once before it forks any slot: preload the imports, build the
    seccomp filter, freeze what it holds out of the collector's way (fewer pages copied in each
    child). benchmarks/fork_floor.py forks a process so prepared."""
    _preload()
    seccomp.prepare()  # the filter built once here, not in every controller
    gc.freeze()


def _started(fds: list[int], own_pids: int) -> _Watched | None:
    """The slot a request asks for, forked and watched: `fds` are its two sockets, the one the
    referee watches it by and the one its configuration comes on. None if none was made (the
    reason said on the first)."""
    sockets = [socket.socket(fileno=fd) for fd in fds]
    if len(sockets) != 2:
        for sock in sockets:
            sock.close()
        return None
    watch, config = sockets
    try:
        pid = fork_init(lambda: _slot(watch, config), own_pids)
    except OSError as e:
        try:
            watch.send(forking.FAILED + protocol.describe(e)[:400].encode())
        except OSError:
            pass  # the referee is gone
        watch.close()
        return None
    finally:
        config.close()
    return _Watched(pid, watch)


def serve(control_fd: int) -> None:
    """Fork a slot for each request on the control socket and watch it until it ends, until
    the referee closes the control socket (the slots still running then die with the template)."""
    control = socket.socket(fileno=control_fd)
    own_pids = os.open("/proc/self/ns/pid", os.O_RDONLY | os.O_CLOEXEC)
    prepare()
    control.send(forking.READY)
    by_pidfd: dict[int, _Watched] = {}
    while True:
        listening = {w.watch.fileno(): w for w in by_pidfd.values() if w.listening}
        ready = set(select.select([control.fileno(), *by_pidfd, *listening], [], [])[0])
        for fd in ready.intersection(listening):  # before any slot is reaped and its descriptors closed
            listening[fd].heard()
        for fd in ready.intersection(by_pidfd):
            by_pidfd.pop(fd).ended()
        if control.fileno() in ready:
            _, fds, _, _ = socket.recv_fds(control, 16, 2)
            if not fds:
                return  # the referee closed its end
            slot = _started(fds, own_pids)
            if slot is not None:
                by_pidfd[slot.pidfd] = slot


if __name__ == "__main__":
    serve(int(sys.argv[1]))
    # nothing to flush or close (its slots die with its PID namespace): the interpreter's teardown
    # would only keep the referee, who waits for the template's end, waiting longer
    os._exit(0)
