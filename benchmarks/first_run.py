"""The first run after an install: the quickstart's `laserarena run asabe` with an empty kernel
cache, as after a plain `pip install .`, beside the same command on the cache the first left
(every later run). The README and the command's own notice quote its figures (the `first-run`
row of docs/performance.json).

`python benchmarks/first_run.py` measures it alone and sets that row of the committed report
(and the figures the pages quote from it); `make bench` measures it with every other figure.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import quoted
from speed import cpu

COMMAND = [sys.executable, "-P", "-m", "referee", "run", "asabe", "--quiet"]


def timed(env: dict[str, str], cwd: str) -> tuple[float, float]:
    """Wall seconds and CPU seconds of the command, its own process's (the compiling is there)."""
    c0, w0 = cpu(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run(COMMAND, env=env, cwd=cwd, check=True, capture_output=True, timeout=900)
    return time.perf_counter() - w0, cpu(resource.RUSAGE_CHILDREN) - c0


def once() -> dict[str, float]:
    """One cold run and one warm one, on a kernel cache of their own (NUMBA_CACHE_DIR)."""
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as folder:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        cold_wall, cold_cpu = timed(env, folder)
        warm_wall, warm_cpu = timed(env, folder)
    return {"cold_wall_s": cold_wall, "cold_cpu_s": cold_cpu, "warm_wall_s": warm_wall, "warm_cpu_s": warm_cpu}


def measure(repeat: int = 3) -> dict[str, float]:
    """Each figure, the median over `repeat` pairs of runs."""
    runs = [once() for _ in range(repeat)]
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="pairs of runs (the median is kept)")
    args = ap.parse_args()
    figures = measure(args.repeat)
    print(
        f"laserarena run asabe: {figures['cold_wall_s']:.1f} s ({figures['cold_cpu_s']:.1f} s CPU) on an empty "
        f"kernel cache, {figures['warm_wall_s']:.1f} s ({figures['warm_cpu_s']:.1f} s CPU) after it"
    )
    report = quoted.load("p")
    report["first-run"] = figures
    quoted.REPORTS["p"].write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    for page in quoted.requote_pages("p", report):
        print(f"  set the figures of {page.relative_to(quoted.ROOT)}")


if __name__ == "__main__":
    main()
