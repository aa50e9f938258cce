"""Canonical JSON for results and replays: same data, same bytes, on any machine."""

from __future__ import annotations

import json
import math
from typing import Any

import msgspec

DECIMALS = 9  # nanometres, nanoradians, nanoseconds: far below any simulated effect


def tidy(obj: Any) -> Any:
    """Round floats to DECIMALS places, turn non-finite floats into None, tuples into lists."""
    if isinstance(obj, msgspec.Struct):  # a typed record: its plain data
        return tidy(msgspec.to_builtins(obj))
    if isinstance(obj, float):
        return round(obj, DECIMALS) if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: tidy(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [tidy(v) for v in obj]
    return obj


def dumps(obj: Any, indent: int | None = 2) -> str:
    """Canonical JSON text: tidied numbers, sorted keys."""
    separators = (",", ": ") if indent else (",", ":")
    return json.dumps(tidy(obj), sort_keys=True, indent=indent, separators=separators, allow_nan=False)
