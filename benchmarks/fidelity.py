"""`make fidelity`: each seed's experiment, re-run in LaserArena over many seeds, beside the seed's
published figure; every model parameter with its source; and what the figures become when a
parameter the seeds do not give is halved or doubled.

An experiment runs a built-in level (or a variant of it: the seed's experiment at the seed's own
pose) for one seed, reads what happened from the match's replay (events, estimates, true poses)
and returns named figures. A row takes one figure over `--seeds` seeds (in worker processes) and
passes when its median lies in the row's band; the table gives the median, the 5-95 % range of
the seeds and how many seeds fell outside the band. Written as Markdown to docs/fidelity.md and
as JSON to docs/fidelity.json (`--out`, `--json`): docs quote figures from it through
benchmarks/quoted.py's markers (tests/test_docs_figures.py holds them to it). Exit status 0; `--strict` makes a failed row exit 1.

    python benchmarks/fidelity.py [--seeds 20] [--workers 2] [--sensitivity-seeds 5] [--strict]
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from itertools import groupby
from pathlib import Path
from typing import Any

import quoted
import yaml

import levels
from levels.loader import parse_level
from levels.model import Level
from levels.robot_models import ROBOT_MODELS
from referee.match.loop import Match
from referee.match.views import replay_header
from referee.media import error_series
from referee.records.replay_format import Replay
from referee.records.replay_writer import MemoryRecorder
from referee.sandbox.teams import resolve
from referee.terminal import markdown_text

IN = 0.0254  # m
SIMI = "Simi 2000 (seed 003)"
BAC = "Bac, Grift & Menezes 2011 (seed 002)"
VANNOY = "Vannoy 2001 (seed 000)"
UBERSETZIG = "Ubersetzig 1999 (seed 001)"
OSENTOSKI = "Osentoski (seed 004)"
ROOT = Path(__file__).resolve().parent.parent

# ---- levels and matches ------------------------------------------------------------------------

Scale = tuple[tuple[str, float], ...]  # (dotted key in the level's data, factor): a parameter scaled


# What a seed's experiment adds to its contest level: the floor tiles Simi's experimenter
# carried the cart by (the contest draws its trials from a region, docs/levels.md)
EXPERIMENT_FLOORS: dict[str, dict[str, Any]] = {
    "simi": {
        "tiles": {
            # "the floor tiles are not perfectly 12 inches apart and they are not perfectly perpendicular
            # to each other": Appendix F's differences fit a grid whose pitches are off by -0.13 and
            # 0.00 % and whose lines are turned -0.20 and -0.07 deg
            "origin": [57.46535, -58.11582],  # the start's tile value: "the initial optical solution position"
            "spacing_error": 0.0015,  # each axis's pitch off by up to 0.15 % (0.018 in a tile), drawn per match
            "angle_error": 0.2,  # deg: each set of lines turned by up to this, drawn per match
        }
    }
}


def level_data(name: str, scale: Scale = (), experiment: bool = False) -> dict[str, Any]:
    """A built-in level's parsed data, with what its seed's experiment adds to its floor
    (EXPERIMENT_FLOORS) if `experiment`, each parameter of `scale` multiplied by its factor (a
    robot's drive error the level leaves at its model's default, `robots.0.drive.gain_sd`, is
    scaled from that default)."""
    data = yaml.safe_load(levels.path(name).read_text())
    if experiment and name in EXPERIMENT_FLOORS:
        data.setdefault("floor", {}).update(copy.deepcopy(EXPERIMENT_FLOORS[name]))
    for key, factor in scale:
        *parents, last = key.split(".")
        node = data
        for part in parents:
            node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
        if last not in node and parents[-1:] == ["drive"]:
            robot = data["robots"][int(parents[1])]
            node[last] = getattr(ROBOT_MODELS[robot.get("model", "boe-bot")].drive, last)
        node[last] = node[last] * factor
    return data


def variant(
    name: str, scale: Scale = (), robot: dict[str, Any] | None = None, experiment: bool = False, **changes: Any
) -> Level:
    """A built-in level with top-level fields or the first robot's fields replaced (parsed data,
    dumped back: the loader validates the variant like any level); a robot field given as None
    is removed (`placement=None`: set down exactly at the start); `experiment`: with what its
    seed's experiment adds (`level_data`)."""
    data = level_data(name, scale, experiment)
    data.update(changes)
    for key, value in (robot or {}).items():
        if value is None:
            data["robots"][0].pop(key, None)
        else:
            data["robots"][0][key] = value
    return parse_level(yaml.safe_dump(data).encode(), f"levels/{name}.yaml (variant)")


def exactly_at(name: str, scale: Scale = (), robot: dict[str, Any] | None = None, **changes: Any) -> Level:
    """A built-in level whose robot is set down exactly at its nominal start, in one trial: the
    seed's experiment at the seed's own pose."""
    if "task" not in changes and level_data(name)["task"]["kind"] == "localize":
        changes["task"] = {"kind": "localize"}
    return variant(name, scale, {"placement": None, **(robot or {})}, **changes)


def play(level: Level, teams: list[str], seed: int, ideal: bool = False) -> Replay:
    """A match in this process (the reference controllers give the same bytes isolated), its
    replay kept in memory."""
    resolved = [resolve(t) for t in teams]
    recorder = MemoryRecorder(replay_header(level, resolved, seed, ideal, None))
    Match(level, resolved, seed=seed, ideal=ideal, isolate=False, recorder=recorder).run()
    return recorder.replay


def truth(rep: Replay, slot: int = 0) -> Callable[[float], tuple[float, float, float]]:
    """`slot`'s true pose as a function of time: interpolated between recorded frames but never
    across a trial's move (as the viewer and `laserarena plot` take it); past the last frame (a
    match that ended between two), the last."""
    times, moves, last = [f[0] for f in rep.frames], rep.moves, tuple(rep.frames[-1][1][slot])

    def at(t: float) -> tuple[float, float, float]:
        pose = error_series.truth_at(rep.frames, times, slot, t, moves)
        return pose if pose is not None else last

    return at


