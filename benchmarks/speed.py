"""How fast a four-robot match runs beside the physics' own cost, measured side by side in one run.

How it works, in detail: docs/internals.md, `benchmarks/speed.py`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import resource
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import sensing

import levels
from levels.loader import load_level
from referee.contest import grading as g
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from referee.version import __version__


def cpu(who: int) -> float:
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def machine_cpu() -> float:
    """CPU seconds every processor of the machine has spent busy since boot (Linux /proc/stat).
    Controllers forked from the sandbox's template are not this process's children, so only
    the machine's total counts them: measure on an otherwise idle machine."""
    fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    user, nice, system, _idle, _iowait, irq, softirq, steal = (int(v) for v in fields[:8])
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def cpu_model() -> str:
    """The processor's name, as the kernel gives it (Linux), else the platform's word."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or platform.machine()


def median_of(repeat: int, measure):
    """Each figure of `measure()`'s dict, the median over `repeat` runs."""
    runs = [measure() for _ in range(repeat)]
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def world(seconds: float, repeat: int) -> dict:
    """Bare stepping and stepping with sensing, simulated s per wall s, and sensing's overhead."""

    def once() -> dict:
        bare, _ = sensing.run(seconds, False)
        sensed, events = sensing.run(seconds, True)
        periods = sensing.run_periods(seconds)
        return {
            "bare_x": seconds / bare,
            "sensing_x": seconds / sensed,
            "sensing_overhead": sensed / bare - 1,
            "compiled_x": seconds / periods,
        }

    sensing.run(seconds / 6, False)  # a warm-up of each, untimed: a process's first run is slower by
    sensing.run(seconds / 6, True)  # a few percent (caches, allocations), which a single run would count
    sensing.run_periods(seconds / 6)  # (and loads the compiled loop)
    return median_of(repeat, once)


def bare_beside(seconds: float = 20.0) -> dict:
    """Bare stepping's wall and CPU seconds per simulated second, from a short run (a World.step
    at a time): taken right before and after each measured run, so that a ratio compares two
    figures of one moment, whatever the machine's speed does meanwhile (a shared virtual
    machine's can swing by half within a minute)."""
    c0, w0 = cpu(resource.RUSAGE_SELF), time.perf_counter()
    sensing.run(seconds, False)
    return {"wall": (time.perf_counter() - w0) / seconds, "cpu": (cpu(resource.RUSAGE_SELF) - c0) / seconds}


def around(measured):
    """`measured()`'s figures, and bare stepping's per simulated second (wall, CPU) measured
    just before and just after it, averaged."""
    before = bare_beside()
    figures = measured()
    after = bare_beside()
    return figures, {k: (before[k] + after[k]) / 2 for k in before}


def match(spec: str, isolate: bool, repeat: int) -> dict:
    """A full asabe-race match (replay written), simulated s per wall s, CPU per simulated s,
    and its speed as a share of bare stepping's measured around it (`around`)."""
    level = load_level(levels.path("asabe-race"))
    teams = [resolve(spec)] * len(level.robots)
    with tempfile.TemporaryDirectory() as d:  # a process's start, once for all its matches (given
        # apart below): the compiled kernels loaded, the sandbox's template booted, untimed
        play_match(dataclasses.replace(level, time_limit=2.0), teams, replay=Path(d) / "m.replay", isolate=isolate)

    def played() -> dict:
        with tempfile.TemporaryDirectory() as d:
            c0, m0, w0 = cpu(resource.RUSAGE_SELF), machine_cpu(), time.perf_counter()
            r = play_match(level, teams, replay=Path(d) / "m.replay", isolate=isolate)
            wall = time.perf_counter() - w0
            own, everything = cpu(resource.RUSAGE_SELF) - c0, machine_cpu() - m0
        return {
            "x": r.end_time / wall,
            "simulated_s": r.end_time,
            "referee_cpu_per_s": own / r.end_time,
            "others_cpu_per_s": max(0.0, everything - own) / r.end_time,
        }

    def once() -> dict:
        figures, bare = around(played)
        return {**figures, "ratio": bare["wall"] * figures["x"]}

    return median_of(repeat, once)


