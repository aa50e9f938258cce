"""Solver speed: ToTal scalar (pure Python) and NumPy-vectorized, plus the other solvers.

Run: python benchmarks/solvers.py (`make bench` runs it and writes its figures to docs/performance.json)
Targets (docs/performance.md): scalar ToTal under 3 us per call; vectorized at least 10 million solves per
second (the published C implementation took 163 ns per call on an i7 920).
"""

from __future__ import annotations

import math
import random
import time

import numpy as np

from robots.toolkit import solvers as S

BEACONS = [(0.0, 0.0), (1.83, 0.0), (1.83, 1.22)]


def problems(n: int, seed: int = 1) -> list[list[float]]:
    rng = random.Random(seed)
    out = []
    for _ in range(n):
        x, y, h = rng.uniform(0.1, 1.7), rng.uniform(0.1, 1.1), rng.uniform(-3, 3)
        out.append([math.atan2(by - y, bx - x) - h for bx, by in BEACONS])
    return out


def per_call(fn, args: list, repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for a in args:
            fn(BEACONS, a)
        best = min(best, (time.perf_counter() - start) / len(args))
    return best


def measure() -> dict:
    """The figures, as a dict."""
    scalar_args = problems(20000)
    total_us = per_call(lambda b, a: S.total(b, a, heading=False), scalar_args) * 1e6
    total_h_us = per_call(S.total, scalar_args) * 1e6
    circles_us = per_call(S.circles, scalar_args) * 1e6
    batch = np.array(problems(200000, seed=2))
    beacons = np.array(BEACONS)
    S.total_batch(beacons, batch[:1000])  # warm up
    best = math.inf
    for _ in range(5):
        start = time.perf_counter()
        S.total_batch(beacons, batch)
        best = min(best, time.perf_counter() - start)
    rate = len(batch) / best
    return {
        "total_scalar_us": total_us,
        "total_heading_us": total_h_us,
        "circles_scalar_us": circles_us,
        "total_vectorized_per_s": rate,
    }


def main() -> None:
    m = measure()
    print("localization solvers (best of several runs)")
    print(
        f"  ToTal scalar        {m['total_scalar_us']:8.2f} us per call   (position, as the paper times it; target < 3 us)"
    )
    print(f"  ToTal + heading     {m['total_heading_us']:8.2f} us per call")
    print(f"  circles scalar      {m['circles_scalar_us']:8.2f} us per call")
    rate = m["total_vectorized_per_s"]
    print(f"  ToTal vectorized    {rate / 1e6:8.1f} M solves/s    (target >= 10 M/s; {1e9 / rate:.0f} ns each)")


if __name__ == "__main__":
    main()
