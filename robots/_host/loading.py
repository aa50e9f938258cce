"""A team spec's grammar (`TeamSpec`, `parse_spec`) and finding the Controller class it names:
`ref:NAME`, `FILE.py[:Class]`, `DIR[:Class]` (a team folder), `module:Class`, or the NAME of
an installed package's controller (entry point group `laserarena.controllers`).

Lives in `robots` because the controller's own process uses it to load the team's code; the
referee reads specs with the same grammar (referee.sandbox.teams) without running any of it.
"""

from __future__ import annotations

import enum
import hashlib
import importlib
import importlib.util
import inspect
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from robots.api import Controller
from robots.controllers import REFERENCE

STANDARD_VIEW = ("numpy", "msgspec")  # what a sandboxed controller may import besides the standard library and robots
ENTRY_POINT_GROUP = "laserarena.controllers"
FOLDER_TEAM = "a folder with __init__.py, or with controller.py or a single other .py file besides tests"
TEAM_FORMS = (
    f"a team is ref:NAME, FILE.py[:Class], DIR[:Class] ({FOLDER_TEAM}), module:Class, "
    f"or the NAME of an installed controller (entry point group {ENTRY_POINT_GROUP})"
)


class LoadError(Exception):
    """A team spec that cannot be loaded; the text is one line naming the spec."""


class SpecKind(enum.Enum):
    """What a spec's form names: it is told by its text alone."""

    REFERENCE = "ref:NAME"
    FILE = "FILE.py[:Class]"
    NAME = "DIR or NAME"  # a package folder if one is there, else an installed controller
    MODULE = "DIR:Class or module:Class"  # a package folder if one is there, else a module


@dataclass(frozen=True)
class TeamSpec:
    """A team spec read once: `target` is the reference name, the `.py` file, the folder or
    entry-point name, or the folder or module before `:`; `cls` the class named after `:`
    ("" for none); `tail` what follows the file or folder as written (":Class", ":" or "")."""

    text: str
    kind: SpecKind
    target: str
    cls: str = ""
    tail: str = ""


def parse_spec(text: str) -> TeamSpec:
    """The form of a team spec, read from its text alone (nothing is looked up)."""
    if text.startswith("ref:"):
        return TeamSpec(text, SpecKind.REFERENCE, text[4:])
    if text.endswith(".py") or ".py:" in text:
        path, _, rest = text.partition(".py")
        return TeamSpec(text, SpecKind.FILE, path + ".py", rest.removeprefix(":"), rest)
    if ":" not in text:
        return TeamSpec(text, SpecKind.NAME, text)
    target, _, cls = text.rpartition(":")
    return TeamSpec(text, SpecKind.MODULE, target, cls, ":" + cls)


def is_file_spec(spec: str) -> bool:
    """Whether a spec names one `.py` file."""
    return parse_spec(spec).kind is SpecKind.FILE


def unknown_reference(name: str) -> str | None:
    """The problem with `ref:NAME` when there is no such reference controller."""
    if name in REFERENCE:
        return None
    return f"no reference controller {name!r} (have: {', '.join(sorted(REFERENCE))})"


def load_class(spec: str) -> type[Controller]:
    """The Controller class a spec names; raise LoadError (one line) if it cannot be loaded."""
    parsed = parse_spec(spec)
    match parsed.kind:
        case SpecKind.REFERENCE:
            problem = unknown_reference(parsed.target)
            if problem:
                raise LoadError(f"team {spec}: {problem}")
            return _from_module(REFERENCE[parsed.target], spec)
        case SpecKind.FILE:
            return _from_file(Path(parsed.target), parsed.cls, spec)
        case SpecKind.NAME:
            return _from_module(entry_point(spec), spec)
    return _from_module(spec, spec)


def entry_point(name: str) -> str:
    """`module:Class` of an installed package's controller, declared in its entry points (read
    from the package's metadata: nothing is imported); LoadError if there is none. Its module
    is imported here, for such a spec alone: it and what it imports are a fifth of what the
    controller template holds, every fork's pages to copy."""
    from importlib import metadata

    found = [ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP) if ep.name == name]
    if not found:
        raise LoadError(f"team {name}: no such file, folder or installed controller; {TEAM_FORMS}")
    return found[0].value


