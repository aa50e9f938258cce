"""Every hostile test runs in a kernel sandbox (failing, not skipping, where none can be made)
and ends with no controller process alive, nothing of theirs left in /tmp and nothing of the
referee's left in its temporary folder."""

import tempfile

import pytest

from hostile.hostile_kit import assert_nothing_left, sandbox_missing, tmp_entries


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
