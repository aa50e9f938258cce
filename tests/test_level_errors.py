"""Every kind of bad level file gives exit 2 and one line naming the file, the line and the key."""

import pytest
from helpers import MINI_LEVEL, run_cli

from levels.loader import LevelError, parse_level


def line_of(text: str, needle: str) -> int:
    """1-based line number of the first line containing `needle`."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


CASES = [
    # (case id, replace this, with this, key named in the message, line marker in the new text)
    ("malformed", "  size: [2.0, 1.0]", "  size: [2.0, 1.0", "(yaml)", None),
    ("unknown key", "  walls_", "", "", None),  # placeholder, replaced below
    ("wrong type", "time_limit: 4", "time_limit: four", "time_limit", "time_limit:"),
    ("missing field", "time_limit: 4\n", "", "time_limit", None),
    ("negative size", "size: [2.0, 1.0]", "size: [-2.0, 1.0]", "field.size", "size:"),
    ("beacon outside", "{id: B, at: [2, 1]}", "{id: B, at: [2.5, 1]}", "beacons.items[2].at", "id: B"),
    ("start outside", "start: [0.5, 0.5, 0]", "start: [0.5, 1.5, 0]", "robots[0].start", "start:"),
    ("footprint outside", "start: [0.5, 0.5, 0]", "start: [0.03, 0.5, 0]", "robots[0].start", "start:"),
    (
        "non-multiple control period",
        "control_period: 0.05",
        "control_period: 0.013",
        "control_period",
        "control_period:",
    ),
    ("unknown unit", "units: m", "units: furlong", "units", "units:"),
    ("bad kind", "kind: sensor_array", "kind: sonar", "beacons.kind", "kind: sonar"),
    ("zero laser", "angular_velocity: 20.0", "angular_velocity: 0", "laser.angular_velocity", "angular_velocity"),
    ("duplicate beacon", "{id: B, at: [2, 1]}", "{id: A, at: [2, 1]}", "beacons.items[2].id", "{id: A, at: [2, 1]}"),
    ("waypoint outside", "[1.5, 0.5]]", "[2.5, 0.5]]", "task.path[1]", "path:"),
    ("zero gain", "{id: B, at: [2, 1]}", "{id: B, at: [2, 1], gain: 0}", "beacons.items[2].gain", "gain: 0"),
    (
        "gain of a reflector",
        "kind: sensor_array\n  items:\n    - {id: O, at: [0, 0]}\n    - {id: A, at: [2, 0]}\n    - {id: B, at: [2, 1]}",
        "kind: reflector\n  items:\n    - {id: O, at: [0, 0]}\n    - {id: A, at: [2, 0]}\n    - {id: B, at: [2, 1], gain: 0.5}",
        "beacons.items[2].gain",
        "gain: 0.5",
    ),
    (
        "unknown param",
        "  kind: sensor_array\n",
        "  kind: sensor_array\n  params: {bogus: 1}\n",
        "beacons.params.bogus",
        "bogus",
    ),
    ("not a mapping", "field:\n  size: [2.0, 1.0]", "field: 3", "field", "field: 3"),
    ("bool for number", "seed: 3", "seed: true", "seed", "seed:"),
    (
        "unknown drive key",
        "    start_known: true\n",
        "    start_known: true\n    drive: {gain: 0.1}\n",
        "robots[0].drive.gain",
        "drive:",
    ),
    (
        "negative drive error",
        "    start_known: true\n",
        "    start_known: true\n    drive: {gain_sd: -0.01}\n",
        "robots[0].drive.gain_sd",
        "drive:",
    ),
    (
        "slip of a whole turn",
        "    start_known: true\n",
        "    start_known: true\n    drive: {turn_slip: 1.5}\n",
        "robots[0].drive.turn_slip",
        "drive:",
    ),
    (
        "placement spread negative",
        "    start_known: true\n",
        "    start_known: true\n    placement: {position: -0.01}\n",
        "robots[0].placement.position",
        "placement:",
    ),
    (
        "placement heading past a half turn",
        "    start_known: true\n",
        "    start_known: true\n    placement: {heading: 270}\n",
        "robots[0].placement.heading",
        "placement:",
    ),
    (
        "placement region outside the field",
        "    start_known: true\n",
        "    start_known: true\n    placement: {region: [[0.2, 0.2], [2.5, 0.8]]}\n",
        "robots[0].placement.region",
        "placement:",
    ),
    (
        "placement region upside down",
        "    start_known: true\n",
        "    start_known: true\n    placement: {region: [[1.2, 0.2], [0.4, 0.8]]}\n",
        "robots[0].placement.region",
        "placement:",
    ),
    (
        "placement spread and region",
        "    start_known: true\n",
        "    start_known: true\n    placement: {position: 0.1, region: [[0.2, 0.2], [1.5, 0.8]]}\n",
        "robots[0].placement.region",
        "placement:",
    ),
    (
        "trials on a waypoint task",
        "  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  path: [[1.0, 0.5], [1.5, 0.5]]\n  trials: {count: 2, positions: [[1, 0.5]]}\n",
        "task.trials",
        "trials:",
    ),
    (
        "trials without poses",
        "  kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  kind: localize\n  trials: {count: 3}\n",
        "task.trials.positions",
        "trials:",
    ),
    (
        "no trial at all",
        "  kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  kind: localize\n  trials: {count: 0}\n",
        "task.trials.count",
        "trials:",
    ),
    (
        "trial position outside",
        "  kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  kind: localize\n  trials: {count: 3, positions: [[1.0, 0.5], [3.0, 0.5]]}\n",
        "task.trials.positions[1]",
        "trials:",
    ),
    (
        "more trials than control periods",
        "  kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  kind: localize\n  trials: {count: 81, positions: [[1.0, 0.5]]}\n",
        "task.trials.count",
        "trials:",
    ),
    (
        "tiles without trial positions",
        "default_controller:",
        "floor:\n  tiles: {origin: [1.0, 0.5]}\ndefault_controller:",
        "floor.tiles",
        "tiles:",
    ),
    (
        "a floor steeper than 45 degrees",
        "default_controller:",
        "floor: {tilt: 50}\ndefault_controller:",
        "floor.tilt",
        "floor:",
    ),
    (
        "tiles off square by 45 degrees",
        "  kind: waypoints\n  radius: 0.05\n  path: [[1.0, 0.5], [1.5, 0.5]]\n",
        "  kind: localize\n  trials: {count: 2, positions: [[1.0, 0.5]]}\n"
        "floor:\n  tiles: {origin: [0.5, 0.5], angle_error: 45}\n",
        "floor.tiles.angle_error",
        "tiles:",
    ),
    (
        "negative laser height",
        "angular_velocity: 20.0\n",
        "angular_velocity: 20.0\n  height: -0.1\n",
        "laser.height",
        "height:",
    ),
    (
        "zero position scale",
        "default_controller:",
        "rules: {position_scale: 0}\ndefault_controller:",
        "rules.position_scale",
        "rules:",
    ),
]


def variant(case):
    cid, old, new, key, marker = case
    if cid == "unknown key":
        text = MINI_LEVEL.replace("  size: [2.0, 1.0]", "  size: [2.0, 1.0]\n  wall: true")
        return text, "field.wall", line_of(text, "wall: true")
    assert old in MINI_LEVEL, cid
    text = MINI_LEVEL.replace(old, new, 1)
    if cid == "malformed":
        return text, key, None
    if cid == "missing field":
        return text, key, 1  # reported at the mapping that lacks it: the top level
    return text, key, line_of(text, marker)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_level_is_one_line_with_file_line_key(case, write_level):
    text, key, line = variant(case)
    path = write_level(text)
    with pytest.raises(LevelError) as info:
        parse_level(text.encode(), str(path))
    err = info.value
    assert err.key == key
    if line is not None:
        assert err.line == line
    msg = str(err)
    assert msg.startswith(f"{path}:{err.line}: {key}: ")
    assert "\n" not in msg


@pytest.mark.parametrize("case", [CASES[0], CASES[2], CASES[5], CASES[8]], ids=lambda c: c[0])
def test_cli_check_exits_2_without_traceback(case, write_level):
    text, key, line = variant(case)
    path = write_level(text)
    for command in ("check", "run"):
        proc = run_cli(command, str(path))
        assert proc.returncode == 2
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1, proc.stderr
        assert "Traceback" not in proc.stderr
        assert lines[0].startswith(f"laserarena: {path}:")
        assert f": {key}:" in lines[0]


def test_malformed_yaml_names_the_line(write_level):
    text = MINI_LEVEL.replace("  size: [2.0, 1.0]", "  size: [2.0, 1.0")
    with pytest.raises(LevelError) as info:
        parse_level(text.encode(), "x.yaml")
    # PyYAML notices the unclosed flow sequence at the next line or shortly after
    assert line_of(text, "size:") <= info.value.line <= line_of(text, "size:") + 3


def test_missing_file_and_empty_file(tmp_path, write_level):
    proc = run_cli("check", str(tmp_path / "nope.yaml"))
    assert proc.returncode == 2 and "nope.yaml" in proc.stderr and "Traceback" not in proc.stderr
    empty = write_level("", "empty.yaml")
    proc = run_cli("check", str(empty))
    assert proc.returncode == 2 and "empty.yaml:1:" in proc.stderr


def test_unknown_level_name_and_bad_team():
    proc = run_cli("run", "no-such-level")
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "no-such-level" in proc.stderr
    proc = run_cli("run", "asabe", "--team", "ref:nobody")
    assert proc.returncode == 2 and "ref:nobody" in proc.stderr and "Traceback" not in proc.stderr


def test_valid_mini_level_checks_ok(write_level):
    proc = run_cli("check", str(write_level(MINI_LEVEL)))
    assert proc.returncode == 0, proc.stderr
    assert "ok" in proc.stdout


def test_controller_limits_in_the_level(write_level):
    text = (
        MINI_LEVEL + "limits: {step_time: 0.02, step_deadline: 0.1, overage_bank: 1.5, max_skips: 2, memory_mb: 256}\n"
    )
    lv = parse_level(text.encode(), "x.yaml")
    assert (
        lv.limits.step_time,
        lv.limits.step_deadline,
        lv.limits.overage_bank,
        lv.limits.max_skips,
        lv.limits.memory,
    ) == (0.02, 0.1, 1.5, 2, 256 << 20)
    bad = MINI_LEVEL + "limits: {step_time: 0.2, step_deadline: 0.1}\n"
    with pytest.raises(LevelError) as info:
        parse_level(bad.encode(), "x.yaml")
    assert info.value.key == "limits.step_deadline" and info.value.line == line_of(bad, "limits:")


def test_a_read_error_survives_pickling():
    """One raised in a worker process (a pool job's level) reaches its caller as itself."""
    import pickle

    from levels.yaml_reader import ReadError

    e = pickle.loads(pickle.dumps(ReadError("lv.yaml", 7, "task.goal", "outside the field")))
    assert isinstance(e, ReadError) and str(e) == "lv.yaml:7: task.goal: outside the field"