def grading(matches: int, spec: str = "ref:bac") -> dict:
    """CPU per simulated second of grading `spec` on asabe with one worker (all processes),
    beside bare 4-robot stepping's CPU per simulated second measured around it (`around`)."""
    path = levels.path("asabe")
    team = resolve(spec)

    def graded() -> dict:
        with tempfile.TemporaryDirectory() as d:
            journal = g.Journal(Path(d) / "bench.sqlite")
            jobs = g.make_jobs(
                [(load_level(path), path)], [(team.spec, team.code_hash)], matches, journal.secret(None), __version__
            )
            c0 = machine_cpu()
            g.grade_jobs(jobs, journal, workers=1, quiet=True)
            used = machine_cpu() - c0
            simulated = sum(result["end_time"] for _, result in journal.results(jobs))
        return {"matches": matches, "cpu_per_s": used / simulated, "simulated_s": simulated}

    figures, bare = around(graded)
    return {**figures, "bare_cpu_per_s": bare["cpu"], "ratio": figures["cpu_per_s"] / bare["cpu"]}


def process_cost(command: list[str], cwd: str | None = None) -> tuple[float, float]:
    """Wall seconds and machine CPU seconds of `command`, a process of its own, to its end. Run
    it in a folder of its own (`cwd`), as a user would: `python -m` and `-c` then import the
    installed package, its modules' bytecode compiled at install, not this checkout's sources."""
    c0, w0 = machine_cpu(), time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, timeout=600, cwd=cwd)
    return time.perf_counter() - w0, machine_cpu() - c0


def command_line_grading(seeds: int) -> tuple[float, float]:
    """Machine CPU (s) and simulated s of `laserarena grade asabe --team ref:bac --workers 1
    --seeds N`, a process of its own, as a grader starts it."""
    with tempfile.TemporaryDirectory() as d:
        journal = Path(d) / "grade.sqlite"
        command = [sys.executable, "-m", "referee", "grade", str(levels.path("asabe")), "--team", "ref:bac"]
        command += ["--seeds", str(seeds), "--workers", "1", "--db", str(journal), "--out", str(Path(d) / "board.csv")]
        _, used = process_cost(command, cwd=d)
        simulated = sum(
            row[0] for row in sqlite3.connect(journal).execute("SELECT json_extract(result, '$.end_time') FROM matches")
        )
    return used, simulated


BARE_PROCESS = """
import sys
sys.path.insert(0, {folder!r})
import sensing
sensing.run({seconds!r}, False)
"""


def command_line_run(spec: str = "ref:dead-reckoning") -> dict:
    """`laserarena run asabe-race` with 4 x `spec`, replay and result written, a process of its
    own; beside a process that steps the same world bare (`sensing.run`, after importing the
    arena and loading the level) for as many simulated seconds, timed just before and after it."""
    with tempfile.TemporaryDirectory() as d:
        result = Path(d) / "result.json"
        command = [sys.executable, "-m", "referee", "run", "asabe-race", *["--team", spec] * 4]
        command += ["--replay", str(Path(d) / "m.replay"), "--json", str(result), "--quiet"]
        process_cost(command, cwd=d)  # untimed: the first reads the files from disk
        simulated = json.loads(result.read_text())["end_time"]
        bare = [sys.executable, "-c", BARE_PROCESS.format(folder=str(Path(__file__).parent), seconds=simulated)]
        before = process_cost(bare, cwd=d)
        wall, used = process_cost(command, cwd=d)
        after = process_cost(bare, cwd=d)
    bare_wall, bare_cpu = (before[0] + after[0]) / 2, (before[1] + after[1]) / 2
    return {
        "simulated_s": simulated,
        "wall_s": wall,
        "cpu_s": used,
        "bare_wall_s": bare_wall,
        "ratio": bare_wall / wall,
        "cpu_ratio": used / bare_cpu,
    }


