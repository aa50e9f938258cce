"""Resolve a team spec from the command line into a `Team` the match can run, WITHOUT running it.

A spec is `ref:NAME` (a reference controller), `path/team.py[:Class]` (a file: that one file
is shipped, docs/controllers.md), `path/DIR[:Class]` (a folder: with `__init__.py` a package,
shipped whole, data files too; else its controller file is `controller.py` or its one other
`.py` file besides tests, and its `.py` files ship beside it), `package.module:Class` (anything
on the path) or NAME (an installed controller's entry point). Resolving finds the files only:
nothing of the team's is imported or executed in the referee. The controller's own
(sandboxed) process loads the code; a failure to load comes back from there as a `load`
fault for that slot. Only `--in-process` imports a team here.
"""

from __future__ import annotations

import fnmatch
import hashlib
import importlib.machinery
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from levels.model import Level
from referee.errors import TeamError
from referee.sandbox.team_files import read_file, read_modules, read_package
from referee.terminal import safe
from robots._host.loading import (
    TEAM_FORMS,
    LoadError,
    SpecKind,
    TeamSpec,
    entry_point,
    parse_spec,
    unknown_reference,
)
from robots.api import Controller
from robots.controllers import REFERENCE

BUILT_IN = "robots"  # present in every controller process: nothing of it is shipped
RESERVED = frozenset(sys.stdlib_module_names) | {BUILT_IN, "sitecustomize", "usercustomize"}


@dataclass(frozen=True)
class Team:
    """A resolved team.

    `label`: machine-independent name for tables and replays; `spec`: the spec as resolved
    (files absolute), what a replay header records; `code_hash`: "sha256:<hex>" over the code
    that runs (see `code_hash`); `files`: (path inside the slot's code folder, bytes) for each
    file shipped into the controller's sandbox, read once (referee.sandbox.team_files): what
    was hashed is what is shipped; `entry`: the spec the controller process
    loads, with file paths relative to that folder; `home`: the folder on this machine the
    files' paths are relative to (an in-process match imports them from there). `factory` makes
    a controller from Python objects instead, for in-process matches of a library user (never
    from a spec)."""

    label: str
    spec: str
    code_hash: str
    files: tuple[tuple[str, bytes], ...] = ()
    entry: str = ""
    factory: Callable[[], Controller] | None = None
    home: str = ""


def file_hash(data: bytes) -> str:
    """The code hash of a one-file team: sha256 of its bytes."""
    return "sha256:" + hashlib.sha256(data).hexdigest()


def tree_hash(files: tuple[tuple[str, bytes], ...]) -> str:
    """The code hash of a package: sha256 over every shipped file, in path order, of its
    relative path, size and bytes."""
    h = hashlib.sha256()
    for rel, data in sorted(files):
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    return "sha256:" + h.hexdigest()


def _importable_name(label: str, name: str) -> None:
    """Refuse a team whose top-level module would shadow the standard library, `robots` or a
    module Python imports at start-up (sitecustomize, usercustomize) in its sandbox."""
    if name in RESERVED:
        raise TeamError(
            f"team {safe(label)}: the module name {name!r} is taken by Python or LaserArena; "
            "rename the team's file or folder"
        )


def _file_team(label: str, spec: str, path: Path, entry: str) -> Team:
    """A team of one module file: its bytes read once, hashed and shipped."""
    _importable_name(label, path.stem)
    data = read_file(path, label)
    return Team(label, spec, file_hash(data), ((path.name, data),), entry, home=str(path.parent))


def _package_team(label: str, spec: str, root: Path, entry: str) -> Team:
    """A team of one package folder: every file's bytes read once, hashed and shipped."""
    _importable_name(label, root.name)
    files = read_package(root, label)
    return Team(label, spec, tree_hash(files), files, entry, home=str(root.parent))


TESTS = ("test_*.py", "*_test.py", "conftest.py")  # never a folder team's controller file


def controller_file(names: list[str]) -> str | None:
    """Which of a folder's `.py` files (`names`, no `__init__.py` among them) is its controller:
    `controller.py` (the name `laserarena new` writes), else the one file that is not a test;
    None when there is no such file or more than one."""
    if "controller.py" in names:
        return "controller.py"
    own = [n for n in names if not any(fnmatch.fnmatchcase(n, t) for t in TESTS)]
    return own[0] if len(own) == 1 else None


