"""Level checks beyond the schema, each on a level mutated as data (yaml.safe_load, change the
dict, dump): convex obstacles, start poses clear of obstacles, beacons and other robots,
enough beacons for a fix, a default controller that exists (found without running it),
nesting and size limits, and rate messages that blame the key that is really wrong."""

import math
import sys
from functools import partial

import pytest
import yaml
from helpers import MINI_LEVEL, run_cli

from levels.loader import LevelError
from levels.loader import load_level as load_bare
from referee.sandbox.teams import controller_problem, resolve

# as the referee loads a level: its default controller checked too
load_level = partial(load_bare, controllers=controller_problem)


def base() -> dict:
    return yaml.safe_load(MINI_LEVEL)


def write(tmp_path, data: dict, name: str = "level.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None))  # leaf lists inline
    return path


def key_lines(path, key: str) -> tuple[int, int]:
    """The lines of a dotted key and of where its value starts, found with PyYAML's own
    composer (independent of the loader); an error may name either."""
    node = yaml.compose(path.read_text())
    line = node.start_mark.line + 1
    for part in key.replace("[", ".[").split("."):
        if part.startswith("["):
            node = node.value[int(part[1:-1])]
            line = node.start_mark.line + 1
        else:
            knode, node = next((k, v) for k, v in node.value if k.value == part)
            line = knode.start_mark.line + 1
    return line, node.start_mark.line + 1


def error(path) -> LevelError:
    with pytest.raises(LevelError) as info:
        load_level(path)
    err = info.value
    assert "\n" not in str(err)
    where = f"{path}:{err.line}" if err.line else str(path)
    assert str(err).startswith(f"{where}: {err.key}: ")
    return err


def expect(tmp_path, data: dict, key: str, words: str) -> LevelError:
    path = write(tmp_path, data)
    err = error(path)
    assert err.key == key, str(err)
    assert err.line in key_lines(path, key), str(err)
    assert words in err.message, str(err)
    return err


def test_mini_level_passes_every_check(tmp_path):
    assert load_level(write(tmp_path, base())).name == "mini"


def test_beacon_outside_the_field(tmp_path):
    d = base()
    d["beacons"]["items"][1]["at"] = [2.5, 0]
    expect(tmp_path, d, "beacons.items[1].at", "outside the field")


def with_obstacle(obstacle: dict) -> dict:
    d = base()
    d["obstacles"] = [obstacle]
    return d


def test_concave_and_self_crossing_polygons_are_refused(tmp_path):
    dent = [[1.0, 0.2], [1.4, 0.2], [1.2, 0.4], [1.4, 0.6], [1.0, 0.6]]  # a notch at point 2
    expect(tmp_path, with_obstacle({"kind": "polygon", "points": dent}), "obstacles[0].points", "not convex")
    # a pentagram: every corner turns the same way, but the outline goes round twice
    star = [
        [1.2 + 0.2 * math.cos(math.radians(90 + 144 * k)), 0.5 + 0.2 * math.sin(math.radians(90 + 144 * k))]
        for k in range(5)
    ]
    expect(tmp_path, with_obstacle({"kind": "polygon", "points": star}), "obstacles[0].points", "crosses itself")
    flat = [[1.0, 0.2], [1.2, 0.2], [1.4, 0.2]]
    expect(tmp_path, with_obstacle({"kind": "polygon", "points": flat}), "obstacles[0].points", "no area")
    for order in (1, -1):  # a convex pentagon passes, either way round
        pentagon = [
            [1.2 + 0.2 * math.cos(order * 2 * math.pi * k / 5), 0.5 + 0.2 * math.sin(order * 2 * math.pi * k / 5)]
            for k in range(5)
        ]
        assert len(load_level(write(tmp_path, with_obstacle({"kind": "polygon", "points": pentagon}))).obstacles) == 1


def test_start_footprint_must_clear_obstacles(tmp_path):
    # the boe-bot is 105 x 95 mm; at (0.5, 0.5) heading 0 it spans x 0.4475..0.5525, y 0.4525..0.5475
    box = {"kind": "box", "center": [0.6035, 0.5], "size": [0.1, 0.1]}  # its left side at x = 0.5535
    assert load_level(write(tmp_path, with_obstacle(box)))
    d = with_obstacle(box)
    d["robots"][0]["start"] = [0.5, 0.5, 45]  # turned 45 deg the body reaches x = 0.5 + 0.0707
    expect(tmp_path, d, "robots[0].start", "overlaps obstacles[0]")
    near = {"kind": "circle", "center": [0.5, 0.58], "radius": 0.03}  # lowest point y = 0.55: clear
    assert load_level(write(tmp_path, with_obstacle(near)))
    touching = {"kind": "circle", "center": [0.5, 0.58], "radius": 0.04}  # lowest point y = 0.54
    expect(tmp_path, with_obstacle(touching), "robots[0].start", "overlaps obstacles[0]")


def test_start_footprint_must_clear_beacons_and_other_robots(tmp_path):
    d = base()
    d["beacons"]["items"].append({"id": "N", "at": [0.5, 0.56]})  # radius 0.02: lowest point 0.54 < 0.5475
    expect(tmp_path, d, "robots[0].start", "overlaps beacon N")
    d = base()
    d["robots"].append({"model": "boe-bot", "start": [0.59, 0.5, 90], "start_known": True})
    expect(tmp_path, d, "robots[1].start", "overlaps robot slot 0")  # 0.59 - 0.0475 < 0.5525
    d["robots"][1]["start"] = [0.61, 0.5, 90]  # 0.61 - 0.0475 = 0.5625: clear
    assert len(load_level(write(tmp_path, d)).robots) == 2


@pytest.mark.parametrize("kind", ["reflector", "sensor_array", "flash_detector", "light"])
def test_fewer_than_three_beacons(tmp_path, kind):
    d = base()
    d["beacons"]["kind"] = kind
    d["beacons"]["items"] = d["beacons"]["items"][:2]
    expect(tmp_path, d, "beacons.items", "needs at least 3")
    # the physics runs with two: text parsed without the level's folder (replays, sensor fixtures) passes
    from levels.loader import parse_level

    assert len(parse_level(yaml.safe_dump(d).encode(), "two.yaml").beacons.items) == 2
    d["beacons"]["items"].append({"id": "C", "at": [0, 1]})
    assert len(load_level(write(tmp_path, d)).beacons.items) == 3


def with_controller(spec: str) -> dict:
    d = base()
    d["default_controller"] = spec
    return d


HOSTILE = "open(__file__ + '.ran', 'w').close()\nraise SystemExit('this must never run')\n"


def test_default_controller_must_exist(tmp_path):
    expect(tmp_path, with_controller("ref:nobody"), "default_controller", "no reference controller 'nobody'")
    expect(tmp_path, with_controller("bots/missing.py"), "default_controller", "no such file")
    expect(tmp_path, with_controller("no_such_module_here:Bot"), "default_controller", "no importable module")
    expect(tmp_path, with_controller("no-such-installed-controller"), "default_controller", "entry point group")


def test_default_controller_file_is_found_beside_the_level_without_running_it(tmp_path, monkeypatch):
    (tmp_path / "bots").mkdir()
    team = tmp_path / "bots" / "team.py"
    team.write_text(HOSTILE)
    monkeypatch.chdir("/")  # relative to the level file, not to where the command runs
    level = load_level(write(tmp_path, with_controller("bots/team.py:Bot")))
    assert level.default_controller == f"{team}:Bot"
    assert not (tmp_path / "bots" / "team.py.ran").exists()


@pytest.mark.parametrize("tail", ["", ":Bot"])
def test_default_package_folder_is_found_beside_the_level_without_running_it(tmp_path, monkeypatch, tail):
    pkg = tmp_path / "bots" / "fleet"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(HOSTILE)
    monkeypatch.chdir("/")  # relative to the level file, as a FILE.py controller is
    level = load_level(write(tmp_path, with_controller("bots/fleet" + tail)))
    assert level.default_controller == f"{pkg}{tail}"
    assert resolve(level.default_controller).files == (("fleet/__init__.py", HOSTILE.encode()),)
    assert not list(pkg.glob("*.ran"))


def test_default_module_is_found_without_running_its_package(tmp_path, monkeypatch):
    pkg = tmp_path / "lib" / "hostile_pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(HOSTILE)
    (pkg / "bot.py").write_text(HOSTILE)
    monkeypatch.syspath_prepend(str(tmp_path / "lib"))
    assert (
        load_level(write(tmp_path, with_controller("hostile_pkg.bot:Bot"))).default_controller == "hostile_pkg.bot:Bot"
    )
    expect(tmp_path, with_controller("hostile_pkg.nothere:Bot"), "default_controller", "no importable module")
    assert not list(pkg.glob("*.ran")) and "hostile_pkg" not in sys.modules


def test_deep_nesting_is_one_line_not_a_recursion_error(tmp_path):
    path = tmp_path / "deep.yaml"
    path.write_text("name: " + "[" * 20000 + "]" * 20000 + "\n")
    err = error(path)
    assert (err.key, err.line) == ("(yaml)", 1) and "nested deeper than" in err.message
    d = base()
    nested: dict = {"x": 1}
    for _ in range(20):
        nested = {"x": nested}
    d["description"] = nested
    path = write(tmp_path, d)
    assert "nested deeper than" in error(path).message
    proc = run_cli("check", str(tmp_path / "deep.yaml"))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_aliases_are_refused_where_they_are_used(tmp_path):
    """A few lines of nested aliases would expand to 9^7 values; a self-containing alias would
    recurse for ever: both are one line naming the line of the first alias."""
    lines = ['a: &a ["x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    for prev, name in zip("abcdef", "bcdefg"):
        lines.append(f"{name}: &{name} [{', '.join([f'*{prev}'] * 9)}]")
    path = tmp_path / "laughs.yaml"
    path.write_text("\n".join(lines) + "\n")
    err = error(path)
    assert (err.key, err.line) == ("(yaml)", 2) and "aliases (*a)" in err.message
    path.write_text("name: mini\nloop: &a [1, *a]\n")  # a value that contains itself
    err = error(path)
    assert (err.key, err.line) == ("(yaml)", 2) and "aliases" in err.message


def test_too_many_values_are_refused(tmp_path):
    path = tmp_path / "wide.yaml"
    path.write_text("name: wide\nitems: [" + ", ".join(["1"] * 200_001) + "]\n")
    err = error(path)
    assert err.key == "(yaml)" and "more than 200000 values" in err.message


def test_oversized_file_is_refused(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text(MINI_LEVEL + ("# padding padding padding\n" * 50000))
    err = error(path)
    assert err.key == "(file)" and "at most" in err.message


def test_rate_messages_name_the_key_that_is_wrong(tmp_path):
    d = base()
    d["physics_rate"], d["control_period"] = 250, 0.2
    err = expect(tmp_path, d, "physics_rate", "not a multiple of the default record_rate 30")
    assert "25" in err.message  # the hint names a divisor of 250 that would do
    d["record_rate"] = 30
    expect(tmp_path, d, "record_rate", "must be positive and divide physics_rate 250")
    d["record_rate"] = 25
    lv = load_level(write(tmp_path, d))
    assert (lv.physics_rate, lv.record_rate, lv.steps_per_control) == (250, 25, 50)


def test_the_physical_world_leaves_controllers_to_the_referee(tmp_path):
    # arena's loader knows nothing of teams: without the referee's check any name passes
    path = write(tmp_path, with_controller("ref:nobody"))
    assert load_bare(path).default_controller == "ref:nobody"
    assert error(path).key == "default_controller"
