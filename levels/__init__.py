"""The level: its model, its YAML reading and checks, its schema, and the built-in levels.

- `model`: the level's frozen dataclasses; `match`: the referee's side of it (clocks,
  controller limits, rules).
- `loader` reads a level file (over `yaml_reader`, a section a private module: `_beacons`,
  `_geometry`, `_robots`, `_task`); `checks` refuses what cannot be played; `schema` and
  `schema_file`: its JSON Schema.
- `robot_models`, `units`, `errors` (the product's one error base); `_frozen`: frozen values.
- The built-in levels are package data (`names`, `path`), so a non-editable install finds them.

Imports: nothing of the product (the bottom).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path


def names() -> list[str]:
    """Names of the built-in levels, sorted."""
    return sorted(p.name[:-5] for p in resources.files(__name__).iterdir() if p.name.endswith(".yaml"))


def path(name: str) -> Path:
    """The file of built-in level `name` (raises KeyError if there is none)."""
    if name not in names():
        raise KeyError(name)
    return Path(str(resources.files(__name__).joinpath(f"{name}.yaml")))
