"""The courier: the one process that holds a contest's Dask client, so that nothing a worker
sends is unpickled in the organizer's process.

Dask's client loads pickles from its peers that no setting turns off: a task's exception when
the scheduler reports it erred (whether or not anyone asks for it), frames marked for
pickling whatever the client's deserializers. So the organizer's process never imports Dask:
it starts `python -P -m referee.contest.courier` (as `nobody` when it is root, so code that
runs here reaches neither the journal, the secret nor the keys' files), writes it one order
(`courier_link.Order`), and reads back typed msgpack reports, which it checks and audits
(`referee.contest.remote`). Here the client still takes only msgpack back from the workers
(`deserializers=["msgpack"]`) and names each match's worker from the scheduler's records.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from typing import Any

from referee.contest.courier_link import Failed, Order, Refused, Report, Returned, receive_order, send
from referee.contest.runner import die_with_parent, serve, worker_version
from referee.version import __version__

SCHEDULER_TIMEOUT = "10s"  # a scheduler that does not answer by then is a bad --scheduler
POLL = 2.0  # seconds between looks at the scheduler's records while no match comes back
NO_WORKERS = 120.0  # seconds a cluster may go without a worker before the run gives up on it


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split()) or type(e).__name__


def reports(order: Order) -> Iterator[Report]:
    """Play the order's jobs on its cluster, a report for each as it comes back; a `Failed`
    report (and nothing more) when the cluster cannot be used."""
    from dask.distributed import Client, wait
    from distributed.security import Security

    keys = order.keys
    security = (
        Security(require_encryption=True, tls_ca_file=keys.ca, tls_client_cert=keys.cert, tls_client_key=keys.key)
        if keys
        else None
    )
    try:
        client = Client(order.address, security=security, timeout=SCHEDULER_TIMEOUT, deserializers=["msgpack"])
    except (OSError, TimeoutError, ValueError) as e:
        yield Failed(f"--scheduler {order.address}: cannot reach the Dask scheduler ({_one_line(e)})")
        return
    with client:
        try:
            versions = client.run(worker_version)
        except (OSError, TimeoutError, TypeError, ValueError) as e:  # TypeError: a reply that was not msgpack
            yield Failed(f"--scheduler {order.address}: cannot ask the workers their version ({_one_line(e)})")
            return
        other = {addr: v for addr, v in versions.items() if v != __version__}
        if other:
            addr, v = sorted(other.items())[0]
            yield Failed(
                f"--scheduler {order.address}: worker {addr} runs laserarena {str(v)[:40]}, this client "
                f"{__version__}; install the same version on every worker"
            )
            return
        futures = {client.submit(serve, job, pure=False): i for i, job in enumerate(order.jobs)}
        alone = time.monotonic()  # since when the cluster has had no worker (or now)
        while futures:
            try:
                done = wait(list(futures), timeout=POLL, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                done = set()
            for future in done:
                yield _came_back(client, future, futures.pop(future))
            if done:
                continue
            # the scheduler's word on the rest: a task that erred ends here, though this client
            # never completes its future (it does not load the worker's exception)
            states = client.run_on_scheduler(task_states, [f.key for f in futures])
            for future in [f for f in futures if isinstance(states, dict) and states.get(f.key) == "erred"]:
                worker = client.run_on_scheduler(erred_on, future.key)
                yield Refused(futures.pop(future), str(worker), "the match's task failed on its worker")
                future.release()
            if client.scheduler_info().get("workers"):
                alone = time.monotonic()
            elif time.monotonic() - alone > NO_WORKERS:
                yield Failed(f"--scheduler {order.address}: no worker in the cluster for {NO_WORKERS:g} s")
                return


def _came_back(client: Any, future: Any, index: int) -> Report:
    """The report of a match whose future has completed."""
    if future.status != "finished":  # its exception stays unread: the client loaded it here, if at all
        worker = client.run_on_scheduler(erred_on, future.key)
        return Refused(index, worker if isinstance(worker, str) else "", "the match's task failed on its worker")
    worker = ",".join(sorted(client.who_has([future]).get(future.key, ())))  # the scheduler's word
    try:
        reply = future.result()
    except Exception as e:  # a reply in pickle: refused by the msgpack-only client
        return Refused(index, worker, f"its reply was not plain data ({_one_line(e)[:200]})")
    finally:
        future.release()
    return _report(index, worker, reply)


def task_states(keys: list[str], dask_scheduler: Any = None) -> dict[str, str]:
    """Run on the scheduler: the state of each task of `keys` it knows, by its records."""
    tasks = dask_scheduler.tasks if dask_scheduler is not None else {}
    return {key: tasks[key].state for key in keys if key in tasks}


def erred_on(key: str, dask_scheduler: Any = None) -> str:
    """Run on the scheduler: the workers a task erred on, by the scheduler's records."""
    task = dask_scheduler.tasks.get(key) if dask_scheduler is not None else None
    return ",".join(sorted(task.erred_on or ())) if task is not None else ""


def _report(index: int, worker: str, reply: object) -> Report:
    """A worker's plain reply as a report (Refused when it is not `serve`'s shape)."""
    if isinstance(reply, dict) and set(reply) == {"error"} and isinstance(reply["error"], str):
        return Refused(index, worker, reply["error"][:1000])
    if (
        isinstance(reply, dict)
        and set(reply) == {"result", "replay", "wall"}
        and isinstance(reply["result"], str)
        and isinstance(reply["replay"], bytes)
        and isinstance(reply["wall"], float)
    ):
        return Returned(index, worker, reply["result"], reply["replay"], reply["wall"])
    return Refused(index, worker, "its reply is not a match's result")


def main() -> int:
    """Read the order on stdin, write the reports on stdout; end with the organizer's process."""
    die_with_parent(os.getppid())
    out = sys.stdout.buffer
    try:
        order = receive_order(sys.stdin.buffer)
        for report in reports(order):
            send(out, report)
    except BrokenPipeError:  # the organizer stopped reading: it has gone, or stopped the contest
        return 0
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
