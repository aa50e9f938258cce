"""One team-spec grammar: every form a user may write, read from its text alone (no file is
looked at), as the referee and a controller's own process both read it."""

import pytest

from robots._host.loading import SpecKind, TeamSpec, is_file_spec, parse_spec


@pytest.mark.parametrize(
    "text, expected",
    [
        ("ref:bac", TeamSpec("ref:bac", SpecKind.REFERENCE, "bac")),
        ("team.py", TeamSpec("team.py", SpecKind.FILE, "team.py")),
        ("dir/team.py:Bot", TeamSpec("dir/team.py:Bot", SpecKind.FILE, "dir/team.py", "Bot", ":Bot")),
        ("/abs/team.py:", TeamSpec("/abs/team.py:", SpecKind.FILE, "/abs/team.py", "", ":")),
        ("fleet", TeamSpec("fleet", SpecKind.NAME, "fleet")),
        ("path/fleet:Bot", TeamSpec("path/fleet:Bot", SpecKind.MODULE, "path/fleet", "Bot", ":Bot")),
        ("path/fleet:", TeamSpec("path/fleet:", SpecKind.MODULE, "path/fleet", "", ":")),
        ("pkg.mod:Bot", TeamSpec("pkg.mod:Bot", SpecKind.MODULE, "pkg.mod", "Bot", ":Bot")),
    ],
)
def test_each_form_is_read_from_its_text(text, expected):
    assert parse_spec(text) == expected
    assert is_file_spec(text) == (expected.kind is SpecKind.FILE)


def test_a_module_named_like_python_is_not_a_file():
    assert parse_spec("python_tools:Bot").kind is SpecKind.MODULE  # ".py" only as a suffix or before ":"
