"""What a forked controller start costs before it does anything of its own: a fork and an exit
of a process holding what the controllers' template holds, bare and with a slot's namespaces.

Run: python benchmarks/fork_floor.py [--starts 30]   (prints JSON; benchmarks/sandbox.py uses it)
This process imports only the standard library and robots/_host/template.py, and prepares itself as
the template does (`template.prepare`: the preloaded imports, the seccomp filter, the frozen
heap), so what it forks is the template's size. Each fork's CPU counts both sides: the parent's
(copying the page tables) and the child's (the pages it writes, copied, and its exit). With the
slot's namespaces (root only, outside the template's sandbox): a new PID namespace for the child
as the template makes it (`fork_init`), and the child unshares the rest as a slot does
(`own_namespaces`), then exits. The kernel's own threads that free a network namespace later
are not counted. Medians of `--starts` forks of each kind, the kinds alternated, after one untimed.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
from typing import NoReturn

from robots._host import template


def fork(own_pids: int, namespaces: bool) -> tuple[float, int]:
    """CPU seconds of one fork and exit from this process, both sides, and the child's page
    faults; with `namespaces`, forked as the template forks a slot (`fork_init`), the child
    making its own namespaces as a slot does (`own_namespaces`)."""

    def child() -> NoReturn:
        code = 1
        try:
            if namespaces:
                template.own_namespaces()
            code = 0
        finally:
            os._exit(code)

    before = resource.getrusage(resource.RUSAGE_SELF)
    if namespaces:
        pid = template.fork_init(child, own_pids)
    else:
        pid = os.fork()
        if pid == 0:
            child()
    _, status, used = os.wait4(pid, 0)
    if status:
        raise SystemExit(f"the forked child could not make its namespaces (status {status})")
    after = resource.getrusage(resource.RUSAGE_SELF)
    parent = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return parent + used.ru_utime + used.ru_stime, used.ru_minflt


def forks(starts: int, kinds: tuple[bool, ...]) -> list[tuple[float, float]]:
    """Per kind (with the slot's namespaces or not), the median CPU ms of a fork and exit and
    the child's median page faults: the kinds alternated, so all see the same machine."""
    own_pids = os.open("/proc/self/ns/pid", os.O_RDONLY | os.O_CLOEXEC)
    runs: list[list[tuple[float, int]]] = [[] for _ in kinds]
    for k in range(starts + 1):
        for i, namespaces in enumerate(kinds):
            cpu, faults = fork(own_pids, namespaces)
            if k:  # the first of each kind is not counted
                runs[i].append((cpu, faults))
    os.close(own_pids)
    return [(statistics.median(c for c, _ in r) * 1e3, statistics.median(f for _, f in r)) for r in runs]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=30, help="forks of each kind (default 30)")
    args = ap.parse_args()
    template.prepare()
    figures = forks(args.starts, (False, True) if os.geteuid() == 0 else (False,))
    out = {"fork_ms": figures[0][0], "fork_faults": figures[0][1]}
    if len(figures) > 1:
        out["namespaces_ms"] = figures[1][0]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