def not_a_team(folder: Path, names: list[str]) -> str:
    """Why the folder `folder`, holding the `.py` files `names`, is no team (one line, with
    what makes a folder a team and every form a team takes)."""
    found = f"{len(names)}: {', '.join(names[:5])}{', ...' if len(names) > 5 else ''}" if names else "none"
    return f"the folder {safe(str(folder), 200)} is not a team (.py files: {found}); {TEAM_FORMS}"


def _folder_team(label: str, spec: TeamSpec, root: Path) -> Team:
    """A team of one folder without `__init__.py`: its Python files read once, hashed and
    shipped side by side; its controller file (`controller_file`) is the one loaded."""
    files = read_modules(root, label)
    names = [name for name, _ in files]
    chosen = controller_file(names)
    if chosen is None:
        raise TeamError(f"team {safe(spec.text)}: {not_a_team(Path(spec.target), names)}")
    cls = spec.cls
    for name in names:
        _importable_name(label, name.removesuffix(".py"))
    return Team(label, f"{root}:{cls}", tree_hash(files), files, chosen + (f":{cls}" if cls else ""), home=str(root))


def find_module(name: str) -> importlib.machinery.ModuleSpec | None:
    """Where module `name` lives, found on sys.path without importing it or its parents
    (importlib.util.find_spec would run a package's __init__ for a dotted name)."""
    found, path = None, None
    parts = name.split(".")
    for i in range(len(parts)):
        prefix = ".".join(parts[: i + 1])
        loaded = sys.modules.get(prefix)  # already imported (our own `robots`): where it really is
        found = getattr(loaded, "__spec__", None) or importlib.machinery.PathFinder.find_spec(prefix, path)
        if found is None:
            return None
        path = found.submodule_search_locations
        if path is None and i < len(parts) - 1:
            return None  # a plain module has no submodules
    return found


def _entry_point(name: str) -> str:
    """`module:Class` of an installed controller named `name` (from metadata, not imported)."""
    try:
        return entry_point(name)
    except LoadError as e:
        raise TeamError(str(e)) from None


def _module_team(label: str, spec: str, target: str) -> Team:
    """A team given as `module:Class`: its top-level package (or module file) is shipped."""
    module = target.partition(":")[0]
    found = find_module(module) if module else None
    if found is None:
        raise TeamError(f"team {label}: no such folder or module {module!r}; {TEAM_FORMS}")
    source = Path(found.origin) if found.origin and Path(found.origin).is_file() else None
    top = module.split(".")[0]
    if top == BUILT_IN:  # our own installed code, never a team's: its hash names the version that runs
        return Team(
            label,
            spec,
            file_hash(source.read_bytes()) if source else file_hash(spec.encode()),
            (),
            target,
        )
    top_spec = find_module(top)
    if top_spec is None:
        raise TeamError(f"team {label}: cannot find package {top!r} on the path")
    if top_spec.submodule_search_locations:  # a package: ship all of it
        return _package_team(label, spec, Path(list(top_spec.submodule_search_locations)[0]), target)
    if top_spec.origin is None:
        raise TeamError(f"team {label}: module {top!r} has no file to ship")
    return _file_team(label, spec, Path(top_spec.origin), target)


def label_of(path: Path) -> str:
    """A team's name in tables and replays: its path relative to the current folder when it
    lies under it, else its last part (never a machine's absolute path)."""
    try:
        inside = path.resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return path.name
    return path.resolve().name if inside == "." else inside


def _unlinked(path: Path) -> Path:
    """`path` made absolute with the folders above it resolved but its own last part kept, so
    a link there is refused when the team is read, not followed."""
    if path.name in ("", ".", ".."):
        return path.resolve()
    return path.parent.resolve() / path.name


def _team_folder(spec: TeamSpec, base: Path | None = None) -> tuple[Path, bool] | None:
    """The folder of a `DIR` or `DIR:Class` spec (relative to `base` if given and the folder is
    relative) and whether it holds a Python package (`__init__.py`), or None if the spec names
    no folder. TeamError for a package whose folder's name is not a Python name."""
    if spec.kind not in (SpecKind.NAME, SpecKind.MODULE) or not spec.target:
        return None
    path = Path(spec.target)
    if base is not None and not path.is_absolute():
        path = base / path
    if not path.is_dir():
        return None
    if not (path / "__init__.py").is_file():
        return path, False
    name = _unlinked(path).name
    if not name.isidentifier():
        raise TeamError(f"team {spec.text}: the package folder's name {name!r} is not a Python name")
    return path, True


