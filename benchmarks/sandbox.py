"""What starting a sandboxed controller costs: CPU and wall time from launch to `ready`
(interpreter, loading, setup) and its end, forked from the template (root referee) vs spawned
(a bwrap sandbox and a fresh interpreter of its own) vs no sandbox, median of several starts
alternated so all see the same machine load. Run: python benchmarks/sandbox.py [--starts N]

A forked start's CPU counts every process it involves: the referee (its slot's pipes, control
group, messages and close), the template (the fork, charged to it) and the controller (its
namespaces, mounts and privilege drop, the runner, the team's loading and setup, its exit).
The kernel's own threads that later free a slot's network namespace and control group are
not counted. Targets: a forked start under 5 ms of CPU, all processes; under 20 ms of sandbox
overhead per spawned start. Beside it, the floor under a forked start (benchmarks/fork_floor.py):
a bare fork and exit of a process the template's size, and the same with the slot's namespaces.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import levels
from levels.loader import load_level
from referee.match.views import brief_for
from referee.sandbox import forkserver, kernel
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve
from referee.sandbox.uids import slot_uid


def _cpu() -> float:
    """CPU seconds of this process and of its children it has waited for."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def start(team, level, sandboxed: bool, forked: bool = False) -> tuple[float, float, tuple[float, float, float]]:
    """(wall, CPU, (referee, template, controller) CPU) seconds from making a controller to
    its `ready` answer and its end. The CPU of a spawned or plain one is the referee's and its
    children's; of a forked one, the referee's, the template's (the fork) and the controller's."""
    server = forkserver.server() if forked else None
    template = server.cpu() if server else 0.0
    cpu, begin = _cpu(), time.perf_counter()
    bot = ProcessBot(team, level.limits, sandboxed=sandboxed, forked=forked)
    try:
        assert bot.setup(brief_for(level, 0)) is None
    finally:
        bot.close()
    wall, referee = time.perf_counter() - begin, _cpu() - cpu
    parts = (referee, 0.0, 0.0)
    if isinstance(bot.proc, forkserver.Forked):
        parts = (referee, server.cpu() - template if server else 0.0, bot.proc.cpu)
    elif forked:
        raise SystemExit("the controller was not forked: no template here")
    return wall, sum(parts), parts


def _bare(sandboxed: bool) -> float:
    """Seconds to run `true` in a sandbox like a controller's (or plainly): the setup cost alone."""
    command = ["true"]
    if sandboxed:
        launch = kernel.launch(command, (), {"PATH": "/usr/bin:/bin"}, slot_uid(0) if os.geteuid() == 0 else None)
        command = launch.argv
    begin = time.perf_counter()
    subprocess.run(command, pass_fds=launch.pass_fds if sandboxed else (), check=True)
    took = time.perf_counter() - begin
    if sandboxed:
        for fd in launch.pass_fds:
            os.close(fd)
        kernel.init_pid(launch.info, timeout=0)
    return took


def forked_start(starts: int = 15, spec: str = "ref:idle") -> dict:
    """A forked controller's start to its `ready` answer and its end, medians of `starts`: its
    wall ms and its CPU ms, all processes (referee, template, controller) and each apart; an
    empty dict where this machine has no template."""
    if kernel.unavailable() or forkserver.server() is None:
        return {}
    level, team = load_level(levels.path("asabe")), resolve(spec)
    start(team, level, True, True)  # warm the page cache
    runs = [start(team, level, True, True) for _ in range(starts)]
    parts = {name: statistics.median(p[i] for _, _, p in runs) * 1e3 for i, name in enumerate(SHARES)}
    return {
        "wall_ms": statistics.median(w for w, _, _ in runs) * 1e3,
        "cpu_ms": statistics.median(c for _, c, _ in runs) * 1e3,
        **{f"{name}_ms": v for name, v in parts.items()},
    }


SHARES = ("referee", "template", "controller")
FORK_FLOOR = Path(__file__).with_name("fork_floor.py")


def floor(starts: int = 30) -> dict:
    """benchmarks/fork_floor.py's figures, in a process of its own: the median CPU ms of a bare
    fork and exit of a process holding what the template holds (`fork_ms`, and the child's page
    faults, `fork_faults`) and, as root, of one that makes the slot's namespaces (`namespaces_ms`)."""
    out = subprocess.run([sys.executable, str(FORK_FLOOR), "--starts", str(starts)], capture_output=True, text=True)
    if out.returncode:
        said = out.stderr.strip().splitlines() or [f"exit status {out.returncode}"]
        raise SystemExit(f"{FORK_FLOOR.name}: {said[-1]}")
    return json.loads(out.stdout)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--starts", type=int, default=15, help="starts of each kind (default 15)")
    ap.add_argument("--team", default="ref:idle", help="the controller to start (default ref:idle)")
    args = ap.parse_args()
    reason = kernel.unavailable()
    if reason:
        raise SystemExit(f"no kernel sandbox here: {reason}")
    level = load_level(levels.path("asabe"))
    team = resolve(args.team)
    kinds = {"no sandbox": (False, False), "spawned sandbox": (True, False)}
    if forkserver.server() is not None:
        kinds["forked sandbox"] = (True, True)
    else:
        print(f"(no template: {forkserver.unavailable() or 'it failed its probe'})")
    for sandboxed, forked in kinds.values():
        start(team, level, sandboxed, forked)  # warm the page cache
    runs: dict[str, list[tuple[float, float, tuple[float, float, float]]]] = {k: [] for k in kinds}
    for _ in range(args.starts):
        for kind, (sandboxed, forked) in kinds.items():
            runs[kind].append(start(team, level, sandboxed, forked))
    bare = [_bare(True) - _bare(False) for _ in range(args.starts)]
    wall = {k: statistics.median(w for w, _, _ in v) for k, v in runs.items()}
    cpu = {k: statistics.median(c for _, c, _ in v) for k, v in runs.items()}
    print(f"controller start to ready and end, median of {args.starts} ({team.label})")
    for kind in kinds:
        print(f"  {kind:16s}  wall {wall[kind] * 1e3:7.1f} ms   CPU {cpu[kind] * 1e3:7.1f} ms")
    p, b = wall["no sandbox"], wall["spawned sandbox"]
    print(f"  spawn overhead    {(b - p) * 1e3:7.1f} ms wall per controller   (target < 20 ms)")
    print(f"  bwrap alone       {statistics.median(bare) * 1e3:7.1f} ms (sandboxed `true` minus plain `true`)")
    if "forked sandbox" in kinds:
        f = "forked sandbox"
        referee, template, controller = (statistics.median(p[i] for _, _, p in runs[f]) * 1e3 for i in range(3))
        print(
            f"  forked CPU        {cpu[f] * 1e3:7.2f} ms CPU per start, all processes   (target <= 5 ms; "
            f"medians: referee {referee:.2f}, template {template:.2f}, controller {controller:.2f})"
        )
        print(f"  spawned / forked  CPU {cpu['spawned sandbox'] / cpu[f]:6.1f} x   wall {b / wall[f]:6.1f} x")
        low = floor()
        print(
            f"  floor: fork+exit  {low['fork_ms']:7.2f} ms CPU of a process the template's size "
            f"({low['fork_faults']:.0f} page faults in the child)"
        )
        if "namespaces_ms" in low:
            print(f"  floor: namespaces {low['namespaces_ms']:7.2f} ms CPU: the same fork, with the slot's namespaces")


if __name__ == "__main__":
    main()
