"""Fixtures shared by the tests (helpers are in helpers.py). Everything runs headless."""

import os
from pathlib import Path

import pytest
from hypothesis import settings

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

# no wall-clock threshold in the suite: a property's first example may load or compile a kernel
settings.register_profile("laserarena", deadline=None)
settings.load_profile("laserarena")


# the modules whose tests take longest (an install, a cold compile, clusters, whole grading
# runs): started first, so that `make test`'s workers do not end waiting on one of them
SLOW_FIRST = ("test_quickstart.py", "test_warm.py", "test_cluster.py", "test_docs_run.py", "test_grade.py")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: item.path.name not in SLOW_FIRST)  # stable: each module keeps its order


@pytest.fixture
def write_level(tmp_path):
    """Write level text to a file and return its path."""

    def write(text: str, name: str = "level.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p

    return write


@pytest.fixture
def shared_dir():
    """A scratch folder any user may write: controllers run as `nobody` when tests run as root."""
    import shutil
    import tempfile

    d = Path(tempfile.mkdtemp(prefix="laserarena-test-", dir="/tmp"))
    d.chmod(0o777)
    yield d
    shutil.rmtree(d, ignore_errors=True)
