"""Helpers the tests share (fixtures stay in conftest.py): a small level, level variants built
from parsed data, and running the command line as a user would."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import yaml

import levels
from arena.level import Level
from arena.loader import parse_level

# A small valid level; tests derive variants of it with `variant`.
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


def edited(source: str, changes: dict[str, Any]) -> str:
    """Level YAML text with `changes` applied to its parsed data. `source` is level text or a
    built-in level's name; a key is a dotted path (`robots.0.start`, `beacons.crosstalk`), a
    value of None deletes the key. The text is dumped back, so the loader validates it as a file."""
    text = levels.path(source).read_text() if "\n" not in source else source
    data = yaml.safe_load(text)
    for path, value in changes.items():
        *parents, last = path.split(".")
        node = data
        for part in parents:
            node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
        key: Any = int(last) if isinstance(node, list) else last
        if value is None:
            del node[key]
        else:
            node[key] = value
    return yaml.safe_dump(data, sort_keys=False)


def variant(source: str, name: str = "variant.yaml", **changes: Any) -> Level:
    """A parsed level: `source` (text or built-in name) with `changes` (dotted keys written with
    `__` for the dots: `robots__0__start=[1, 2, 0]`)."""
    text = edited(source, {k.replace("__", "."): v for k, v in changes.items()})
    return parse_level(text.encode(), name)


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run `python -m referee ARGS` as a separate process, as a user would."""
    return subprocess.run([sys.executable, "-m", "referee", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)