def errors(rep: Replay, slot: int = 0, after: float = 0.0) -> list[tuple[float, float, float]]:
    """(time, x error, y error) of every estimate `slot` reported `after` seconds or more after the
    match or its trial began (a trial's move falls on a control tick: the frames around it are
    two poses, so no estimate within `after` of it is taken)."""
    out = []
    begins, at = [0.0, *rep.moves], truth(rep, slot)
    for e in rep.estimates:
        began = max(b for b in begins if b < e["t"] or b == 0.0)
        if e["r"] == slot and e["t"] >= began + after:
            x, y, _ = at(e["t"])
            out.append((e["t"], e["e"][0] - x, e["e"][1] - y))
    return out


def rms(values: list[float]) -> float:
    return math.sqrt(statistics.fmean(v * v for v in values)) if values else math.inf


def heading_rms_after(rep: Replay, after: float, slot: int = 0) -> float:
    """RMS heading error (deg) of the estimates `slot` reported after `after` seconds."""
    at = truth(rep, slot)
    return math.degrees(
        rms(
            [
                math.remainder(e["e"][2] - at(e["t"])[2], math.tau)
                for e in rep.estimates
                if e["r"] == slot and e["t"] > after
            ]
        )
    )


# ---- experiments: one seed in, named figures out -----------------------------------------------


def vannoy_example(seed: int, scale: Scale = (), ideal: bool = False) -> dict[str, float]:
    """The worked example: the robot still at (8, 5) ft, compass 230 deg; the three reflection
    times after the second click against the seed's, the largest difference (ms)."""
    published = [1.0556, 2.3628, 2.8508]
    rep = play(exactly_at("vannoy", scale), ["ref:idle"], seed, ideal=ideal)
    mine = [e for e in rep.events if e["r"] == 0]
    click = next(e["t"] for e in mine if e["kind"] == "index" and e["t"] > 0)
    hits = [e["t"] - click for e in mine if e["kind"] == "hit" and e["t"] > click][:3]
    worst = max(abs(a - b) for a, b in zip(hits, published)) if len(hits) == 3 else math.inf
    return {"worst_ms": 1000 * worst}


def vannoy_ideal_example(seed: int, scale: Scale = ()) -> dict[str, float]:
    return vannoy_example(seed, scale, ideal=True)


@dataclass(frozen=True)
class Measurements:
    """A run's laser revolutions counted as Bac's Table 1 counts its measurements."""

    four: int  # correct, from all four arrays
    three: int  # correct, from three arrays (one pulse missing)
    erroneous: int  # merged, extra or missing two or more pulses, or off the revolution time

    @property
    def correct(self) -> int:
        return self.four + self.three

    @property
    def total(self) -> int:
        return self.correct + self.erroneous


def revolutions(hits: list[tuple[float, str]], order: list[str]) -> list[list[tuple[float, str]]]:
    """The pulses (time, array) cut into revolutions: a revolution ends where the arrays stop
    coming in the beam's `order` (the next pulse is of an array already passed). Pulses that read
    one time (a merged pulse reads its predecessor's) come in the beam's order after the pulse
    before them."""
    rank = {b: k for k, b in enumerate(order)}
    out: list[list[tuple[float, str]]] = []
    for _, tied in groupby(sorted(hits), key=lambda h: h[0]):
        last = rank[out[-1][-1][1]] if out else -1
        for t, b in sorted(tied, key=lambda h: (rank[h[1]] - last - 1) % len(order)):
            if not out or rank[b] <= rank[out[-1][-1][1]]:
                out.append([])
            out[-1].append((t, b))
    return out


def measurement(rev: list[tuple[float, str]], after: list[tuple[float, str]], period: float) -> int | None:
    """How many arrays a revolution's measurement is correct from (3 or 4), 0 if it is
    erroneous, None if the run ends before it closes. The beam closes it when it next passes an
    array of it (`after`: the pulses that follow); its durations, the last to that pulse, must
    all be positive and, as the seed's filter has it, "the smallest pulse duration" is the
    tolerance of its revolution time against the nominal `period`."""
    seen = {b: t for t, b in rev}
    close = next(((t, b) for t, b in after if b in seen), None)
    if close is None:
        return None
    times = [t for t, _ in rev] + [close[0]]
    durations = [b - a for a, b in zip(times, times[1:])]
    ok = min(durations) > 1e-9 and abs(close[0] - seen[close[1]] - period) <= min(durations)
    return len(rev) if ok and len(rev) >= 3 else 0


def table1(rep: Replay, order: list[str], omega: float, slot: int = 0) -> Measurements:
    """`slot`'s revolutions counted as Table 1 counts them: correct from four or from three
    arrays (a single missing pulse: "it can yield a valid position value even if one of the
    sensor arrays is occluded"), or erroneous; a revolution with no pulse at all is erroneous
    too. Read from the events alone; a revolution across a trial's move is no measurement."""
    period = 2 * math.pi / abs(omega)
    hits = [(e["t"], e["b"]) for e in rep.events if e["r"] == slot and e["kind"] == "hit"]
    revs = revolutions(hits, order if omega > 0 else order[::-1])
    counts = {4: 0, 3: 0, 0: 0}
    for k, rev in enumerate(revs[1:], 1):  # the first began before the run did
        after = [h for later in revs[k + 1 : k + 3] for h in later]
        got = measurement(rev, after, period)
        if got is None or any(rev[0][0] < move <= (after[0][0] if after else math.inf) for move in rep.moves):
            continue
        counts[got] += 1
        if k + 1 < len(revs):  # whole revolutions with no pulse before the next one
            counts[0] += max(0, round((revs[k + 1][0][0] - rev[0][0]) / period) - 1)
    return Measurements(counts[4], counts[3], counts[0])


