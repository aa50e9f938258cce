"""The YAML reading kit (levels/yaml_reader.py) on its own, and YAML aliases in a level: refused in
the one line docs/levels.md quotes, wherever they appear."""

from __future__ import annotations

import pytest
from helpers import MINI_LEVEL, run_cli

from levels import yaml_reader as yr
from levels.loader import LevelError, parse_level

# the template a base robot's fields would be shared from, were aliases allowed
ALIASED = MINI_LEVEL.replace("    start: [0.5, 0.5, 0]\n", "    start: &base [0.5, 0.5, 0]\n") + "extra: *base\n"


def test_an_alias_is_one_line_naming_the_file_the_line_and_the_alias(tmp_path):
    path = tmp_path / "aliased.yaml"
    path.write_text(ALIASED)
    line = ALIASED.splitlines().index("extra: *base") + 1
    expected = f"{path}:{line}: (yaml): aliases (*base) are not allowed in levels"
    with pytest.raises(LevelError) as e:
        parse_level(ALIASED.encode(), str(path))
    assert str(e.value) == expected
    proc = run_cli("check", str(path))
    assert proc.returncode == 2 and proc.stderr.strip().splitlines() == [f"laserarena: {expected}"], proc.stderr


def test_a_merge_key_is_an_alias_too():
    text = MINI_LEVEL.replace("laser:\n", "laser: &l\n") + "robots_laser: {<<: *l}\n"
    with pytest.raises(LevelError, match=r"aliases \(\*l\) are not allowed in levels"):
        parse_level(text.encode(), "merge.yaml")


def test_an_anchor_no_alias_uses_is_harmless():
    text = MINI_LEVEL.replace("    start: [0.5, 0.5, 0]\n", "    start: &base [0.5, 0.5, 0]\n")
    assert parse_level(text.encode(), "anchor.yaml").robots[0].start.x == 0.5


def test_the_kit_reads_any_yaml_file_with_lines_and_keys():
    ctx = yr.Context("settings.yaml")
    _, root = yr.compose(ctx, b"speed: 2\nsize: [1, 2]\nnested:\n  fast: true\n")
    top = yr.Map(ctx, root, "", ("speed", "size", "nested"))
    assert top.req("speed", yr.positive) == 2.0 and top.req("size", yr.size) == (1.0, 2.0)
    with pytest.raises(yr.ReadError) as e:
        top.sub("nested", ("off",))
    assert type(e.value) is yr.ReadError
    assert str(e.value) == "settings.yaml:4: nested.fast: unknown key (expected one of: off)"


def test_the_kit_raises_the_error_class_it_is_given():
    class SettingsError(yr.ReadError):
        pass

    ctx = yr.Context("settings.yaml", SettingsError)
    _, root = yr.compose(ctx, b"speed: -1\n")
    with pytest.raises(SettingsError, match=r"^settings.yaml:1: speed: must be positive, got -1$"):
        yr.Map(ctx, root, "", ("speed",)).req("speed", yr.positive)
    with pytest.raises(SettingsError, match=r"^settings.yaml:1: \(top\): the file is empty$"):
        yr.compose(ctx, b"")


def test_a_line_of_a_dotted_key_is_its_deepest_part_in_the_file():
    _, root = yr.compose(yr.Context("f.yaml"), b"a:\n  b:\n    - 1\n    - c: 2\n")
    assert yr.line_of(root, "a.b[1].c") == 4
    assert yr.line_of(root, "a.b[7]") == 2
    assert yr.line_of(root, "z") == 1
