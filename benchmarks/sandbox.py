"""What the kernel sandbox adds to starting a controller: the time from launch to `ready`
(interpreter start, loading, setup) with and without the sandbox, median of several starts
alternated so both see the same machine load. Run: python benchmarks/sandbox.py [--starts N]

Target: under 20 ms of sandbox overhead per controller start.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import time

import levels
from arena.loader import load_level
from referee.match.loop import brief_for
from referee.sandbox import kernel
from referee.sandbox.privacy import slot_uid
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve


def start(team, level, sandboxed: bool) -> float:
    """Seconds from launching a controller to its `ready` answer."""
    bot = ProcessBot(team, level.limits, sandboxed=sandboxed)
    begin = time.perf_counter()
    try:
        assert bot.setup(brief_for(level, 0)) is None
        return time.perf_counter() - begin
    finally:
        bot.close()


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
    start(team, level, True), start(team, level, False)  # warm the page cache
    plain, boxed = [], []
    for _ in range(args.starts):
        plain.append(start(team, level, False))
        boxed.append(start(team, level, True))
    bare = [_bare(True) - _bare(False) for _ in range(args.starts)]
    p, b = statistics.median(plain), statistics.median(boxed)
    print(f"controller start to ready, median of {args.starts} ({team.label})")
    print(f"  without sandbox   {p * 1e3:8.1f} ms")
    print(f"  with sandbox      {b * 1e3:8.1f} ms")
    print(f"  overhead          {(b - p) * 1e3:8.1f} ms per controller   (target < 20 ms)")
    print(f"  ratio             {b / p:8.2f} x")
    print(f"  bwrap alone       {statistics.median(bare) * 1e3:8.1f} ms (sandboxed `true` minus plain `true`)")


if __name__ == "__main__":
    main()
