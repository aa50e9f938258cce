"""The level: its model (`model`, `match`), its YAML reading (`loader`), checks and schema, and
the built-in levels, shipped as package data so a non-editable install finds them.

The bottom of the product: it imports nothing of `arena`, `robots` or `referee`.
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
