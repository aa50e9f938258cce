"""Resolve a team spec from the command line into a controller factory.

A spec is `ref:NAME` (a reference controller), `path/team.py` or `path/team.py:Class`
(a file), or `package.module:Class` (anything importable).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from referee.errors import UserError
from robots.api import Controller
from robots.controllers import REFERENCE


@dataclass(frozen=True)
class Team:
    """A resolved team: a machine-independent `label` and a way to make its controller."""

    label: str
    factory: Callable[[], Controller]


def resolve(spec: str) -> Team:
    """Turn a team spec into a `Team`; raise `UserError` (one line) if it cannot be loaded."""
    if spec.startswith("ref:"):
        name = spec[4:]
        if name not in REFERENCE:
            raise UserError(f"team {spec}: no reference controller {name!r} "
                            f"(have: {', '.join(sorted(REFERENCE))})")
        return Team(spec, _class_from_module(REFERENCE[name], spec))
    path_part, _, cls = spec.partition(":") if ".py:" in spec or spec.endswith(".py") else ("", "", "")
    if path_part:
        return Team(f"{Path(path_part).name}{':' + cls if cls else ''}", _class_from_file(Path(path_part), cls, spec))
    if ":" not in spec:
        raise UserError(f"team {spec}: expected ref:NAME, FILE.py[:Class] or module:Class")
    return Team(spec, _class_from_module(spec, spec))


def _class_from_module(target: str, spec: str) -> Callable[[], Controller]:
    module_name, _, cls = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except Exception as e:  # the team's import failed: report it in one line
        raise UserError(f"team {spec}: cannot import {module_name}: {type(e).__name__}: {e}") from None
    return _pick(module, cls, spec)


def _class_from_file(path: Path, cls: str, spec: str) -> Callable[[], Controller]:
    if not path.is_file():
        raise UserError(f"team {spec}: no such file {path}")
    digest = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
    name = f"laserarena_team_{path.stem}_{digest}"
    module_spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module
    try:
        module_spec.loader.exec_module(module)
    except Exception as e:
        del sys.modules[name]
        raise UserError(f"team {spec}: {path.name} failed to load: {type(e).__name__}: {e}") from None
    return _pick(module, cls, spec)


def _pick(module: object, cls: str, spec: str) -> Callable[[], Controller]:
    if cls:
        found = getattr(module, cls, None)
        if not (inspect.isclass(found) and issubclass(found, Controller)):
            raise UserError(f"team {spec}: {cls} is not a Controller class in {module.__name__}")
        return found
    own = [c for _, c in inspect.getmembers(module, inspect.isclass)
           if issubclass(c, Controller) and c is not Controller and c.__module__ == module.__name__]
    if len(own) != 1:
        names = ", ".join(c.__name__ for c in own) or "none"
        raise UserError(f"team {spec}: name the class as FILE.py:Class "
                        f"(found {len(own)} Controller classes: {names})")
    return own[0]