def bac_static(seed: int, scale: Scale = ()) -> dict[str, float]:
    """Table 1: the paper's own method (ref:bac-seed), as Table 1 was made, standing at the
    measured point in one run: its measurements counted as Table 1 counts them (erroneous, % of
    all; from three arrays, % of the correct) and the std of the correct fixes (mm)."""
    level = exactly_at("bac-static", scale)
    rep = play(level, ["ref:bac-seed"], seed)
    order = [b.id for b in level.beacons.items]  # O, A, B, C: counter-clockwise round the table
    m = table1(rep, order, level.robots[0].laser.angular_velocity)
    errs = errors(rep, after=2.0)
    if len(errs) < 2 or not m.correct:  # hardware that gives no measurements (a parameter far off)
        return {"bad_percent": 100.0, "three_percent": 0.0, "std_x_mm": math.inf, "std_y_mm": math.inf}
    mx, my = statistics.median(e[1] for e in errs), statistics.median(e[2] for e in errs)
    correct = [e for e in errs if math.hypot(e[1] - mx, e[2] - my) < 0.01]  # the seed filtered the rest
    return {
        "bad_percent": 100 * m.erroneous / m.total,
        "three_percent": 100 * m.three / m.correct,
        "std_x_mm": 1000 * statistics.pstdev(e[1] for e in correct),
        "std_y_mm": 1000 * statistics.pstdev(e[2] for e in correct),
    }


def bac_line(seed: int, scale: Scale = ()) -> dict[str, float]:
    """Fig. 7: the paper's method on its unsteered straight run; the std of the y deviation of
    its fixes from the true path over the first 0.9 m travelled (the seed's 40 readings), mm."""
    rep = play(variant("bac-line", scale), ["ref:bac-seed"], seed)
    x0, y0, _ = rep.frames[0][1][0]
    dev, at = [], truth(rep)
    for e in rep.estimates:
        x, y, _ = at(e["t"])
        if e["t"] >= 1.0 and math.hypot(x - x0, y - y0) <= 0.9:
            dev.append(e["e"][1] - y)
    return {"std_y_mm": 1000 * statistics.pstdev(dev), "readings": len(dev)}


def merged_percent(rep: Replay, order: list[str], slot: int = 0) -> float:
    """Merged pulses per revolution of `slot`'s (%, revolutions cut as Table 1 cuts them): a
    pulse that reads its predecessor's time: a merged measurement, the seed's "T_2 was occasionally processed as
    35 ms"."""
    hits = sorted((e["t"], e["b"]) for e in rep.events if e["r"] == slot and e["kind"] == "hit")
    merged = sum(b[0] - a[0] <= 1e-9 for a, b in zip(hits, hits[1:]))  # across a revolution's end too
    revs = revolutions(hits, order)
    return 100 * merged / len(revs) if revs else math.inf


def asabe(seed: int, scale: Scale = ()) -> dict[str, float]:
    """Fig. 8: ref:bac on the letters from its real start (and its merged measurements while it
    drives); blind dead reckoning from the announced start; and blind dead reckoning set down
    exactly at its start (the drive's own drift)."""
    level = variant("asabe", scale)
    rep = play(level, ["ref:bac"], seed)
    laser = rep.result["robots"][0]
    blind = play(variant("asabe", scale), ["ref:dead-reckoning"], seed).result["robots"][0]
    exact = play(exactly_at("asabe", scale), ["ref:dead-reckoning"], seed).result["robots"][0]
    return {
        "reached": laser["task"]["reached"],
        "finished": float(laser["task"]["finished"] is not None),
        "rms_mm": 1000 * (laser["localization"]["position_rms"] or math.inf),
        "heading_after_deg": heading_rms_after(rep, 5.0),
        "ratio": (laser["localization"]["position_rms"] or math.inf)
        / (blind["localization"]["position_rms"] or math.inf),
        "beats_blind": float(laser["score"]["total"] > blind["score"]["total"]),
        "drift_mm": 1000 * (exact["localization"]["position_rms"] or math.inf),
        "merged_percent": merged_percent(rep, [b.id for b in level.beacons.items]),
    }


def asabe_race(seed: int, scale: Scale = ()) -> dict[str, float]:
    """Four ref:bac robots blocking each other's beams: their position RMS (mm), the worst and
    the median of the four."""
    level = variant("asabe-race", scale)
    rms_ = [
        1000 * (r["localization"]["position_rms"] or math.inf)
        for r in play(level, ["ref:bac"] * len(level.robots), seed).result["robots"]
    ]
    return {"worst_mm": max(rms_), "median_mm": statistics.median(rms_)}


def shared_race(seed: int, scale: Scale = ()) -> dict[str, float]:
    """asabe-race-shared: four ref:bac robots, every array latching every robot's pulse (Bac's
    own arrays): whether all reach every waypoint, and the worst and median robot's RMS (mm)."""
    level = variant("asabe-race-shared", scale)
    robots = play(level, ["ref:bac"] * len(level.robots), seed).result["robots"]
    rms_ = [1000 * (r["localization"]["position_rms"] or math.inf) for r in robots]
    done = all(r["task"]["reached"] == r["task"]["total"] for r in robots)
    return {"finished": float(done), "worst_mm": max(rms_), "median_mm": statistics.median(rms_)}


# Appendix F: the 40 tile positions (in) at which the seed compared optical with measured values.
SIMI_POSITIONS = [
    (57.46535, -58.11582),
    (57.465, -46.116),
    (57.465, -34.116),
    (57.465, -22.116),
    (45.465, -22.116),
    (33.465, -22.116),
    (33.465, -46.116),
    (45.465, -46.116),
    (45.465, -34.116),
    (33.465, -34.116),
    (45.465, -58.116),
    (45.465, -70.116),
    (57.465, -70.116),
    (57.465, -82.116),
    (81.465, -58.116),
    (81.465, -82.116),
    (81.465, -94.116),
    (81.465, -46.116),
    (81.465, -22.116),
    (81.465, -34.116),
    (81.465, -70.116),
    (93.465, -70.116),
    (93.465, -82.116),
    (93.465, -46.116),
    (93.465, -34.116),
    (93.465, -22.116),
    (105.465, -22.116),
    (105.465, -34.116),
    (105.465, -46.116),
    (105.465, -58.116),
    (93.465, -58.116),
    (117.465, -34.116),
    (117.465, -22.116),
    (69.465, -46.116),
    (69.465, -34.116),
    (69.465, -22.116),
    (69.465, -58.116),
    (69.465, -70.116),
    (69.465, -82.116),
    (69.465, -94.116),
]
# five of them, each turned through the seed's 45, 90, -45 and -90 degrees for the heading error
SIMI_TURNS = [(57.46535, -58.11582), (45.465, -34.116), (93.465, -34.116), (69.465, -82.116), (81.465, -58.116)]
SIMI_TILE = SIMI_POSITIONS[0]  # the start's tile: "the initial optical solution position"
TRIAL_TIME = 3.0  # s at each pose: about 90 laser turns
Pose3 = tuple[float, float, float]


