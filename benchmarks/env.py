"""How fast the learning envs step beside bare pymunk stepping of the same world, side by side in one run.

Bare: the level's pymunk space stepped `Space.step` by `Space.step` through one control period,
its robots driving gentle circles (what a user's own pymunk loop costs). Beside it, the same
period in the simulator's compiled loop (`World.run`: physics alone) and with every laser and
detector (`Sensing`: what any env step costs before the referee's checks and the env's work).
Figures are medians of interleaved rounds; ratios are bare over the figure (1.0: a step costs
what bare pymunk does), the median of each round's own ratio.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium
import numpy as np

import referee.gym  # registers LaserArena-v0
from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.world import World
from levels.loader import find_level
from referee.gym import parallel

LEVEL, RACE = "asabe", "asabe-race"
WHEELS = (0.08, 0.12)  # m/s, every robot in every figure
Clock = Callable[[], float]


def bare(name: str, periods: int, clock: Clock, how: str = "pymunk") -> float:
    """Seconds (by `clock`) per control period of the level's world: "pymunk", its space stepped
    by pymunk's `Space.step`; "compiled", `World.run`; "sensed", `World.run` with every period's
    states recorded and flushed into detections, as a match does."""
    level = find_level(name)
    world = World(level)
    sensing = Sensing(world, RandomTree(level.seed)) if how == "sensed" else None
    for slot in range(len(level.robots)):
        world.command(slot, *WHEELS)
    space, dt, steps = world.space, world.dt, level.steps_per_control
    for _ in range(5):  # the wheels up to speed (pymunk then keeps them there); sensing's first
        states, _ = world.run(steps)  # period, which makes its plan and its blocks of draws once
        if sensing:
            sensing.record_many(states)
            sensing.flush()
    start = clock()
    for _ in range(periods):
        if how == "pymunk":
            for _ in range(steps):
                space.step(dt)
            continue
        states, _ = world.run(steps)
        if sensing:
            sensing.record_many(states)
            sensing.flush()
    return (clock() - start) / periods


def action(name: str) -> np.ndarray:
    """The env action that stands for WHEELS on this level's first robot."""
    top = find_level(name).robots[0].model.max_wheel_speed
    return np.array([w / top for w in WHEELS], dtype=np.float32)


def single(periods: int, goal: bool = False) -> float:
    """CPU seconds per step of the Gymnasium env (an episode that ends is reset, in the count)."""
    env = gymnasium.make(referee.gym.ENV_ID, level=LEVEL, goal=goal)
    a = action(LEVEL)
    env.reset(seed=1)
    start = time.process_time()
    for _ in range(periods):
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    used = time.process_time() - start
    env.close()
    return used / periods


def multi(periods: int) -> float:
    """CPU seconds per step (every agent acting) of the PettingZoo parallel env on asabe-race."""
    env = parallel.parallel_env(level=RACE)
    a = action(RACE)
    env.reset(seed=1)
    start = time.process_time()
    for _ in range(periods):
        env.step({agent: a for agent in env.agents})
        if not env.agents:
            env.reset()
    used = time.process_time() - start
    env.close()
    return used / periods