def controller_problem(text: str, base: Path) -> tuple[str, str | None]:
    """Whether a level's default controller spec names something that exists, found WITHOUT
    running any of its code: `ref:NAME` among the reference controllers, `FILE.py[:Class]` or
    `DIR[:Class]` relative to the level's folder `base`, `module:Class` by the import system's
    finders, or an installed controller's entry point. Returns (the spec with a file or folder
    made absolute, problem or None)."""
    spec = parse_spec(text)
    if spec.kind is SpecKind.REFERENCE:
        return text, unknown_reference(spec.target)
    if spec.kind is SpecKind.FILE:
        file = Path(spec.target)
        file = file if file.is_absolute() else base / file
        if not file.is_file():
            return text, f"no such file {file} (a controller file is found relative to the level file)"
        return str(file.resolve()) + spec.tail, None
    try:
        found = _team_folder(spec, base)
    except TeamError as e:
        return text, str(e).removeprefix(f"team {text}: ")
    if found is not None:
        folder, package = found
        names = sorted(p.name for p in folder.glob("*.py"))
        if not package and controller_file(names) is None:
            return text, not_a_team(folder, names)
        return str(folder.resolve()) + spec.tail, None
    if spec.kind is SpecKind.NAME:
        try:
            entry_point(text)
        except LoadError as e:
            return text, str(e).removeprefix(f"team {text}: ")
        return text, None
    if not spec.cls or not spec.target or not _importable(spec.target):
        problem = f"no importable module {spec.target!r}" if spec.target else "expected module:Class"
        return text, f"{problem}; {TEAM_FORMS}"
    return text, None


def _importable(name: str) -> bool:
    """Whether `find_module` finds a dotted module (a malformed name is not one)."""
    try:
        return find_module(name) is not None
    except (ImportError, ValueError):
        return False


def resolve(text: str) -> Team:
    """Turn a team spec into a `Team`; raise `TeamError` (one line) if its code cannot be found.
    Whether the code loads is learnt only in the controller's process."""
    spec = parse_spec(text)
    if spec.kind is SpecKind.REFERENCE:
        problem = unknown_reference(spec.target)
        if problem:
            raise TeamError(f"team {text}: {problem}")
        return _module_team(text, text, REFERENCE[spec.target])
    if spec.kind is SpecKind.FILE:
        source = Path(spec.target)
        if not source.is_file() and not source.is_symlink():
            raise TeamError(f"team {text}: no such file {source}; {TEAM_FORMS}")
        placed = _unlinked(source)
        return _file_team(label_of(placed) + spec.tail, str(placed) + spec.tail, placed, source.name + spec.tail)
    found = _team_folder(spec)
    if found:  # recorded as `DIR:Class`, or `DIR:` to find the class
        root = _unlinked(found[0])
        label = label_of(root) + (f":{spec.cls}" if spec.cls else "")
        if found[1]:  # a package is imported by its folder's name
            return _package_team(label, f"{root}:{spec.cls}", root, f"{root.name}:{spec.cls}")
        return _folder_team(label, spec, root)
    if spec.kind is SpecKind.NAME:
        return _module_team(text, text, _entry_point(text))
    return _module_team(text, text, text)


def code_hash(spec: str) -> str:
    """The `Team.code_hash` of a spec (for replays and verification), without running anything."""
    return resolve(spec).code_hash


def fill_slots(level: Level, specs: list[str] | None, slots: int | None = None) -> list[Team]:
    """The teams of `slots` robot slots (all of the level's by default), in slot order: the
    specs given, then the level's default controller for the rest; TeamError (one line) if
    more specs are given than there are slots, or one cannot be resolved."""
    n = len(level.robots) if slots is None else slots
    given = list(specs or [])
    if len(given) > n:
        raise TeamError(f"{level.name}: {len(given)} teams for {n} robot slot(s)")
    return [resolve(s) for s in given + [level.default_controller] * (n - len(given))]