def trial_fixes(rep: Replay, slot: int = 0) -> list[tuple[Pose3 | None, Pose3]]:
    """(estimate, true pose) at the end of each trial: the solution the controller settled on
    before the robot was carried on (None if it gave none in that trial), and where it stood."""
    out: list[tuple[Pose3 | None, Pose3]] = []
    at = truth(rep, slot)
    for begin, end in zip([0.0, *rep.moves], [*rep.moves, rep.duration]):
        mine = [e["e"] for e in rep.estimates if e["r"] == slot and begin < e["t"] <= end]
        out.append(((mine[-1][0], mine[-1][1], mine[-1][2]) if mine else None, at(end)))
    return out


def simi_tour(scale: Scale, positions: list[tuple[float, float]], headings: list[float]) -> Level:
    """The simi level as one tour of the experimenter's: the start, then each listed tile once (in
    a secret order, on the floor's real tiles) at one of `headings`, TRIAL_TIME at each; the robot
    told nothing (the thesis computed each optical solution from the detectors alone)."""
    trials = {"count": len(positions) + 1, "positions": [list(p) for p in positions], "headings": headings}
    return variant(
        "simi",
        scale,
        {"start_known": False},
        experiment=True,
        time_limit=TRIAL_TIME * (len(positions) + 1),
        task={"kind": "localize", "trials": trials},
    )


def tile_of(true: Pose3, start: Pose3) -> tuple[float, float]:
    """The tile a trial was carried to: the listed one nearest the true move from the start."""
    x, y = (true[0] - start[0]) / IN + SIMI_TILE[0], (true[1] - start[1]) / IN + SIMI_TILE[1]
    return min(SIMI_POSITIONS, key=lambda p: math.dist(p, (x, y)))


def simi(seed: int, scale: Scale = ()) -> dict[str, float]:
    """Chapter 4 on one floor (the seed's tiles and tilt), the thesis's two procedures. The map:
    the start, then the 40 positions of Appendix F, each "difference between the tile values and
    the optical values" with the tiles laid out from the start's optical solution (relative), and
    optical minus true (absolute), worst per axis (in); how many got a fix; the start's own error.
    The turns: five positions each "rotated 45°, 90°, -45°, and -90°" (four visits each, turns
    drawn from those), the worst heading error against the start's optical heading plus the
    nominal turn, and against the truth (deg). A turned position with no solution scores inf."""
    (e0, t0), *rest = trial_fixes(play(simi_tour(scale, SIMI_POSITIONS[1:], [0]), ["ref:simi"], seed))
    if e0 is None:
        return dict.fromkeys(
            ("start_x", "start_y", "rel_x", "rel_y", "abs_x", "abs_y", "heading", "heading_abs"), math.inf
        ) | {"fixed": 0}
    rel, absolute = [0.0, 0.0], [0.0, 0.0]
    for est, true in rest:
        if est is None:
            continue
        tile = tile_of(true, t0)
        for axis in (0, 1):
            moved = (est[axis] - e0[axis]) / IN - (tile[axis] - SIMI_TILE[axis])
            rel[axis] = max(rel[axis], abs(moved))
            absolute[axis] = max(absolute[axis], abs(est[axis] - true[axis]) / IN)
    turns = [45.0, 90.0, -45.0, -90.0]
    (h0, _), *turned = trial_fixes(play(simi_tour(scale, SIMI_TURNS * 4, turns), ["ref:simi"], seed))
    heading = heading_abs = 0.0 if h0 is not None else math.inf
    for est, true in turned:
        if est is None or h0 is None:
            heading = heading_abs = math.inf
            continue
        turn = math.radians(min(turns, key=lambda a: abs(math.remainder(math.radians(a) - true[2], math.tau))))
        heading = max(heading, abs(math.degrees(math.remainder(est[2] - h0[2] - turn, math.tau))))
        heading_abs = max(heading_abs, abs(math.degrees(math.remainder(est[2] - true[2], math.tau))))
    return {
        "start_x": abs(e0[0] - t0[0]) / IN,
        "start_y": abs(e0[1] - t0[1]) / IN,
        "fixed": 1 + sum(est is not None for est, _ in rest),
        "rel_x": rel[0],
        "rel_y": rel[1],
        "abs_x": absolute[0],
        "abs_y": absolute[1],
        "heading": heading,
        "heading_abs": heading_abs,
    }


def osentoski(seed: int, scale: Scale = ()) -> dict[str, float]:
    """ref:osentoski's own level: six trials anywhere in front of the lights (no published
    figure: what its parameters cost)."""
    r = play(variant("osentoski", scale), ["ref:osentoski"], seed).result["robots"][0]
    return {"rms_mm": 1000 * (r["localization"]["position_rms"] or math.inf), "fraction": r["localization"]["fraction"]}


def unknown_start(name: str, seed: int, scale: Scale = ()) -> dict[str, float]:
    """A goto reference from a start drawn anywhere in its level's region, facing anywhere."""
    r = play(variant(name, scale), [f"ref:{name}"], seed).result["robots"][0]
    return {
        "reached": float(r["task"]["finished"] is not None),
        "rms_mm": 1000 * (r["localization"]["position_rms"] or math.inf),
    }


def vannoy_start(seed: int, scale: Scale = ()) -> dict[str, float]:
    return unknown_start("vannoy", seed, scale)


