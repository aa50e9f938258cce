"""One kernel sandbox per controller: bubblewrap (`bwrap`) namespaces around `robots._host.runner`.

Each slot gets its own PID namespace (its processes see and signal only each other, and all
die with the namespace's init), mount namespace (a read-only view of the system's /usr, of the
interpreter and the packages a controller may import as `stage` staged them under neutral
names, its own code at /team, a private /tmp and /dev/shm in memory), network namespace
(loopback only), IPC and UTS namespaces. As root the controller then runs as a uid of its
own (`referee.sandbox.uids.slot_uid`); as an ordinary user it runs in a user namespace of its own.
The team's files are handed in as in-memory copies (memfd), so nothing of the checkout needs
to be readable by the controller's user and nothing is written to the host's disk.
docs/security.md holds the threat model; docs/decisions/0013-bubblewrap-sandbox-per-slot.md
why bubblewrap.
"""

from __future__ import annotations

import functools
import os
import re
import select
import shutil
import site
import subprocess
import sys
import sysconfig
import time
from dataclasses import dataclass
from pathlib import Path

import robots._host.seccomp
from referee.sandbox.privacy import switches_users
from referee.sandbox.stage import ALLOWED, LIB_DIR, PYTHON_DIR, stage
from referee.sandbox.uids import slot_uid
from referee.threads import ONE_BLAS_THREAD
from robots._host import protocol

TEAM_DIR = "/team"  # the slot's code, read-only
TMP_SIZE = 64 << 20  # bytes of the private /tmp (and /dev/shm): memory, not disk
RUNNER_ENV = {  # every controller's interpreter, sandboxed or not: deterministic hashing, one BLAS thread
    "PYTHONHASHSEED": "0",
    "PYTHONDONTWRITEBYTECODE": "1",
    "PYTHONSAFEPATH": "1",
    **ONE_BLAS_THREAD,
}
SANDBOX_ENV = dict(  # the whole environment inside a sandbox; the runner adds TEAM_DIR once its limits are set
    RUNNER_ENV, PATH="/usr/bin:/bin", HOME="/tmp", LANG="C.UTF-8", PYTHONPATH=LIB_DIR
)
SITE_FOLDERS = ("site-packages", "dist-packages")  # where installed packages live
SYSTEM_FILES = ("/etc/ld.so.cache", "/etc/ld.so.conf", "/etc/ld.so.conf.d", "/etc/localtime")


@dataclass(frozen=True)
class Launch:
    """How to start one sandboxed controller: the command line and the descriptors it needs."""

    argv: list[str]
    pass_fds: tuple[int, ...]
    info: int  # read end of bwrap's --info-fd: the sandbox init's pid, to end the sandbox by


def init_pid(info: int, timeout: float = 1.0) -> int | None:
    """The host pid of a sandbox's init (its PID namespace dies with it), read from bwrap's info
    descriptor (which this closes); None if bwrap never got that far."""
    data, deadline = b"", time.monotonic() + timeout
    try:
        while b"}" not in data and time.monotonic() < deadline:
            if not select.select([info], [], [], max(0.0, deadline - time.monotonic()))[0]:
                break
            chunk = os.read(info, 4096)
            if not chunk:
                break
            data += chunk
    finally:
        os.close(info)
    found = re.search(rb'"child-pid"\s*:\s*(\d+)', data)
    return int(found.group(1)) if found else None


@functools.cache
def missing() -> str | None:
    """What a sandbox needs that this machine lacks, and what would give it (None: nothing),
    found without trying one: Linux, bwrap, setpriv (root), the installation's staged view."""
    if sys.platform != "linux":
        return f"no Linux namespaces on {sys.platform}"
    bwrap = shutil.which("bwrap")
    if bwrap is None:
        return "bubblewrap (bwrap) is not installed: apt-get install bubblewrap"
    if switches_users() and shutil.which("setpriv") is None:
        return "setpriv (util-linux) is not installed: apt-get install util-linux"
    try:
        stage()
    except OSError as e:
        return f"cannot stage the sandbox's view of the installation: {e.strerror or e}"
    return None


