"""Every hostile test runs in a kernel sandbox (failing, not skipping, where none can be made)
and ends with no controller process alive, nothing of theirs left in /tmp and nothing of the
referee's left in its temporary folder. Each runs `alone` (`make test`'s second pass): most load
the machine on purpose, with tight limits, and time an honest neighbour or count what is left."""

import tempfile
from pathlib import Path

import pytest

from hostile.hostile_kit import assert_nothing_left, sandbox_missing, tmp_entries

HERE = Path(__file__).resolve().parent


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if HERE in item.path.resolve().parents:
            item.add_marker(pytest.mark.alone)


@pytest.fixture(autouse=True)
def contained(tmp_path, monkeypatch):
    reason = sandbox_missing()
    assert reason is None, f"no kernel sandbox here: {reason} (install bubblewrap: apt-get install bubblewrap)"
    before = tmp_entries()
    scratch = tmp_path / "referee-tmp"  # whatever the referee puts in a temporary folder lands here
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    yield
    assert_nothing_left(before)
    assert list(scratch.iterdir()) == []