def ubersetzig_start(seed: int, scale: Scale = ()) -> dict[str, float]:
    return unknown_start("ubersetzig", seed, scale)


SEED_LEVELS = ["vannoy", "ubersetzig", "bac-static", "bac-line", "asabe", "simi", "osentoski"]


def ideal(name: str, seed: int) -> dict[str, float]:
    """With perfect hardware a level's default reference localizes within 5 mm from its first
    event on (the estimate at t = 0 can only be the announced start, off by its spread): RMS and
    worst, mm."""
    level = variant(name)
    rep = play(level, [level.default_controller], seed, ideal=True)
    d = [1000 * math.hypot(ex, ey) for t, ex, ey in errors(rep) if t > 0]
    return {"rms_mm": rms(d), "max_mm": max(d) if d else math.inf}


EXPERIMENTS: dict[str, Callable[..., dict[str, float]]] = {
    "vannoy_example": vannoy_example,
    "vannoy_ideal_example": vannoy_ideal_example,
    "bac_static": bac_static,
    "bac_line": bac_line,
    "asabe": asabe,
    "asabe_race": asabe_race,
    "shared_race": shared_race,
    "simi": simi,
    "osentoski": osentoski,
    "vannoy_start": vannoy_start,
    "ubersetzig_start": ubersetzig_start,
    **{f"ideal_{name}": (lambda n: lambda seed, scale=(): ideal(n, seed))(name) for name in SEED_LEVELS},
}


def _run(job: tuple[str, int, Scale]) -> tuple[tuple[str, int, Scale], dict[str, float]]:
    experiment, seed, scale = job
    return job, EXPERIMENTS[experiment](seed, scale)


# ---- rows: one figure of an experiment over the seeds, against the seed's ---------------------


@dataclass(frozen=True)
class Row:
    """One figure: the seed's, ours over the seeds (the median passes or fails the band)."""

    key: str  # its name in docs/fidelity.json
    experiment: str
    figure: str
    title: str
    source: str  # the seed and the sentence the figure comes from
    published: str
    low: float
    high: float
    unit: str
    digits: int = 1
    seeds: int = 0  # 0: the run's --seeds; more where a row counts seeds (at least 29 of 30)