# where a run's fixed cost goes: processes that each do one more of what `laserarena run` does
# before and around its match, timed beside the command itself (the last stage); modules are
# imported as the command imports them, kept out of the collector's way (arena.heap)
_KEPT = "from arena.heap import lasting\nwith lasting():\n    import {}\n"
FIXED_STAGES = (
    ("interpreter", "pass"),
    ("numpy", _KEPT.format("numpy")),
    ("modules", _KEPT.format("numpy, referee.cli.commands, referee.match.loop")),
    (
        "in_process",  # the same match in this process: the kernels' loading (no numba), the match, its replay
        _KEPT.format("sys, levels.loader, referee.match.loop, referee.sandbox.teams, referee.cli.commands")
        + "from pathlib import Path\n"
        + "level, teams = levels.loader.load_level(Path(sys.argv[1])), [referee.sandbox.teams.resolve(sys.argv[2])] * 4\n"
        + "referee.match.loop.play_match(level, teams, isolate=False, replay=Path(sys.argv[3]))",
    ),
)


def command_line_fixed(spec: str = "ref:dead-reckoning") -> dict:
    """A run's fixed cost: `laserarena run` of a 1-second `asabe-race` with 4 x `spec`, replay
    and result written, a process of its own (wall seconds, whole command); and where it goes,
    the wall seconds each stage of `FIXED_STAGES` adds to the one before it (`isolation`: the
    command's own over the in-process match: its sandboxed controllers, the result written)."""
    text = re.sub(r"(?m)^time_limit:.*$", "time_limit: 1", levels.path("asabe-race").read_text())
    with tempfile.TemporaryDirectory() as d:
        level = Path(d) / "one-second.yaml"
        level.write_text(text)
        command = [sys.executable, "-m", "referee", "run", str(level), *["--team", spec] * 4]
        command += ["--replay", str(Path(d) / "m.replay"), "--json", str(Path(d) / "r.json"), "--quiet"]
        process_cost(command, cwd=d)  # untimed: the first reads the files from disk
        walls = {}
        for name, code in FIXED_STAGES:
            stage = [sys.executable, "-c", code, str(level), spec, str(Path(d) / "s.replay")]
            walls[name], _ = process_cost(stage, cwd=d)
        wall, used = process_cost(command, cwd=d)
    out = {"wall_s": wall, "cpu_s": used}
    before = 0.0
    for name, took in (*walls.items(), ("isolation", wall)):
        out[f"{name}_s"], before = took - before, took
    return out


def measure(repeat: int = 3, seconds: float = 60.0, matches: int = 2) -> dict:
    """Every speed figure, in one run."""
    w = world(seconds, max(repeat, 5))  # cheap (a second a run) and noisy: never fewer than 5
    out: dict = {"world": w, "matches": {}}
    for spec in ("ref:bac", "ref:dead-reckoning"):
        for isolate in (True, False):
            m = match(spec, isolate, repeat)
            out["matches"][f"{spec} {'isolated' if isolate else 'in-process'}"] = m
    out["grading"] = {}
    for spec in ("ref:bac", "ref:dead-reckoning"):
        out["grading"][spec] = median_of(repeat, lambda spec=spec: grading(matches, spec))
    (one, one_s), (four, four_s) = command_line_grading(1), command_line_grading(4)
    per_simulated_s = (four - one) / (four_s - one_s)  # what the three more matches cost
    out["command_line_grading"] = {
        "cpu_per_s": four / four_s,
        "ratio": four / four_s * w["bare_x"],
        "fixed_cpu_s": one - per_simulated_s * one_s,
        "match_cpu_per_s": per_simulated_s,
    }
    out["command_line_run"] = median_of(repeat, command_line_run)
    out["command_line_run_bac"] = median_of(repeat, lambda: command_line_run("ref:bac"))
    out["command_line_fixed"] = median_of(max(repeat, 5), command_line_fixed)
    return out