@functools.cache
def unavailable() -> str | None:
    """Why no sandbox can be made here and what would make one (None when it can): probed once
    per process by running `true` in one, so a kernel or container that forbids namespaces is
    found before a match."""
    if reason := missing():
        return reason
    trial = launch(["true"], (), {"PATH": "/usr/bin:/bin"}, slot_uid(0) if switches_users() else None)
    try:  # a whole controller sandbox, bind mounts and privilege drop included, running `true`
        probe = subprocess.run(trial.argv, pass_fds=trial.pass_fds, capture_output=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"bwrap does not start: {e}"
    finally:
        for fd in (*trial.pass_fds, trial.info):
            os.close(fd)
    if probe.returncode != 0:
        said = protocol.one_line(probe.stderr.decode(errors="replace"))[:160]
        return f"bwrap cannot make namespaces here ({said}): run as root, or allow unprivileged user namespaces"
    return None


def _namespaces(own_user_namespace: bool) -> list[str]:
    user = ["--unshare-user", "--disable-userns"] if own_user_namespace else []
    return [
        "bwrap",
        *user,
        "--unshare-pid",
        "--unshare-net",
        "--unshare-ipc",
        "--unshare-uts",
        "--unshare-cgroup-try",
        "--die-with-parent",
        "--new-session",
        "--as-pid-1",
    ]


def python() -> str:
    """The interpreter a sandbox runs, as its path reads there (`stage`)."""
    return stage().python


def _import_roots() -> list[str]:
    """Every folder where Python finds installed packages (site-packages and dist-packages, of
    this interpreter, its base and the system's Pythons): each one the system's /usr holds is
    covered by an empty folder in a sandbox, so no installed package but `ALLOWED` is readable
    or importable there."""
    stdlib = {os.path.realpath(sysconfig.get_paths()[key]) for key in ("stdlib", "platstdlib")}
    prefixes = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix, "/usr", "/usr/local"}
    roots = set(site.getsitepackages()) | {site.getusersitepackages()}
    roots |= {p for p in sys.path if Path(p).name in SITE_FOLDERS}
    roots |= {
        str(p) for prefix in prefixes for name in SITE_FOLDERS for p in Path(prefix).glob(f"lib*/python3*/{name}")
    }
    found = set()
    for root in roots:
        real = os.path.realpath(root)
        if os.path.isdir(real) and not any(Path(s).is_relative_to(real) for s in stdlib):
            found.add(real)
    return sorted(found)


def importable_in_sandbox(module: str) -> bool:
    """Whether a controller in a sandbox can import `module`: the standard library, `robots`
    and `ALLOWED` (a team's own modules aside)."""
    top = module.partition(".")[0]
    return top in sys.stdlib_module_names or top in ("robots", *ALLOWED)


def _parents(paths: list[str]) -> list[str]:
    """`--dir` for every folder above the mount points in `paths`: bwrap would create the missing
    ones closed to all but root (0700), and the controller's uid must pass through them. They
    are made 0711 (it can pass through, not list them), but for the import roots and the
    team's own folders, which imports list."""
    folders = sorted({str(p) for path in paths for p in Path(path).parents if str(p) != "/"})
    mine = tuple(f"{root}/" for root in (LIB_DIR, TEAM_DIR, PYTHON_DIR))
    return [
        arg
        for f in folders
        for arg in (
            "--perms",
            "0755" if f in (LIB_DIR, TEAM_DIR, PYTHON_DIR) or f.startswith(mine) else "0711",
            "--dir",
            f,
        )
    ]


