"""What ref:bac's own computing costs, and whether its accuracy holds.

Cost: in-process matches (`isolate=False`) of asabe and asabe-race with ref:bac in every slot and
with ref:dead-reckoning (whose own computing is next to nothing), interleaved; ref:bac's own CPU
per simulated second per robot is the difference of the process's CPU per simulated second,
divided by the robots, the median of `--repeat` pairs (CPU time, not wall time: other work on
the machine changes it little). Target: <= 1 ms.

Accuracy (`--accuracy`): asabe's position RMS, the mean over seeds 1..N of
result["robots"][0]["localization"]["position_rms"], and asabe-race's worst robot (< 60 mm).
Profile (`--profile`): a cProfile of one asabe-race match of ref:bac, its top functions.

    python benchmarks/bac_cost.py [--repeat 5] [--accuracy [--seeds 20]] [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import statistics
import time

import levels
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

LEVELS = ("asabe", "asabe-race")


def cpu_per_second(level_name: str, spec: str, seed: int) -> float:
    """This process's CPU (s) per simulated second of one in-process match, every slot `spec`."""
    level = load_level(levels.path(level_name))
    teams = [resolve(spec)] * len(level.robots)
    c0 = time.process_time()
    result = play_match(level, teams, seed=seed, isolate=False)
    return (time.process_time() - c0) / result.end_time


def cost(repeat: int) -> dict[str, float]:
    """ref:bac's own CPU (ms) per simulated second per robot, per level: medians of interleaved pairs."""
    out = {}
    for name in LEVELS:
        robots = len(load_level(levels.path(name)).robots)
        cpu_per_second(name, "ref:bac", 1)  # a first match loads what a process loads once
        diffs = []
        for k in range(repeat):
            bac = cpu_per_second(name, "ref:bac", k + 1)
            blind = cpu_per_second(name, "ref:dead-reckoning", k + 1)
            diffs.append(1000 * (bac - blind) / robots)
        out[name] = statistics.median(diffs)
        print(
            f"{name:12s} ref:bac own CPU {out[name]:.2f} ms per simulated s per robot  (pairs: "
            + ", ".join(f"{d:.2f}" for d in diffs)
            + ")",
            flush=True,
        )
    return out


def accuracy(seeds: int) -> None:
    """asabe's mean position RMS over seeds 1..`seeds`, and asabe-race's worst robot."""
    asabe = load_level(levels.path("asabe"))
    rms = []
    for seed in range(1, seeds + 1):
        r = play_match(asabe, [resolve("ref:bac")], seed=seed, isolate=False).to_dict()
        rms.append(r["robots"][0]["localization"]["position_rms"])
    print(
        f"asabe position RMS, mean of seeds 1-{seeds}: {1000 * statistics.mean(rms):.3f} mm "
        f"(median {1000 * statistics.median(rms):.3f}, worst {1000 * max(rms):.3f})",
        flush=True,
    )
    print("  by seed (mm): " + " ".join(f"{1000 * r:.2f}" for r in rms), flush=True)
    race = load_level(levels.path("asabe-race"))
    worst = []
    for seed in range(1, seeds + 1):
        r = play_match(race, [resolve("ref:bac")] * len(race.robots), seed=seed, isolate=False).to_dict()
        worst.append(max(robot["localization"]["position_rms"] for robot in r["robots"]))
    print(
        f"asabe-race worst robot's position RMS over seeds 1-{seeds}: {1000 * max(worst):.1f} mm "
        f"(median of the seeds' worst {1000 * statistics.median(worst):.1f}; target < 60)",
        flush=True,
    )


def profile(top: int) -> None:
    """The top functions of one asabe-race match of ref:bac, by their own time."""
    level = load_level(levels.path("asabe-race"))
    teams = [resolve("ref:bac")] * len(level.robots)
    play_match(level, teams, seed=1, isolate=False)
    prof = cProfile.Profile()
    prof.runcall(play_match, level, teams, seed=1, isolate=False)
    pstats.Stats(prof).sort_stats("tottime").print_stats(top)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved pairs of matches per level (default 5)")
    ap.add_argument("--accuracy", action="store_true", help="also the accuracy over seeds")
    ap.add_argument("--seeds", type=int, default=20, help="seeds of the accuracy figures (default 20)")
    ap.add_argument("--profile", action="store_true", help="a cProfile of one asabe-race match instead")
    ap.add_argument("--top", type=int, default=30)
    args = ap.parse_args()
    if args.profile:
        profile(args.top)
        return
    cost(args.repeat)
    if args.accuracy:
        accuracy(args.seeds)


if __name__ == "__main__":
    main()
