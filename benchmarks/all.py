"""`make bench`: every speed figure of LaserArena on this machine, side by side, in one run.

(a) the 4-robot asabe-race world: bare stepping, sensing, full matches isolated and in-process
    with two controllers, grading's CPU beside bare stepping's (benchmarks/speed.py);
(b) localization solvers, scalar and vectorized; (c) rendering and encoding frames per second;
(d) grading throughput; (e) the learning envs beside bare stepping (benchmarks/env.py); (f) how a
match's cost grows with robots and beacons (benchmarks/scaling.py); (g) a controller's start,
forked from the sandbox's template (benchmarks/sandbox.py); (h) what the slot's boundary costs
per slot and per answer (benchmarks/boundary.py); (i) the first run after an install, its
kernels compiled, beside the next (benchmarks/first_run.py). Prints
a table and writes the figures as JSON (--json): to docs/performance.json by default, the
committed report the docs quote (benchmarks/quoted.py's `<!--p:KEY:STAT-->` markers, set here
and held to it by tests/test_docs_figures.py), where each figure is in the unit the docs show
it in.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import boundary
import env
import first_run
import grading
import quoted
import render
import sandbox
import scaling
import solvers
import speed


def report(f: dict, repeat: int) -> dict:
    """The figures as the docs quote them: {key: {stat: value}}, in the units shown."""
    sp, s, r, g = f["speed"], f["solvers"], f["render"], f["grading"]
    w = sp["world"]
    out: dict = {
        "machine": dict(f["machine"], repeat=repeat, seconds=round(f["seconds"])),
        "world": {
            "bare_x": w["bare_x"],
            "compiled_x": w["compiled_x"],
            "compiled_over_bare": w["compiled_x"] / w["bare_x"],
            "sensing_x": w["sensing_x"],
            "sensing_overhead_percent": 100 * w["sensing_overhead"],
        },
    }
    for name, m in sp["matches"].items():
        spec, _, how = name.partition(" ")
        out[f"match.{spec.removeprefix('ref:')}.{how}"] = {
            "x": m["x"],
            "ratio": m["ratio"],
            "referee_cpu_ms": 1000 * m["referee_cpu_per_s"],
            "others_cpu_ms": 1000 * m["others_cpu_per_s"],
        }
    for spec, gr in sp["grading"].items():
        out[f"grading.{spec.removeprefix('ref:')}"] = {
            "cpu_ms": 1000 * gr["cpu_per_s"],
            "ratio": gr["ratio"],
            "bare_cpu_ms": 1000 * gr["bare_cpu_per_s"],
        }
    c = sp["command_line_grading"]
    out["grade-command"] = {
        "cpu_ms": 1000 * c["cpu_per_s"],
        "ratio": c["ratio"],
        "fixed_cpu_s": c["fixed_cpu_s"],
        "match_cpu_ms": 1000 * c["match_cpu_per_s"],
    }
    keys = ("wall_s", "simulated_s", "bare_wall_s", "ratio", "cpu_ratio")
    out["run-command"] = {k: sp["command_line_run"][k] for k in keys}
    out["run-command.bac"] = {k: sp["command_line_run_bac"][k] for k in keys}
    out["run-fixed"] = dict(sp["command_line_fixed"])
    out["solvers"] = {
        "total_scalar_us": s["total_scalar_us"],
        "total_heading_us": s["total_heading_us"],
        "circles_scalar_us": s["circles_scalar_us"],
        "total_vectorized_m_per_s": s["total_vectorized_per_s"] / 1e6,
        "total_vectorized_ns": 1e9 / s["total_vectorized_per_s"],
    }
    out["render"] = {"draw_fps": r["draw_fps"], "encode_fps": r["encode_fps"], "both_fps": r["both_fps"]}
    out["throughput"] = {
        "cpu_per_match_s": g["cpu_per_match_s"],
        "per_hour_1": g["per_hour_1"],
        "per_hour_all": g["per_hour_all"],
        "workers": g["workers"],
        "speedup": g["speedup"],
    }
    if f["start"]:
        out["start"] = dict(f["start"])
    out["boundary"] = dict(f["boundary"])
    out["first-run"] = dict(f["first_run"])
    out["env"] = dict(f["env"])  # microseconds per step, steps per second, ratios to bare: as env.py gives them
    for what in ("robots", "beacons"):
        for n, fig in f["scaling"][what].items():
            out[f"scaling.{what}.{n}"] = dict(fig, referee_cpu_ms=1000 * fig["isolated_cpu"])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--json",
        metavar="OUT",
        default=str(quoted.REPORTS["p"]),
        help="write the figures here as JSON (default docs/performance.json, whose figures the docs quote)",
    )
    ap.add_argument("--repeat", type=int, default=3, help="runs per speed figure (the median is kept)")
    ap.add_argument("--note", default="", help="a word on the run kept in the report, e.g. that the machine was busy")
    args = ap.parse_args()
    t0 = time.perf_counter()
    figures = {
        "machine": {
            "cpus": os.cpu_count(),
            "cpu": speed.cpu_model(),
            "python": platform.python_version(),
            "platform": platform.platform(),
        }
    }
    figures["speed"] = speed.measure(args.repeat)
    figures["solvers"] = solvers.measure()
    figures["render"] = render.measure(300)
    figures["grading"] = grading.measure(8)  # enough matches that each pool worker's start (imports, numba) is spread
    figures["env"] = env.measure(max(args.repeat, 5))  # cheap (seconds a round) and noisy: never fewer than 5
    figures["scaling"] = scaling.scaling(10.0, args.repeat)
    figures["start"] = sandbox.forked_start(15)
    if figures["start"]:
        figures["start"].update(sandbox.floor(30))
    figures["boundary"] = boundary.measure()
    figures["first_run"] = first_run.measure(args.repeat)
    s, r, g = figures["solvers"], figures["render"], figures["grading"]
    rows = [(f"(a) {a.strip()}", b, c) for a, b, c in speed.table(figures["speed"])]
    rows += [
        ("(b) ToTal scalar", f"{s['total_scalar_us']:.2f} us/call", "target < 3 us"),
        ("(b) ToTal vectorized", f"{s['total_vectorized_per_s'] / 1e6:.1f} M solves/s", "target >= 10 M/s"),
        ("(c) render 960x640", f"{r['draw_fps']:.0f} frames/s", ""),
        ("(c) encode H.264 960x640", f"{r['encode_fps']:.0f} frames/s", "target >= 100"),
        ("(d) grading: CPU per asabe match", f"{g['cpu_per_match_s']:.2f} s", "the match ends when ASABE is drawn"),
        (
            "(d) grading throughput",
            f"{g['per_hour_all']:.0f} matches/h on {g['workers']} workers",
            f"{g['speedup']:.2f}x of one worker",
        ),
    ]
    rows += [(f"(e) {a.strip()}", b, c) for a, b, c in env.table(figures["env"])]
    rows += [(f"(f) {a}", b, "") for a, b in scaling.rows(figures["scaling"])]
    if figures["start"]:
        st = figures["start"]
        shares = ", ".join(f"{name} {st[name + '_ms']:.1f}" for name in sandbox.SHARES)
        rows.append(
            (
                "(g) a forked controller's start",
                f"{st['cpu_ms']:.1f} ms CPU, all processes",
                f"target <= 5 ms ({shares})",
            )
        )
        floor = f"{st['fork_ms']:.1f} ms CPU"
        if "namespaces_ms" in st:
            floor += f", {st['namespaces_ms']:.1f} with the slot's namespaces"
        rows.append(("(g) its floor: a fork and exit", floor, "a process the template's size"))
    b = figures["boundary"]
    if "cpu_group_ms" in b:
        rows.append(("(h) a slot's cpu group", f"{b['cpu_group_ms']:.2f} ms", "made, weighed, removed"))
        rows.append(("(h) a slot's memory, pids, cpu groups", f"{b['groups_ms']:.2f} ms", "made, limited, removed"))
    rows.append(("(h) the stage held, per referee", f"{b['stage_ms']:.2f} ms", "its sources' identities hashed"))
    rows.append(
        (
            "(h) an answer decoded",
            f"{b['answer_us']:.1f} us once",
            f"{b['answer_twice_us']:.1f} us as before (envelope, check, decode)",
        )
    )
    rows.append(
        (
            "(h) the largest legal answer",
            f"{b['largest_answer_ms']:.0f} ms once",
            f"{b['largest_answer_twice_ms']:.0f} ms as before; its sender's budget pays",
        )
    )
    fr = figures["first_run"]
    rows.append(
        (
            "(i) the first run after an install",
            f"{fr['cold_wall_s']:.1f} s ({fr['cold_cpu_s']:.1f} s CPU)",
            f"laserarena run asabe compiling its kernels; {fr['warm_wall_s']:.1f} s the next time",
        )
    )
    width = max(len(a) for a, _, _ in rows)
    m = figures["machine"]
    print(f"LaserArena benchmarks on {m['cpus']} x {m['cpu']}, Python {m['python']} (medians of {args.repeat} runs)")
    for a, b, c in rows:
        print(f"  {a:<{width}}  {b:<28} {c}")
    figures["seconds"] = time.perf_counter() - t0
    print(f"  ({figures['seconds']:.0f} s)")
    out = report(figures, args.repeat)
    out["machine"]["note"] = args.note
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(out, indent=1, sort_keys=True) + "\n")
    if Path(args.json) == quoted.REPORTS["p"]:  # the committed report: set the figures the docs quote
        for page in quoted.requote_pages("p", out):
            print(f"  set the figures of {page.relative_to(quoted.ROOT)}")


if __name__ == "__main__":
    main()
