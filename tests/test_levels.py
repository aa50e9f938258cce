"""The built-in levels hold the seeds' dimensions and layouts, and each one runs."""

import json
import math
import pickle
from types import MappingProxyType

import pytest
from helpers import run_cli

import levels
from levels.loader import load_level

FT, IN = 0.3048, 0.0254
ALL = [
    "asabe",
    "asabe-race",
    "asabe-race-shared",
    "bac-line",
    "bac-static",
    "osentoski",
    "simi",
    "ubersetzig",
    "vannoy",
]


def flat(points):
    """[(x, y), ...] as [x, y, ...] for pytest.approx, which does not nest."""
    return [v for p in points for v in p]


def load(name):
    return load_level(levels.path(name))


def test_nine_builtin_levels_listed_with_default_controller():
    assert levels.names() == ALL
    proc = run_cli("levels")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert [line.split()[0] for line in lines] == ALL
    for line in lines:
        assert "default ref:" in line


def test_vannoy_field_and_worked_example_timings():
    lv = load("vannoy")
    assert lv.field.size == pytest.approx((13 * FT, 21 * FT))
    assert [b.id for b in lv.beacons.items] == ["A", "B", "C"]
    assert flat((b.x, b.y) for b in lv.beacons.items) == pytest.approx(
        flat([(0, 21 * FT), (13 * FT, 21 * FT), (13 * FT, 0)])
    )
    r = lv.robots[0]
    assert (r.start.x, r.start.y) == pytest.approx((8 * FT, 5 * FT))
    assert math.degrees(r.start.heading) == pytest.approx(220)  # compass 230 deg
    assert r.laser.period == pytest.approx(4.0) and r.laser.angular_velocity > 0 and r.laser.index
    # Seed table 1: reflections 1.0556, 2.3628, 2.8508 s after the click, computed here from
    # the level's own numbers with plain trigonometry.
    times = sorted(
        ((math.atan2(b.y - r.start.y, b.x - r.start.x) - r.start.heading) % (2 * math.pi)) / r.laser.angular_velocity
        for b in lv.beacons.items
    )
    assert times == pytest.approx([1.0556, 2.3628, 2.8508], abs=2e-4)
    assert lv.beacons.params["range"] == pytest.approx(25 * FT)
    assert (lv.task.goal.x, lv.task.goal.y) == pytest.approx((1 * FT, 10.5 * FT))


def test_ubersetzig_targets_on_one_wall():
    lv = load("ubersetzig")
    assert flat((b.x, b.y) for b in lv.beacons.items) == pytest.approx(flat([(0, -48 * IN), (0, 0), (0, 48 * IN)]))
    assert (lv.field.xmin, lv.field.xmax, lv.field.ymin, lv.field.ymax) == pytest.approx(
        (0, 127 * IN, -127 * IN, 127 * IN)
    )
    # the head's 200 raw steps, which the seed's code turns into 256 BAMs: "hit(hit_index) * 64 / 50"
    assert lv.beacons.params["quantization"] == 200 and lv.beacons.params["false_rate"] == 0


@pytest.mark.parametrize("name", ["asabe", "bac-static", "bac-line", "asabe-race", "asabe-race-shared"])
def test_bac_table_four_corner_arrays(name):
    lv = load(name)
    assert lv.field.size == pytest.approx((1.83, 1.22))
    assert lv.beacons.kind == "sensor_array" and not lv.robots[0].laser.index
    assert flat(sorted((b.x, b.y) for b in lv.beacons.items)) == pytest.approx(
        flat(sorted([(0, 0), (1.83, 0), (1.83, 1.22), (0, 1.22)]))
    )
    for b in lv.beacons.items:  # each array faces the table centre
        assert b.facing == pytest.approx(math.atan2(0.61 - b.y, 0.915 - b.x))