MATCH_TARGETS = {
    "ref:dead-reckoning isolated": " (target >= 0.5)",
    "ref:dead-reckoning in-process": " (target >= 0.7)",
    "ref:bac isolated": " (target >= 0.3)",
}


def table(f: dict) -> list[tuple[str, str, str]]:
    """The figures as (what, value, against its target) rows."""
    w = f["world"]
    rows = [
        ("asabe-race bare stepping", f"{w['bare_x']:.0f}x real time", ""),
        (
            "  compiled, a control period at a time",
            f"{w['compiled_x']:.0f}x real time",
            "World.run, as a match steps it",
        ),
        (
            "  with sensing",
            f"{w['sensing_x']:.0f}x real time",
            f"sensing adds {100 * w['sensing_overhead']:.0f} % (target < 50 %)",
        ),
    ]
    for name, m in f["matches"].items():
        rows.append(
            (
                f"  full match, 4 x {name}",
                f"{m['x']:.0f}x real time",
                f"{m['ratio']:.2f} of bare{MATCH_TARGETS.get(name, '')}; CPU per simulated s: "
                f"referee {1000 * m['referee_cpu_per_s']:.1f} ms, controllers and the rest "
                f"{1000 * m['others_cpu_per_s']:.1f} ms",
            )
        )
    for spec, gr in f["grading"].items():
        rows.append(
            (
                f"grading {spec} on asabe",
                f"{1000 * gr['cpu_per_s']:.1f} ms CPU per simulated s",
                f"{gr['ratio']:.1f}x bare stepping's {1000 * gr['bare_cpu_per_s']:.2f} ms"
                + (" (target <= 1.5x)" if spec == "ref:bac" else " (the platform's own share; target <= 1x)"),
            )
        )
    c = f["command_line_grading"]
    rows.append(
        (
            "laserarena grade asabe, 4 seeds",
            f"{1000 * c['cpu_per_s']:.1f} ms CPU per simulated s",
            f"{c['ratio']:.1f}x bare; each run {c['fixed_cpu_s']:.2f} s whatever its matches, "
            f"then {1000 * c['match_cpu_per_s']:.1f} ms per simulated s",
        )
    )
    for key, spec, target in (
        ("command_line_run", "ref:dead-reckoning", "0.5"),
        ("command_line_run_bac", "ref:bac", "0.3"),
    ):
        r = f[key]
        rows.append(
            (
                f"laserarena run asabe-race, 4 x {spec}",
                f"{r['wall_s']:.2f} s wall, {r['simulated_s']:.0f} s simulated",
                f"{r['ratio']:.2f} of a bare-stepping process's {r['bare_wall_s']:.2f} s (whole processes, "
                f"target >= {target}); CPU {r['cpu_ratio']:.1f}x its",
            )
        )
    fixed = f["command_line_fixed"]
    rows.append(
        (
            "laserarena run, a 1 s asabe-race (fixed cost)",
            f"{fixed['wall_s']:.2f} s wall",
            f"target <= 0.3 s; {fixed['wall_s'] / f['command_line_run']['wall_s']:.2f} of the whole 4 x "
            "ref:dead-reckoning run",
        )
    )
    rows.append(
        (
            "  where it goes (each stage's added wall)",
            ", ".join(f"{name} {fixed[f'{name}_s']:.2f}" for name, _ in (*FIXED_STAGES, ("isolation", ""))),
            "s",
        )
    )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per figure (the median is kept)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = ap.parse_args()
    f = measure(args.repeat)
    if args.json:
        print(json.dumps(f, indent=2, sort_keys=True))
        return
    rows = table(f)
    width = max(len(a) for a, _, _ in rows)
    for a, b, c in rows:
        print(f"{a:<{width}}  {b:<30} {c}")


if __name__ == "__main__":
    main()
