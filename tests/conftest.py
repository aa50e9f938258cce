"""Shared test helpers. Everything runs headless."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

# A small valid level; tests write variants of it to exercise the loader.
MINI_LEVEL = """\
name: mini
description: a small test table
units: m
seed: 3
time_limit: 4
physics_rate: 240
control_period: 0.05
field:
  size: [2.0, 1.0]
beacons:
  kind: sensor_array
  items:
    - {id: O, at: [0, 0]}
    - {id: A, at: [2, 0]}
    - {id: B, at: [2, 1]}
laser:
  angular_velocity: 20.0
  index: false
robots:
  - model: boe-bot
    start: [0.5, 0.5, 0]
    start_known: true
task:
  kind: waypoints
  radius: 0.05
  path: [[1.0, 0.5], [1.5, 0.5]]
default_controller: ref:dead-reckoning
"""


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run `python -m referee ARGS` as a separate process, as a user would."""
    return subprocess.run([sys.executable, "-m", "referee", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


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
