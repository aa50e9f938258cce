"""How much each of Bac's hardware parameters that are ours matters: the headline figures at half
and at twice its value.

`figures(overrides)` runs the Bac levels with some `sensor_array` parameters replaced (and `gain`,
array C's trim) and returns the figures the seed publishes: at Table 1's point (1.16, 0.53) m, the
paper's method (ref:bac-seed) set down exactly there for 60 s, the share of correct measurements
from three arrays, the share of erroneous ones (both counted as Table 1 counts them) and the
static std of x and y; and ref:bac's position RMS on asabe. The main program prints a Markdown
table of every parameter at x0.5 and x2 beside the levels' own values.

    python benchmarks/bac_sensitivity.py [--seeds 2] [--workers 2]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import yaml

import levels
from arena.level import Level
from arena.loader import parse_level

sys.path.insert(0, str(Path(__file__).resolve().parent))
import fidelity

# Bac's parameters that are ours or sized by us (docs/sensors.md), `gain` being array C's trim
OURS = (
    "rise_time",
    "trigger_fraction",
    "acceptance",
    "light_noise",
    "gain",
    "false_rate",
    "wobble",
    "beam_diameter",
    "beam_divergence",
    "timing_noise",
    "spin_time",
)
TRIMMED = "C"  # the array whose trim `gain` sets


@dataclass(frozen=True)
class Figures:
    """The seed's headline figures from one set of parameters, averaged over seeds."""

    three: float  # % of correct measurements from three arrays, at Table 1's point
    erroneous: float  # % of all measurements, at Table 1's point
    std_x: float  # mm, the paper's method at Table 1's point
    std_y: float
    asabe_rms: float  # mm, ref:bac on asabe (nan: it never had an estimate)
    asabe_reached: float  # waypoints of 33 ref:bac reached on asabe


def bac_level(name: str, overrides: dict[str, float], exact: bool = False) -> Level:
    """A Bac level with `sensor_array` parameters replaced (`gain`: array C's), in the file's
    units (angles in degrees); `exact` sets the robot down at its start in one trial."""
    data = yaml.safe_load(levels.path(name).read_text())
    for key, value in overrides.items():
        if key == "gain":
            next(b for b in data["beacons"]["items"] if b["id"] == TRIMMED)["gain"] = value
        else:
            data["beacons"]["params"][key] = value
    if exact:
        data["robots"][0].pop("placement", None)
        data["task"] = {"kind": "localize"}
    return parse_level(yaml.safe_dump(data).encode(), f"levels/{name}.yaml (sensitivity)")


def static_figures(overrides: dict[str, float], seed: int, folder: Path) -> tuple[float, float, float, float]:
    """(three-array %, erroneous %, std x mm, std y mm) at Table 1's point, as `fidelity.bac_static`."""
    level = bac_level("bac-static", overrides, exact=True)
    rep = fidelity.play(level, ["ref:bac-seed"], seed, folder)
    m = fidelity.table1(rep, [b.id for b in level.beacons.items], level.robots[0].laser.angular_velocity)
    errs = fidelity.errors(rep, after=2.0)
    shares = (100 * m.three / m.correct if m.correct else math.nan, 100 * m.erroneous / max(1, m.total))
    if not errs:  # no fix at all
        return (*shares, math.nan, math.nan)
    mx, my = statistics.median(e[1] for e in errs), statistics.median(e[2] for e in errs)
    correct = [e for e in errs if math.hypot(e[1] - mx, e[2] - my) < 0.01]
    return (*shares, 1000 * statistics.pstdev(e[1] for e in correct), 1000 * statistics.pstdev(e[2] for e in correct))


def asabe_figures(overrides: dict[str, float], seed: int, folder: Path) -> tuple[float, float]:
    """ref:bac on asabe: its position RMS (mm; nan without any estimate) and waypoints reached."""
    robot = fidelity.play(bac_level("asabe", overrides), ["ref:bac"], seed, folder).result["robots"][0]
    rms = robot["localization"]["position_rms"]
    return (math.nan if rms is None else 1000 * rms), robot["task"]["reached"]


def figures(overrides: dict[str, float], seeds: tuple[int, ...] = (1, 2)) -> Figures:
    """The headline figures with these parameter `overrides`, averaged over `seeds`."""
    with tempfile.TemporaryDirectory(prefix="laserarena-sensitivity-") as d:
        folder = Path(d)
        runs = [(*static_figures(overrides, s, folder), *asabe_figures(overrides, s, folder)) for s in seeds]
    return Figures(*(statistics.fmean(column) for column in zip(*runs)))


def nominal(name: str) -> float:
    """The levels' own value of an ours parameter, in the file's units."""
    data = yaml.safe_load(levels.path("bac-static").read_text())
    if name == "gain":
        return next(b for b in data["beacons"]["items"] if b["id"] == TRIMMED)["gain"]
    return data["beacons"]["params"][name]


def _row(job: tuple[str, float, tuple[int, ...]]) -> tuple[str, float, Figures]:
    name, factor, seeds = job
    return name, factor, figures({name: nominal(name) * factor} if name else {}, seeds)


def markdown(rows: list[tuple[str, float, Figures]], seeds: tuple[int, ...]) -> str:
    lines = [
        "| parameter | value | three arrays at Table 1's point | erroneous | static std x / y | asabe: RMS, waypoints |",
        "|---|---|---|---|---|---|",
    ]
    for name, factor, f in rows:
        value = "levels' own" if not name else f"x{factor:g} = {nominal(name) * factor:.4g}"
        lines.append(
            f"| {name or '-'} | {value} | {f.three:.1f} % | {f.erroneous:.1f} % | "
            f"{f.std_x:.2f} / {f.std_y:.2f} mm | {f.asabe_rms:.2f} mm, {f.asabe_reached:.1f} of 33 |"
        )
    note = f"(seeds {', '.join(map(str, seeds))}, means; Table 1: 56 %, 0.4 %, 1.7 / 1.7 mm; nan: no fix at all)"
    return "\n".join(lines) + "\n\n" + note + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1..N (default 2)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    args = ap.parse_args(argv)
    seeds = tuple(range(1, args.seeds + 1))
    jobs = [("", 1.0, seeds)] + [(name, factor, seeds) for name in OURS for factor in (0.5, 2.0)]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(_row, jobs, chunksize=1))
    print(markdown(rows, seeds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
