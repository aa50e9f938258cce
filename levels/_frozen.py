"""Frozen level records whose read-only mappings travel through pickle as dicts."""

from __future__ import annotations

from dataclasses import fields
from types import MappingProxyType
from typing import Any


def with_proxies(cls: type, values: dict[str, Any]) -> Any:
    """An instance of the dataclass `cls` from its field values, each dict read-only again."""
    return cls(**{k: MappingProxyType(v) if isinstance(v, dict) else v for k, v in values.items()})


def reduce_proxies(self: Any) -> tuple:
    """Pickles a frozen dataclass whose read-only mappings (a mappingproxy does not pickle)
    travel as dicts: a Level goes whole to an async vector env's workers."""
    values = {f.name: getattr(self, f.name) for f in fields(self)}
    return with_proxies, (
        type(self),
        {k: dict(v) if isinstance(v, MappingProxyType) else v for k, v in values.items()},
    )
