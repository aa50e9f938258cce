"""Starting a controller process, one of three ways: forked from a root referee's template
(`forkserver`, into namespaces of its own), spawned in a bwrap sandbox of its own (`kernel`),
or, where no sandbox can be made, a plain process in its own session, run as `nobody` when the
referee is root (with a one-line warning). Each is a fresh `robots._host.runner` that imports only
`robots` and the team's code, and speaks the protocol on its stdin and stdout.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import robots
from referee.errors import LaserArenaWarning
from referee.sandbox import forkserver, kernel
from referee.sandbox.kernel import RUNNER_ENV
from referee.sandbox.privacy import (
    check_readable_by_others,
    drop_to,
    is_root,
    share_team_files,
    switches_users,
)
from referee.sandbox.teams import Team
from referee.sandbox.uids import slot_uid
from robots._host.loading import is_file_spec

ROBOTS_HOME = str(Path(robots.__file__).resolve().parent.parent)
MAX_PROCS = 64  # processes and threads a slot may have at once (a controller needs one; no fork bomb)


@functools.cache
def _warn_unsandboxed(reason: str) -> None:
    """Say once per process, in one line, that controllers run without a kernel sandbox, why,
    and what would give them one (docs/security.md says what is then not enforced)."""
    warnings.warn(f"no kernel sandbox, controllers are not isolated: {reason}", LaserArenaWarning, stacklevel=1)


@dataclass
class Launched:
    """A controller process just started, and what was made for it that its end must undo."""

    proc: subprocess.Popen[bytes] | forkserver.Forked
    in_sandbox: bool = False  # a kernel sandbox: bwrap's exit status says a signal as 128 + its number
    info: int | None = None  # bwrap's info descriptor (kernel.init_pid), for a spawned sandbox
    folder: tempfile.TemporaryDirectory | None = None  # the team's files, without a sandbox


@dataclass(frozen=True)
class Plan:
    """How to start one slot's controller: `sandboxed=False` skips the kernel sandbox,
    `forked=False` spawns a sandbox of its own where a root referee's template could fork it
    (both for the benchmarks that measure what they cost); `cpus` the CPUs it may run on."""

    team: Team
    memory: int  # bytes of address space
    slot: int = 0
    sandboxed: bool = True
    forked: bool = True
    cpus: list[int] | None = None


def _joining(groups: list[int]) -> list[str]:
    """The runner's option to join the slot's control groups first (`groups`: descriptors of
    their `cgroup.procs`, opened here and inherited)."""
    return ["--join", ",".join(map(str, groups))] if groups else []


def launch(plan: Plan, stderr: int, groups: list[int]) -> Launched:
    """Start the controller of `plan`, its stderr `stderr`, joining the control groups `groups`."""
    server = forkserver.server() if plan.sandboxed and plan.forked and switches_users() else None
    if server is not None:  # forked from the template (whose probe slot has tried the sandbox)
        return _from_template(server, plan, stderr, groups)
    reason = kernel.unavailable() if plan.sandboxed else None
    if reason:
        root = "; controllers run as root: root cannot become nobody here" if is_root() and drop_to() is None else ""
        _warn_unsandboxed(reason + root)
    if plan.sandboxed and not reason:
        return _sandboxed(plan, stderr, groups)
    return _plain(plan, ["--memory", str(plan.memory)], stderr, groups)


def _runner_argv(plan: Plan, uid: int | None) -> list[str]:
    """The runner's arguments inside a sandbox: the team's entry under TEAM_DIR and its limits
    (with a uid of its own, the kernel can count this slot's processes alone)."""
    entry = plan.team.entry
    if is_file_spec(entry):
        entry = f"{kernel.TEAM_DIR}/{entry}"
    argv = [entry, "--memory", str(plan.memory), "--path", kernel.TEAM_DIR]
    return argv if uid is None else [*argv, "--max-procs", str(MAX_PROCS)]


def _from_template(server: forkserver.ForkServer, plan: Plan, stderr: int, groups: list[int]) -> Launched:
    """The controller forked by the template, into namespaces of its own."""
    uid = slot_uid(plan.slot)
    config = {"uid": uid, "argv": _runner_argv(plan, uid), **({"cpus": plan.cpus} if plan.cpus else {})}
    return Launched(_forked(server, plan.team, config, stderr, groups), in_sandbox=True)


def _sandboxed(plan: Plan, stderr: int, groups: list[int]) -> Launched:
    uid = slot_uid(plan.slot) if switches_users() else None
    launch = kernel.launch(
        [kernel.python(), "-s", "-m", "robots._host.runner", *_runner_argv(plan, uid)],
        plan.team.files,
        kernel.SANDBOX_ENV,
        uid,
    )
    try:
        proc = subprocess.Popen(
            [*launch.argv, *_joining(groups)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=stderr,
            env={"PATH": os.environ.get("PATH", "/usr/bin:/bin")},
            start_new_session=True,
            close_fds=True,
            pass_fds=(*launch.pass_fds, *groups),
        )
    except BaseException:
        os.close(launch.info)  # no sandbox to end
        raise
    finally:
        for fd in launch.pass_fds:
            os.close(fd)
    return Launched(proc, in_sandbox=True, info=launch.info)


def _forked(
    server: forkserver.ForkServer, team: Team, config: dict, stderr: int, groups: list[int]
) -> forkserver.Forked:
    """A controller forked by `server`, with pipes as Popen makes them (the child's ends handed over)."""
    stdin_r, stdin_w = os.pipe()
    stdout_r, stdout_w = os.pipe()
    try:
        watch = server.spawn(config, team.files, (stdin_r, stdout_w, stderr), groups)
    except BaseException:
        os.close(stdin_w)
        os.close(stdout_r)
        raise
    finally:
        os.close(stdin_r)
        os.close(stdout_w)
    return forkserver.Forked(watch, open(stdin_w, "wb"), open(stdout_r, "rb"))


def _plain(plan: Plan, limits: list[str], stderr: int, groups: list[int]) -> Launched:
    user, as_user = drop_to(), dict[str, Any]()
    folder = tempfile.TemporaryDirectory(prefix="laserarena-team-")
    share_team_files(plan.team.files, Path(folder.name))
    entry = plan.team.entry
    if is_file_spec(entry):
        entry = str(Path(folder.name) / entry)
    if user is not None:  # the referee is root: the controller runs as nobody
        check_readable_by_others(sys.executable, ROBOTS_HOME)
        os.chmod(folder.name, 0o755)
        as_user = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[])
    env = {k: v for k, v in os.environ.items() if k in ("PATH", "LANG", "LC_ALL", "TZ")}
    # the child imports the very `robots` package this referee uses, installed or not, and
    # finds a module team in the copy of its package (the runner adds it once its limits are set)
    path = os.pathsep.join([ROBOTS_HOME] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.update(RUNNER_ENV, PYTHONPATH=path)
    try:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-s",
                "-m",
                "robots._host.runner",
                entry,
                *limits,
                "--path",
                folder.name,
                *_joining(groups),
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=stderr,
            cwd=folder.name,
            env=env,
            start_new_session=True,
            close_fds=True,
            pass_fds=groups,
            **as_user,
        )
    except BaseException:
        folder.cleanup()
        raise
    return Launched(proc, folder=folder)
