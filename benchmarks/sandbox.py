"""What starting a sandboxed controller costs: CPU and wall time from launch to `ready`
(interpreter, loading, setup) and its end, forked from the template (root referee) vs spawned
(a bwrap sandbox and a fresh interpreter of its own) vs no sandbox, median of several starts
alternated so all see the same machine load. Run: python benchmarks/sandbox.py [--starts N]

Targets: a forked start under 5 ms of CPU; under 20 ms of sandbox overhead per spawned start.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import time

import levels
from arena.loader import load_level
from referee.match.views import brief_for
from referee.sandbox import forkserver, kernel
from referee.sandbox.privacy import slot_uid
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve


def _cpu() -> float:
    """CPU seconds of this process and of its children it has waited for."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def start(team, level, sandboxed: bool, forked: bool = False) -> tuple[float, float]:
    """(wall, CPU) seconds from launching a controller to its `ready` answer and its end; CPU
    counts the referee, the controller and, when forked, its monitor and the template's fork."""
    server = forkserver.server() if forked else None
    template = server.cpu() if server else 0.0
    bot = ProcessBot(team, level.limits, sandboxed=sandboxed, forked=forked)
    cpu, begin = _cpu(), time.perf_counter()
    try:
        assert bot.setup(brief_for(level, 0)) is None
    finally:
        bot.close()
    wall, cpu = time.perf_counter() - begin, _cpu() - cpu
    if isinstance(bot.proc, forkserver.Forked):
        cpu += bot.proc.cpu + (server.cpu() - template if server else 0.0)
    elif forked:
        raise SystemExit("the controller was not forked: no template here")
    return wall, cpu


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
    runs: dict[str, list[tuple[float, float]]] = {k: [] for k in kinds}
    for _ in range(args.starts):
        for kind, (sandboxed, forked) in kinds.items():
            runs[kind].append(start(team, level, sandboxed, forked))
    bare = [_bare(True) - _bare(False) for _ in range(args.starts)]
    wall = {k: statistics.median(w for w, _ in v) for k, v in runs.items()}
    cpu = {k: statistics.median(c for _, c in v) for k, v in runs.items()}
    print(f"controller start to ready and end, median of {args.starts} ({team.label})")
    for kind in kinds:
        print(f"  {kind:16s}  wall {wall[kind] * 1e3:7.1f} ms   CPU {cpu[kind] * 1e3:7.1f} ms")
    p, b = wall["no sandbox"], wall["spawned sandbox"]
    print(f"  spawn overhead    {(b - p) * 1e3:7.1f} ms wall per controller   (target < 20 ms)")
    print(f"  bwrap alone       {statistics.median(bare) * 1e3:7.1f} ms (sandboxed `true` minus plain `true`)")
    if "forked sandbox" in kinds:
        f = "forked sandbox"
        print(f"  forked CPU        {cpu[f] * 1e3:7.1f} ms per controller   (target < 5 ms)")
        print(f"  spawned / forked  CPU {cpu['spawned sandbox'] / cpu[f]:6.1f} x   wall {b / wall[f]:6.1f} x")


if __name__ == "__main__":
    main()