def import_hint(e: ImportError, alone: bool) -> str:
    """What to do about a failed import, by what failed (`alone`: the team is one FILE.py):
    a name robots does not have, a module outside what a sandboxed controller may import
    (the standard library, `robots`, `STANDARD_VIEW`), or a module of the team's own that was
    not shipped."""
    top = (e.name or "").partition(".")[0]
    if top == "robots":
        return " (what robots' modules provide: docs/api.md and docs/toolkit.md)"
    if not isinstance(e, ModuleNotFoundError) or not top or top in sys.stdlib_module_names or top in STANDARD_VIEW:
        return ""
    own = "; a module of your own ships beside it when the folder is the team, given as --team DIR" if alone else ""
    return (
        f" (a sandboxed controller imports the standard library, robots, {', '.join(STANDARD_VIEW)} and its own "
        f"modules{own}; docs/controllers.md)"
    )


def _from_module(target: str, spec: str) -> type[Controller]:
    module_name, _, cls = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except (Exception, SystemExit) as e:  # the team's import failed (or exited): report it in one line
        hint = import_hint(e, alone=False) if isinstance(e, ImportError) else ""
        raise LoadError(f"team {spec}: cannot import {module_name}: {type(e).__name__}: {e}{hint}") from e
    return _pick(module, cls, spec, module_name)


def _from_file(path: Path, cls: str, spec: str) -> type[Controller]:
    if not path.is_file():
        raise LoadError(f"team {spec}: no such file {path}")
    digest = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
    name = f"laserarena_team_{path.stem}_{digest}"
    if name in sys.modules:
        return _pick(sys.modules[name], cls, spec, path.name)
    module_spec = importlib.util.spec_from_file_location(name, path)
    if module_spec is None or module_spec.loader is None:
        raise LoadError(f"team {spec}: {path.name} cannot be imported as a Python module")
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module
    try:
        module_spec.loader.exec_module(module)
    except (Exception, SystemExit) as e:  # a SystemExit at import must not end the loader
        del sys.modules[name]
        hint = import_hint(e, alone=True) if isinstance(e, ImportError) else ""
        raise LoadError(f"team {spec}: {path.name} failed to load: {type(e).__name__}: {e}{hint}") from e
    return _pick(module, cls, spec, path.name)


SUBCLASS = (
    "a controller is a class that subclasses Controller: `class MyBot(Controller):` "
    "after `from robots.api import Controller` (docs/api.md)"
)


def _pick(module: ModuleType, cls: str, spec: str, where: str) -> type[Controller]:
    """The Controller class `cls` of `module` (shown as `where`: the team's file or module),
    or its one Controller class when none is named; LoadError in the team's words otherwise."""
    inside = module.__name__ + "."  # a package's __init__ exports the class of one of its modules
    mine = [
        c
        for _, c in inspect.getmembers(module, inspect.isclass)
        if c.__module__ == module.__name__ or hasattr(module, "__path__") and c.__module__.startswith(inside)
    ]
    own = [c for c in mine if issubclass(c, Controller) and c is not Controller]
    if cls:
        found = getattr(module, cls, None)
        if found is None:
            have = ", ".join(c.__name__ for c in own) or "none"
            raise LoadError(f"team {spec}: {where} has no class {cls} (its Controller classes: {have})")
        if not (inspect.isclass(found) and issubclass(found, Controller)):
            raise LoadError(f"team {spec}: {cls} in {where} does not subclass Controller; {SUBCLASS}")
        return found
    if len(own) == 1:
        return own[0]
    if own:
        names = ", ".join(c.__name__ for c in own)
        raise LoadError(
            f"team {spec}: {where} has {len(own)} Controller classes ({names}); "
            f"name the one to run after the team's name, as TEAM:{own[0].__name__}"
        )
    imported = [
        n
        for n, c in inspect.getmembers(module, inspect.isclass)
        if issubclass(c, Controller) and c is not Controller and c not in mine
    ]
    if imported:  # a controller of another module's, under the name it has here
        raise LoadError(
            f"team {spec}: {where} defines no Controller class of its own (it imports {', '.join(imported)}); "
            f"subclass one, or name it after the team's name, as TEAM:{imported[0]}"
        )
    if mine:
        names = ", ".join(c.__name__ for c in mine)
        raise LoadError(f"team {spec}: no class in {where} subclasses Controller (found {names}); {SUBCLASS}")
    raise LoadError(f"team {spec}: {where} defines no class; {SUBCLASS}")