def _system_view() -> list[str]:
    """The read-only part of the file system a Python controller needs: the system's /usr with
    every import folder in it but the standard library covered, and the staged installation
    (`stage`): the packages a controller may import at LIB_DIR, an interpreter from outside
    /usr at PYTHON_DIR. No folder of the host's installation is bound: none can be named."""
    args = ["--ro-bind", "/usr", "/usr"]
    for top in ("/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32"):
        if os.path.islink(top):
            args += ["--symlink", os.readlink(top), top]
        elif os.path.isdir(top):
            args += ["--ro-bind", top, top]
    for f in SYSTEM_FILES:
        args += ["--ro-bind-try", f, f]
    for folder in _import_roots():
        if Path(folder).is_relative_to("/usr"):  # visible: covered
            args += ["--perms", "0755", "--tmpfs", folder, "--remount-ro", folder]
    for host, inside in stage().binds:
        args += ["--ro-bind", host, inside]
    return _parents([args[i + 2] for i, a in enumerate(args) if a.startswith("--") and "bind" in a]) + args


def _team_files(files: tuple[tuple[str, bytes], ...]) -> tuple[list[str], list[int]]:
    """The team's files as read-only in-memory copies under TEAM_DIR: (arguments, descriptors)."""
    args, fds = _parents([f"{TEAM_DIR}/{rel}" for rel, _ in files]) + ["--dir", TEAM_DIR], []
    for rel, data in files:
        fd = os.memfd_create(f"team:{rel}", 0)
        os.write(fd, data)
        os.lseek(fd, 0, os.SEEK_SET)
        fds.append(fd)
        args += ["--perms", "0444", "--ro-bind-data", str(fd), f"{TEAM_DIR}/{rel}"]
    return args, fds


def _sandbox(
    files: tuple[tuple[str, bytes], ...], env: dict[str, str], own_user_namespace: bool, filtered: bool = False
) -> Launch:
    """bwrap's arguments up to `--`: the namespaces, the system view, `files` at TEAM_DIR, a
    private /proc, /dev, /tmp and /dev/shm, a read-only root and the environment `env`;
    `filtered`: under robots/_host/seccomp.py's filter."""
    team, fds = _team_files(files)
    info, info_w = os.pipe()
    fds.append(info_w)
    code = robots._host.seccomp.program() if filtered else None
    if code is not None:
        rules = os.memfd_create("seccomp", 0)
        os.write(rules, code)
        os.lseek(rules, 0, os.SEEK_SET)
        fds.append(rules)
        team += ["--seccomp", str(rules)]
    private = ["--proc", "/proc", "--dev", "/dev"]
    for folder in ("/tmp", "/dev/shm"):
        private += ["--perms", "1777", "--size", str(TMP_SIZE), "--tmpfs", folder]
    args = (
        _namespaces(own_user_namespace)
        + ["--info-fd", str(info_w)]
        + private
        + _system_view()
        + team
        + ["--remount-ro", "/", "--chdir", "/tmp", "--clearenv"]
    )
    for key, value in sorted({**env, **dict(stage().env)}.items()):
        args += ["--setenv", key, value]
    return Launch(args + ["--"], tuple(fds), info)


def launch(command: list[str], files: tuple[tuple[str, bytes], ...], env: dict[str, str], uid: int | None) -> Launch:
    """The bwrap command line running `command` in a new sandbox with `files` at TEAM_DIR.
    `uid`: the host uid to run as (a root referee that can switch users), else None (a user
    namespace of its own, as the caller's user).
    The caller must close `pass_fds` once the process has started, and `info` (`init_pid`)."""
    box = _sandbox(files, env, uid is None, filtered=True)
    args = box.argv
    if uid is not None:  # root: leave every privilege behind before the interpreter starts
        args += [
            "setpriv",
            f"--reuid={uid}",
            f"--regid={uid}",
            "--clear-groups",
            "--inh-caps=-all",
            "--bounding-set=-all",
            "--no-new-privs",
        ]
    return Launch(args + command, box.pass_fds, box.info)


def template_launch(command: list[str], env: dict[str, str]) -> Launch:
    """The bwrap command line running the controller template (robots/_host/template.py) as root in
    a sandbox like a controller's but empty at TEAM_DIR: the view every slot forked from it
    starts with (it makes its own namespaces, mounts and uid from there)."""
    box = _sandbox((), env, False)
    return Launch(box.argv + command, box.pass_fds, box.info)
