"""Resolve a team spec from the command line into a `Team` the match can run.

A spec is `ref:NAME` (a reference controller), `path/team.py` or `path/team.py:Class`
(a file), or `package.module:Class` (anything importable). It is loaded once here, so a bad
spec is a one-line error before the match starts.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from referee.errors import UserError
from robots.api import Controller
from robots.loading import LoadError, is_file_spec, load_class


@dataclass(frozen=True)
class Team:
    """A resolved team: a machine-independent `label`, a way to make its controller here
    (`factory`), and the `spec` a controller process loads it from (files made absolute)."""

    label: str
    factory: Callable[[], Controller]
    spec: str = ""


def resolve(spec: str) -> Team:
    """Turn a team spec into a `Team`; raise `UserError` (one line) if it cannot be loaded."""
    try:
        cls = load_class(spec)
    except LoadError as e:
        raise UserError(str(e)) from None
    if is_file_spec(spec):
        path, _, rest = spec.partition(".py")
        absolute = str(Path(path + ".py").resolve()) + rest
        return Team(Path(path + ".py").name + rest, cls, absolute)
    return Team(spec, cls, spec)