ROWS = [
    Row("vannoy.example_ideal", "vannoy_ideal_example", "worst_ms", "Vannoy worked example, reflection times after the click, worst difference (ideal)", f"{VANNOY}: Table 1, reflections at 1.0556, 2.3628 and 2.8508 s after the click", "0 ms", 0, 1, "ms", 2),
    Row("vannoy.example", "vannoy_example", "worst_ms", "Vannoy worked example, reflection times after the click, worst difference", f"{VANNOY}: Table 1, reflections at 1.0556, 2.3628 and 2.8508 s after the click", "0 ms (timed to 0.1 ms)", 0, 1, "ms", 2),
    Row("bac.static_bad", "bac_static", "bad_percent", "Bac static: erroneous measurements, counted as Table 1 (bac-static, the measured point)", f'{BAC}: "the number of filtered errors varied between 1% and 3.7% of the total measurements"', "1-3.7 %", 1, 4, "%"),
    Row("bac.static_three", "bac_static", "three_percent", "Bac Table 1: correct measurements from three arrays at (1.16, 0.53) m", f"{BAC}: Table 1, 807 three-sensor measurements of 1444 correct", "56 %", 30, 80, "%"),
    Row("bac.static_std_x", "bac_static", "std_x_mm", "Bac Table 1: static std of x, the paper's method (ref:bac-seed) at (1.16, 0.53) m", f"{BAC}: Table 1, standard deviation 1.7 mm among correct measurements", "1.7 mm", 0.85, 3.4, "mm", 2),
    Row("bac.static_std_y", "bac_static", "std_y_mm", "Bac Table 1: static std of y, the paper's method (ref:bac-seed) at (1.16, 0.53) m", f"{BAC}: Table 1, standard deviation 1.7 mm among correct measurements", "1.7 mm", 0.85, 3.4, "mm", 2),
    Row("bac.line_std", "bac_line", "std_y_mm", "Bac fig. 7: straight 0.9 m line at 31 rad/s, std of the y deviation (ref:bac-seed)", f'{BAC}: "the deviations from the straight path had a standard deviation of 3.6 mm" (40 readings over 0.9 m)', "3.6 mm", 1.2, 10.8, "mm"),
    Row("asabe.drift", "asabe", "drift_mm", "ASABE: blind dead reckoning (ref:dead-reckoning) position RMS, set down exactly at its start", f'{BAC}: "this is no guarantee that the robot will follow a perfectly straight line"', "drifts", 100, 1500, "mm", 0),
    Row("bac.moving_merged", "asabe", "merged_percent", "ASABE: ref:bac's revolutions with a merged pulse while it drives the letters", f'{BAC}: "During the motion of the robot, erroneous measurements occurred ... in about 3.4% of all incoming measurements"', "3.4 %", 1.7, 6.8, "%"),
    Row("asabe.reached", "asabe", "reached", "Bac fig. 8: the 'ASABE' letters, ref:bac, waypoints reached of 33", f"{BAC}: \"the robot followed the 'ASABE' path reasonably well\"", "33 of 33", 33, 33, "", 0),
    Row("asabe.rms", "asabe", "rms_mm", "ASABE: ref:bac position RMS", "ours: the fused reference keeps its fix along the letters", "-", 0, 5, "mm"),
    Row("asabe.heading", "asabe", "heading_after_deg", "ASABE: ref:bac heading RMS once it has driven to learn it (after 5 s)", f'{BAC}: "the orientation was determined by evaluating two consecutive positions"', "-", 0, 10, "deg"),
    Row("asabe.ratio", "asabe", "ratio", "ASABE: laser (ref:bac) vs blind (ref:dead-reckoning from the announced start), position RMS ratio", f'{SIMI}: "As with any system that uses dead-reckoning, error will always accumulate over time"', "laser wins", 0, 1 / 3, "", 3),
    Row("race.worst", "asabe_race", "worst_mm", "asabe-race: four ref:bac robots blocking each other's beams, worst robot's position RMS", "ours: references keep their fix under occlusion", "-", 0, 60, "mm"),
    Row("race.median", "asabe_race", "median_mm", "asabe-race: the same, median robot's position RMS", "ours: references keep their fix under occlusion", "-", 0, 30, "mm"),
    Row("shared.finished", "shared_race", "finished", "asabe-race-shared: four ref:bac robots, every array latching every robot's pulse, seeds on which all reach every waypoint", f'{BAC}: "all 20 phototransistors in the array were placed in parallel" (ours: four robots on one table)', "-", 0.9, 1, "", 2),
    Row("shared.worst", "shared_race", "worst_mm", "asabe-race-shared: the same, worst robot's position RMS", "ours: references tell their own pulses from the others'", "-", 0, 60, "mm"),
    Row("shared.median", "shared_race", "median_mm", "asabe-race-shared: the same, median robot's position RMS", "ours: references tell their own pulses from the others'", "-", 0, 30, "mm"),
    Row("simi.start_x", "simi", "start_x", "Simi: the start's optical solution, told nothing, off the true start in x", f'{SIMI}: "a difference in values of 0.032 inches in the x-direction and 0.298 inches in the y-direction" (against a tape-measured start)', "0.032 in", 0, 0.6, "in", 3),
    Row("simi.start_y", "simi", "start_y", "Simi: the same in y", f'{SIMI}: "a difference in values of 0.032 inches in the x-direction and 0.298 inches in the y-direction"', "0.298 in", 0, 0.6, "in", 3),
    Row("simi.fixed", "simi", "fixed", "Simi: positions of Appendix F that get a fix, of 40", f"{SIMI}: Appendix F, 40 tile positions", "40 of 40", 40, 40, "", 0),
    Row("simi.rel_x", "simi", "rel_x", "Simi map: worst x error over the 40 positions, relative to the start's solution (the tiles laid out from it)", f'{SIMI}: "The maximum amount of difference between the tile values and the optical values was 0.188 inches in the x-direction and 0.259 inches in the y-direction"', "0.188 in", 0.13, 0.39, "in", 3),
    Row("simi.rel_y", "simi", "rel_y", "Simi map: the same in y", f'{SIMI}: "... 0.188 inches in the x-direction and 0.259 inches in the y-direction"', "0.259 in", 0.13, 0.39, "in", 3),
    Row("simi.abs_x", "simi", "abs_x", "Simi map: worst x error over the 40 positions, absolute (optical minus true)", f"{SIMI}: not measured (the thesis had no truth but the tiles)", "-", 0, 0.39, "in", 3),
    Row("simi.abs_y", "simi", "abs_y", "Simi map: the same in y", f"{SIMI}: not measured", "-", 0, 0.39, "in", 3),
    Row("simi.heading", "simi", "heading", "Simi: worst heading error, 5 positions turned by +-45 and +-90 deg, against the start's solution and the nominal turn", f'{SIMI}: "The maximum error was found to be 0.8 degrees"', "0.8 deg", 0.27, 2.4, "deg", 2),
    Row("simi.heading_abs", "simi", "heading_abs", "Simi: worst heading error of the same turns, absolute (optical minus true)", f"{SIMI}: not measured (the turns were the hand's)", "-", 0, 0.8, "deg", 2),
    Row("vannoy.reached", "vannoy_start", "reached", "vannoy: ref:vannoy from a start anywhere in the level's region, seeds on which it reaches the charger", f'{VANNOY}: "Point R represents the exact position of the robot, which is unknown in the beginning"', "-", 29 / 30, 1, "", 2, 30),
    Row("vannoy.rms", "vannoy_start", "rms_mm", "vannoy: ref:vannoy from a start anywhere in the region, position RMS", f"{VANNOY}: (no figure; ours)", "-", 0, 100, "mm", 1, 30),
    Row("ubersetzig.reached", "ubersetzig_start", "reached", "ubersetzig: ref:ubersetzig from a start anywhere in the level's region, seeds on which it reaches the goal", f'{UBERSETZIG}: the robot is localized from one scan anywhere in "0 < rx < 127, -127 < ry < +127"', "-", 29 / 30, 1, "", 2, 30),
    Row("ubersetzig.rms", "ubersetzig_start", "rms_mm", "ubersetzig: ref:ubersetzig from a start anywhere in the region, position RMS", f'{UBERSETZIG}: "Accuracy is plus or minus a few inches within a typical room"', "a few inches: 25-100 mm", 0, 100, "mm", 1, 30),
    Row("osentoski.rms", "osentoski", "rms_mm", "osentoski: ref:osentoski over six trials anywhere in front of the lights, position RMS", f"{OSENTOSKI}: no figure published; the level's position scale is one 3-degree sample at 1.2 m", "-", 0, 63, "mm"),
    *(
        Row(f"ideal.{name}", f"ideal_{name}", "max_mm", f"--ideal: {name}, the default reference's worst position error from its first event on", "ours: perfect hardware, exact method", "-", 0, 5, "mm", 2)
        for name in SEED_LEVELS
    ),
]  # fmt: skip
# a share row's figure is 1 or 0 per seed: it passes on the mean, not the median
SHARES = {"vannoy.reached", "ubersetzig.reached", "shared.finished"}


def percentile(values: list[float], q: float) -> float:
    """The q-quantile of the values (linear between order statistics)."""
    ordered = sorted(values)
    pos = q * (len(ordered) - 1)
    lo, hi = math.floor(pos), math.ceil(pos)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (pos - lo)