def test_asabe_path_33_waypoints_in_box_from_start():
    lv = load("asabe")
    path = lv.robots[0].path
    assert len(path) == 33
    assert path[0] == pytest.approx((0.56, 0.35))
    xs, ys = [p[0] for p in path], [p[1] for p in path]
    assert max(xs) - min(xs) == pytest.approx(1.2) and max(ys) - min(ys) == pytest.approx(0.6)
    assert (min(xs), min(ys)) == pytest.approx((0.56, 0.35))
    assert (lv.robots[0].start.x, lv.robots[0].start.y) == pytest.approx((0.56, 0.35))
    assert lv.task.radius == pytest.approx(0.05) and lv.robots[0].laser.angular_velocity == 81
    assert load("bac-line").task.radius == pytest.approx(0.03)
    assert load("bac-line").robots[0].laser.angular_velocity == 31


def test_bac_static_true_position():
    r = load("bac-static").robots[0]
    assert (r.start.x, r.start.y) == pytest.approx((1.16, 0.53))
    assert (r.model.length, r.model.width) == pytest.approx((0.105, 0.095))


def test_simi_equilateral_triangle():
    lv = load("simi")
    pts = [(b.x, b.y) for b in lv.beacons.items]
    assert flat(pts) == pytest.approx(
        flat([(129.75 * IN, -10 * IN), (10 * IN, -10 * IN), (69.875 * IN, -113.7065 * IN)])
    )
    for i in range(3):
        assert math.dist(pts[i], pts[(i + 1) % 3]) == pytest.approx(119.75 * IN, rel=1e-5)
    assert lv.robots[0].laser.angular_velocity == pytest.approx(1800 / 60 * 2 * math.pi)
    assert lv.beacons.params["counts_per_turn"] == 12500


def test_osentoski_three_lights_in_a_line_equally_spaced():
    lv = load("osentoski")
    (x0, y0), (x1, y1), (x2, y2) = [(b.x, b.y) for b in lv.beacons.items]
    assert y0 == y1 == y2 and x1 - x0 == pytest.approx(x2 - x1)
    assert lv.beacons.kind == "light" and lv.beacons.params["samples_per_turn"] == 120
    r = lv.robots[0]
    assert x0 < r.start.x < x2


def test_asabe_race_four_robots_own_paths():
    lv = load("asabe-race")
    assert len(lv.robots) == 4 and lv.task.kind == "race"
    assert len({r.path for r in lv.robots}) == 4


def test_asabe_race_shared_is_the_race_on_bacs_arrays():
    # the same race but for the crosstalk: Bac's arrays do not tell the lasers apart
    coded, shared = load("asabe-race"), load("asabe-race-shared")
    assert (coded.beacons.crosstalk, shared.beacons.crosstalk) == ("coded", "shared")
    assert shared.robots == coded.robots and shared.beacons.params == coded.beacons.params
    assert shared.beacons.items == coded.beacons.items and shared.task == coded.task


@pytest.mark.parametrize("name", ALL)
def test_a_level_pickles_whole_and_stays_read_only(name):
    """An async vector env's workers get their keywords pickled: a loaded Level goes as it is."""
    lv = load(name)
    data = pickle.dumps(lv)
    back = pickle.loads(data)
    assert pickle.dumps(back) == data and back.hash == lv.hash  # bytes: a goal's heading may be NaN, never equal
    assert isinstance(back.beacons.params, MappingProxyType) and isinstance(back.rules.penalties, MappingProxyType)


@pytest.mark.parametrize("name", ALL)
def test_each_level_runs_to_completion(name, tmp_path):
    out = tmp_path / "r.json"
    proc = run_cli("run", name, "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    lv = load(name)
    assert result["level"] == {"name": name, "hash": lv.hash}
    assert len(result["robots"]) == len(lv.robots)
    assert 0 < result["end_time"] <= lv.time_limit
    if result["end_reason"] == "time_limit":
        assert result["end_time"] == pytest.approx(lv.time_limit)
    assert all(not r["faults"] for r in result["robots"])
    assert name in proc.stdout and "slot" in proc.stdout
