"""Matches on the organizer's Dask cluster, seen from the organizer's process, which never
imports Dask: a courier process holds the client (`referee.contest.courier`, as `nobody` when
this process is root) and reports each match as typed plain data. Each is checked against its
job (`received`) and its worker audited (`audit`) before it is handed out. A match a worker
refused, a bad result or a failed audit ends the run in one line naming the worker (exit 2);
what was trusted is kept, and running the command again plays the rest.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from collections.abc import Generator, Hashable
from typing import TypeVar

from referee.contest import courier_box
from referee.contest.audit import Audit, AuditFailed
from referee.contest.cluster import Cluster
from referee.contest.courier_link import Failed, Order, Refused, Report, receive_report, send
from referee.contest.received import BadResult, checked
from referee.contest.runner import MatchJob, Played, play
from referee.errors import UserError
from referee.sandbox.privacy import drop_to
from referee.terminal import safe

K = TypeVar("K", bound=Hashable)
STOP_WAIT = 5.0  # seconds a courier told to stop (SIGTERM) may take before it is killed


def on_cluster(todo: list[tuple[K, MatchJob]], cluster: Cluster) -> Generator[tuple[K, Played]]:
    """Play every (key, job) on `cluster`, yielding (key, played) for each result that passed
    its checks and its worker's audit. Close the generator to stop: the courier ends."""
    if importlib.util.find_spec("distributed") is None:
        raise UserError("--scheduler needs Dask: pip install 'laserarena[dask]'")
    courier = _courier()
    audit: Audit[K] = Audit(cluster.audit, play)
    left = set(range(len(todo)))
    try:
        assert courier.stdin is not None and courier.stdout is not None
        send(courier.stdin, Order(cluster.address, cluster.keys, [job for _, job in todo]))
        courier.stdin.close()
        while left:
            report = _next(courier)
            if isinstance(report, Failed):
                raise UserError(safe(report.reason, 1000))
            if report.index not in left:
                raise UserError(f"--scheduler {safe(cluster.address, 200)}: match {report.index} reported again")
            left.discard(report.index)
            key, job = todo[report.index]
            worker = safe(report.worker or "(unknown)", 200)
            what = f"{safe(job.level, 60)} seed {job.seed}"
            if isinstance(report, Refused):
                raise UserError(f"worker {worker}: {what}: {safe(report.reason, 500)}")
            try:
                played = checked(report, job)
            except BadResult as e:
                raise AuditFailed(
                    f"worker {worker} sent a bad result for {what}: {safe(e, 300)}; its results of this run were "
                    "discarded; take it out of the cluster and run the command again (trusted results are kept)",
                    audit.kept(report.worker),
                ) from None
            yield from audit.take(report.worker, key, job, played)
        yield from audit.finish()
    finally:
        _stop(courier)


def _courier() -> subprocess.Popen[bytes]:
    """Start the courier: this interpreter, in a session of its own, from `/`, as `nobody`
    when this process is root (it can then read no organizer file; `courier_box` says how it
    reaches the installation)."""
    user = drop_to()
    env = dict(os.environ)
    argv = [sys.executable, "-P", "-m", "referee.contest.courier"]
    if user is not None:
        argv = courier_box.command(argv[1:], user.pw_uid, user.pw_gid)
        env["HOME"] = "/"
    return subprocess.Popen(
        argv,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        cwd="/",
        env=env,
        start_new_session=True,  # a Ctrl-C is the organizer's to handle; it stops the courier
    )


def _next(courier: subprocess.Popen[bytes]) -> Report:
    """The courier's next report; UserError (one line) when it ended or spoke nonsense."""
    assert courier.stdout is not None
    try:
        report = receive_report(courier.stdout)
    except ValueError as e:
        raise UserError(f"the Dask courier sent something that is not a report ({safe(e, 200)})") from None
    if report is None:
        code = courier.wait()
        raise UserError(f"the Dask courier ended (exit code {code}) before every match came back")
    return report


def _stop(courier: subprocess.Popen[bytes]) -> None:
    if courier.poll() is None:
        courier.terminate()
        try:
            courier.wait(STOP_WAIT)
        except subprocess.TimeoutExpired:
            courier.kill()
            courier.wait()
    for pipe in (courier.stdin, courier.stdout):
        if pipe is not None:
            pipe.close()