@dataclass(frozen=True)
class Outcome:
    """A row's figure over the seeds."""

    row: Row
    values: list[float]

    @property
    def centre(self) -> float:
        return statistics.fmean(self.values) if self.row.key in SHARES else statistics.median(self.values)

    @property
    def ok(self) -> bool:
        return self.row.low - 1e-9 <= self.centre <= self.row.high + 1e-9

    @property
    def outside(self) -> int:
        if self.row.key in SHARES:
            return sum(v < 1 for v in self.values)
        return sum(not self.row.low - 1e-9 <= v <= self.row.high + 1e-9 for v in self.values)

    def shown(self) -> str:
        d, unit = self.row.digits, f" {self.row.unit}" if self.row.unit else ""
        if self.row.key in SHARES:
            return f"{sum(self.values):.0f} of {len(self.values)} seeds"
        return (
            f"{self.centre:.{d}f}{unit} ({percentile(self.values, 0.05):.{d}f} to "
            f"{percentile(self.values, 0.95):.{d}f})"
        )

    def band(self) -> str:
        unit = f" {self.row.unit}" if self.row.unit else ""
        if self.row.key in SHARES:
            return f"at least {self.row.low:.0%} of seeds"
        if self.row.low == self.row.high:
            return f"{self.row.low:g}{unit}"
        return f"{self.row.low:g}-{self.row.high:g}{unit}" if self.row.low > 0 else f"< {self.row.high:g}{unit}"


# ---- sensitivity: what the figures become at half and twice a parameter of ours ----------------


@dataclass(frozen=True)
class Sensitive:
    """A model parameter no seed gives (its level comment says "ours"), and the figure it moves."""

    level: str
    key: str  # dotted key in the level's data
    row: str  # the row whose figure it moves most


SENSITIVE = [
    Sensitive("bac-static", "beacons.params.timing_noise", "bac.static_std_x"),
    Sensitive("bac-static", "beacons.params.wobble", "bac.static_std_x"),
    Sensitive("bac-static", "beacons.params.rise_time", "bac.static_three"),
    Sensitive("bac-static", "beacons.params.trigger_fraction", "bac.static_three"),
    Sensitive("bac-static", "beacons.params.beam_diameter", "bac.static_three"),
    Sensitive("bac-static", "beacons.params.beam_divergence", "bac.static_three"),
    Sensitive("bac-static", "beacons.params.light_noise", "bac.static_three"),
    Sensitive("bac-static", "beacons.items.3.gain", "bac.static_three"),
    Sensitive("bac-static", "beacons.params.merge_rate", "bac.static_bad"),
    Sensitive("bac-static", "beacons.params.false_rate", "bac.static_bad"),
    Sensitive("asabe", "beacons.params.acceptance", "asabe.rms"),
    Sensitive("asabe", "beacons.params.merge_rate", "bac.moving_merged"),
    Sensitive("asabe", "beacons.params.spin_time", "asabe.rms"),
    Sensitive("simi", "beacons.params.light_noise", "simi.rel_y"),
    Sensitive("simi", "beacons.params.trigger_fraction", "simi.rel_y"),
    Sensitive("simi", "beacons.params.beam_divergence", "simi.rel_y"),
    Sensitive("simi", "floor.tilt", "simi.rel_y"),
    Sensitive("simi", "floor.tilt_length", "simi.rel_y"),
    Sensitive("simi", "laser.height", "simi.rel_y"),
    Sensitive("simi", "floor.tiles.spacing_error", "simi.rel_y"),
    Sensitive("simi", "floor.tiles.angle_error", "simi.rel_y"),
    Sensitive("simi", "robots.0.placement.heading", "simi.heading"),
    Sensitive("vannoy", "beacons.params.timing_noise", "vannoy.example"),
    Sensitive("vannoy", "beacons.params.wobble", "vannoy.example"),
    Sensitive("vannoy", "beacons.params.max_incidence", "vannoy.rms"),
    Sensitive("vannoy", "beacons.params.false_rate", "vannoy.rms"),
    Sensitive("ubersetzig", "beacons.params.max_incidence", "ubersetzig.rms"),
    Sensitive("osentoski", "beacons.params.beam_width", "osentoski.rms"),
    Sensitive("osentoski", "beacons.params.brightness_noise", "osentoski.rms"),
    Sensitive("osentoski", "beacons.params.servo_jitter", "osentoski.rms"),
    Sensitive("osentoski", "beacons.params.saturation_range", "osentoski.rms"),
    *(
        Sensitive("asabe", f"robots.0.drive.{key}", "asabe.drift")
        for key in ("gain_sd", "radius_sd", "track_sd", "dead_band", "saturation", "turn_slip", "turn_slip_sd", "accel_slip", "latency", "latency_jitter")
    ),
]  # fmt: skip
FACTORS = (0.5, 2.0)


def sensitivity_jobs(seeds: int) -> list[tuple[str, int, Scale]]:
    """A run of each sensitive parameter's row experiment at half and at twice its value."""
    jobs = []
    for s in SENSITIVE:
        experiment = next(r.experiment for r in ROWS if r.key == s.row)
        for factor in FACTORS:
            scale = ((s.key, factor),)
            jobs += [(experiment, seed, scale) for seed in range(1, seeds + 1)]
    return jobs


def level_parameters() -> list[tuple[str, str, str, str]]:
    """Every hardware parameter the built-in levels set, with the comment its level file gives it
    (its source sentence, or "ours" and why): (level, key, value, comment)."""
    out = []
    for name in levels.names():
        lines = levels.path(name).read_text().splitlines()
        section = ""
        for i, line in enumerate(lines):
            stripped = line.strip()
            if line and not line[0].isspace():
                section = stripped.split(":")[0]
            if section not in ("beacons", "laser") or ":" not in stripped or stripped.startswith(("#", "-", "{")):
                continue
            key, _, rest = stripped.partition(":")
            value, _, comment = rest.partition("#")
            if not value.strip() or key in ("kind", "items", "params", "radius", "crosstalk"):
                continue
            out.append((name, key, value.strip(), " ".join([comment.strip(), *_continued(lines, i)]).strip()))
    return out


def _continued(lines: list[str], i: int) -> list[str]:
    """The comment lines that carry on line i's comment: comment-only lines below it whose `#`
    stands at least as far right as line i's."""
    if "#" not in lines[i]:
        return []
    column, more = lines[i].index("#"), []
    for follow in lines[i + 1 :]:
        if not follow.strip().startswith("#") or follow.index("#") < column:
            break
        more.append(follow.strip().lstrip("# "))
    return more