def process_cpu(pid: int) -> float:
    """CPU seconds process `pid` has used (Linux /proc; a clock tick's resolution)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def vector(mode: str, n: int, periods: int) -> tuple[float, float]:
    """Wall and CPU seconds (this process's and its workers') per env step of `make_vec` with
    `n` envs (episodes reset themselves)."""
    envs = gymnasium.make_vec(referee.gym.ENV_ID, num_envs=n, vectorization_mode=mode, level=LEVEL)
    actions = np.tile(action(LEVEL), (n, 1))
    envs.reset(seed=1)
    envs.step(actions)  # the workers' first step (their compiled kernels load) is not timed
    workers = [p.pid for p in getattr(envs, "processes", [])]

    def cpu() -> float:
        return time.process_time() + sum(map(process_cpu, workers))

    c0, w0 = cpu(), time.perf_counter()
    for _ in range(periods):
        envs.step(actions)
    wall, used = time.perf_counter() - w0, cpu() - c0
    envs.close()
    return wall / (periods * n), used / (periods * n)


def round_of(periods: int) -> dict[str, float]:
    """One round of every figure, each beside the bare stepping it is compared with."""
    cpu = time.process_time
    f = {"bare_us": 1e6 * bare(LEVEL, periods, cpu), "bare_race_us": 1e6 * bare(RACE, periods, cpu)}
    f["compiled_us"] = 1e6 * bare(LEVEL, periods, cpu, "compiled")
    f["sensed_us"] = 1e6 * bare(LEVEL, periods, cpu, "sensed")
    f["single_us"] = 1e6 * single(periods)
    f["goal_us"] = 1e6 * single(periods, goal=True)
    f["parallel_us"] = 1e6 * multi(periods)
    for n in (1, 2):
        f[f"sync{n}_us"] = 1e6 * vector("sync", n, periods)[1]
        f[f"native{n}_us"] = 1e6 * vector("vector_entry_point", n, periods)[1]
    f["bare_wall_us"] = 1e6 * bare(LEVEL, periods, time.perf_counter)
    for n in (1, 2):
        wall, used = vector("async", n, periods)
        f[f"async{n}_us"], f[f"async{n}_cpu_us"] = 1e6 * wall, 1e6 * used
    f["bare_wall_us"] = (f["bare_wall_us"] + 1e6 * bare(LEVEL, periods, time.perf_counter)) / 2  # before and after
    return f


def measure(repeat: int = 5, periods: int = 300) -> dict[str, float]:
    """Every figure, medians of `repeat` rounds: microseconds per step, steps per second and
    ratios to bare."""
    round_of(max(periods // 10, 5))  # untimed: loads the compiled kernels, fills the caches
    runs = [round_of(periods) for _ in range(repeat)]
    f = {k: statistics.median(r[k] for r in runs) for k in runs[0]}

    def paired(top: str, bottom: str) -> float:
        """The median over the rounds of each round's own ratio: a round's figures are timed
        within seconds of each other, so a machine whose speed swings between rounds moves both."""
        return statistics.median(r[top] / r[bottom] for r in runs)

    f["compiled_ratio"] = paired("bare_us", "compiled_us")
    f["sensed_ratio"] = paired("bare_us", "sensed_us")
    f["sensing_over_physics"] = statistics.median((r["sensed_us"] - r["compiled_us"]) / r["compiled_us"] for r in runs)
    f["single_ratio"] = paired("bare_us", "single_us")
    f["parallel_ratio"] = paired("bare_race_us", "parallel_us")
    for n in (1, 2):
        f[f"sync{n}_ratio"] = paired("bare_us", f"sync{n}_us")
        f[f"native{n}_ratio"] = paired("bare_us", f"native{n}_us")
        f[f"async{n}_ratio"] = paired("bare_wall_us", f"async{n}_us")
    for name in ("single", "goal", "parallel", "native1", "native2", "sync1", "sync2", "async1", "async2"):
        f[f"{name}_steps_per_s"] = 1e6 / f[f"{name}_us"]  # per CPU s; async: per wall s, all envs
    f["async_scaling"] = f["async1_us"] / f["async2_us"]
    return f


def table(f: dict[str, float]) -> list[tuple[str, str, str]]:
    """The figures as (what, value, against bare) rows."""
    rows = [
        (f"{LEVEL} bare pymunk stepping", f"{f['bare_us']:.0f} us CPU per control period", ""),
        (f"{RACE} bare pymunk stepping", f"{f['bare_race_us']:.0f} us CPU per control period", ""),
        (
            f"{LEVEL} compiled loop (physics alone)",
            f"{f['compiled_us']:.0f} us CPU per control period",
            f"{f['compiled_ratio']:.2f} of bare",
        ),
        (
            f"{LEVEL} compiled loop + sensing",
            f"{f['sensed_us']:.0f} us CPU per control period",
            f"{f['sensed_ratio']:.2f} of bare; sensing {f['sensing_over_physics']:.2f}x the physics",
        ),
        ("LaserArena-v0, one env", f"{f['single_us']:.0f} us CPU per step", f"{f['single_ratio']:.2f} of bare"),
        ("  with goal=True", f"{f['goal_us']:.0f} us CPU per step", f"{f['bare_us'] / f['goal_us']:.2f} of bare"),
        (
            f"PettingZoo parallel_env, {RACE}",
            f"{f['parallel_us']:.0f} us CPU per step",
            f"{f['parallel_ratio']:.2f} of bare ({RACE})",
        ),
    ]
    for n in (1, 2):
        cost = f"{f[f'native{n}_us']:.0f} us CPU per env step"
        rows.append((f"make_vec (in-process), {n} env", cost, f"{f[f'native{n}_ratio']:.2f} of bare"))
    for n in (1, 2):
        cost = f"{f[f'sync{n}_us']:.0f} us CPU per env step"
        rows.append((f"make_vec sync, {n} env", cost, f"{f[f'sync{n}_ratio']:.2f} of bare"))
    for n in (1, 2):
        rate = f"{f[f'async{n}_steps_per_s']:.0f} env steps per wall s"
        cost = f"{f[f'async{n}_ratio']:.2f} of bare (wall); {f[f'async{n}_cpu_us']:.0f} us CPU per env step"
        rows.append((f"make_vec async, {n} env", rate, cost))
    rows.append(("  async scaling, 2 envs over 1", f"{f['async_scaling']:.2f}x", "2.0 is linear on 2 cores"))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds (the median is kept)")
    ap.add_argument("--periods", type=int, default=300, help="control periods per figure and round")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON instead of a table")
    args = ap.parse_args()
    f = measure(args.repeat, args.periods)
    if args.json:
        print(json.dumps(f, indent=2, sort_keys=True))
        return
    rows = table(f)
    width = max(len(a) for a, _, _ in rows)
    print(f"medians of {args.repeat} rounds of {args.periods} control periods")
    for a, b, c in rows:
        print(f"  {a:<{width}}  {b:<36} {c}")


if __name__ == "__main__":
    main()