# ---- the report --------------------------------------------------------------------------------


def markdown(outcomes: list[Outcome], seeds: int, seconds: float, sensitivity: dict, s_seeds: int) -> str:
    lines = [
        "# Fidelity: the seeds' figures beside LaserArena's",
        "",
        "Made by `make fidelity` (`python benchmarks/fidelity.py`): each seed's experiment re-run on its",
        f"built-in level with the default hardware error over seeds 1-{seeds}, in {seconds:.0f} s. Do not edit by",
        "hand: run it again. LaserArena's figure is the median over the seeds with the 5-95 % range of",
        "the seeds in brackets (a share of seeds where the row counts them); a row passes when its",
        "median lies in the band, and *outside* counts the seeds that did not. An experiment the seed",
        "made at one pose sets the robot down exactly there; the level's own matches draw the start",
        "within its spread (docs/levels.md). How the references fare against blind driving and not",
        "sensing at all, level by level: docs/baselines.md. The figures are also in docs/fidelity.json.",
        "",
        "| experiment | source | published | LaserArena | band | outside | pass |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        r = o.row
        lines.append(
            f"| `{r.key}`: {r.title} | {r.source} | {r.published} | {o.shown()} | {o.band()} | "
            f"{o.outside} of {len(o.values)} | {'yes' if o.ok else '**no**'} |"
        )
    lines += [
        "",
        "## Sensitivity: the parameters no seed gives",
        "",
        'Each parameter whose level comment says "ours" (the list below gives the reason for its',
        f"value), halved and doubled, and the median over seeds 1-{s_seeds} of the figure it moves most",
        '(the row of the table above named by its key; "as set" is that row\'s median).',
        "",
        "| level | parameter | value | figure | at half | as set | at twice |",
        "|---|---|---|---|---|---|---|",
    ]
    by_row = {o.row.key: o for o in outcomes}
    for s in SENSITIVE:
        o = by_row[s.row]
        value: Any = level_data(s.level, ((s.key, 1.0),), experiment=True)
        for part in s.key.split("."):
            value = value[int(part)] if isinstance(value, list) else value[part]
        d = o.row.digits
        half, twice = (sensitivity[(s.key, s.level, f)] for f in FACTORS)
        lines.append(
            f"| {markdown_text(s.level)} | `{s.key.rsplit('.', 1)[-1]}` | {value:g} | `{o.row.key}` ({o.row.unit or 'value'}) | "
            f"{half:.{d}f} | {o.centre:.{d}f} | {twice:.{d}f} |"
        )
    lines += [
        "",
        "## Every hardware parameter of the built-in levels, and where it comes from",
        "",
        "Read from the level files (the comment beside each value); the drive's parameters are in",
        "docs/drive.md, each robot's start and its spread in docs/levels.md.",
        "",
        "| level | parameter | value | source, or why ours |",
        "|---|---|---|---|",
    ]
    for name, key, value, comment in level_parameters():
        lines.append(f"| {markdown_text(name)} | `{key}` | {markdown_text(value)} | {markdown_text(comment, 1000)} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="seeds 1..N of every row (default 20)")
    ap.add_argument("--sensitivity-seeds", type=int, default=5, help="seeds of each sensitivity run (default 5)")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "fidelity.md"))
    ap.add_argument("--json", default=str(ROOT / "docs" / "fidelity.json"))
    ap.add_argument("--strict", action="store_true", help="exit 1 if a row fails its band")
    args = ap.parse_args(argv)
    if min(args.seeds, args.workers, args.sensitivity_seeds) < 1:
        ap.error("--seeds, --sensitivity-seeds and --workers must be at least 1")
    start = time.perf_counter()
    seeds_of: dict[str, int] = {}
    for r in ROWS:
        seeds_of[r.experiment] = max(seeds_of.get(r.experiment, 1), r.seeds or args.seeds)
    jobs = [(e, seed, ()) for e, n in sorted(seeds_of.items()) for seed in range(1, n + 1)]
    jobs += sensitivity_jobs(args.sensitivity_seeds)
    figures: dict[tuple[str, int, Scale], dict[str, float]] = {}
    with ProcessPoolExecutor(args.workers) as pool:
        for job, result in pool.map(_run, jobs, chunksize=1):
            figures[job] = result
    outcomes = []
    for row in ROWS:
        o = Outcome(
            row, [figures[(row.experiment, seed, ())][row.figure] for seed in range(1, (row.seeds or args.seeds) + 1)]
        )
        outcomes.append(o)
        print(
            f"{'pass' if o.ok else 'FAIL'}  {row.title}: {o.shown()}  (published {row.published}; band {o.band()}; "
            f"outside {o.outside} of {len(o.values)})",
            flush=True,
        )
    sensitivity = {}
    for s in SENSITIVE:
        row = next(r for r in ROWS if r.key == s.row)
        for factor in FACTORS:
            scale = ((s.key, factor),)
            values = [
                figures[(row.experiment, seed, scale)][row.figure] for seed in range(1, args.sensitivity_seeds + 1)
            ]
            sensitivity[(s.key, s.level, factor)] = statistics.median(values)
    seconds = time.perf_counter() - start
    Path(args.out).write_text(
        markdown(outcomes, args.seeds, seconds, sensitivity, args.sensitivity_seeds), encoding="utf-8"
    )
    report = {
        o.row.key: {"median": o.centre, "p5": percentile(o.values, 0.05), "p95": percentile(o.values, 0.95), "ok": o.ok, "outside": o.outside, "seeds": len(o.values)}
        for o in outcomes
    }  # fmt: skip
    Path(args.json).write_text(json.dumps(report, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    if Path(args.json) == quoted.REPORTS["f"]:  # the committed report: the docs quote it
        quoted.requote_pages("f", report)
    failed = sum(not o.ok for o in outcomes)
    print(f"{len(outcomes) - failed} of {len(outcomes)} rows within their band in {seconds:.0f} s; wrote {args.out}")
    return 1 if args.strict and failed else 0


if __name__ == "__main__":
    sys.exit(main())
