"""The Python API: `referee.run_match(level, teams=[...])`, for scripts and notebooks.

A team is a spec string (as on the command line) or a Controller class. An isolated match
ships a class's SOURCE into the sandbox, never the live object (docs/decisions/0019-ship-class-source.md):
the file of the class's module when it has one, else (a notebook, `python -c`) the class's own
source after the imports its module's globals show.
"""

from __future__ import annotations

import ast
import hashlib
import inspect
import linecache
import shutil
import tempfile
import types
from pathlib import Path

from arena.level import Level
from arena.loader import find_level, load_level
from referee.errors import TeamError, UserError
from referee.records.results import MatchResult
from referee.sandbox.process import isolation_unavailable
from referee.sandbox.teams import Team, resolve
from robots.api import Controller


def _context(module: types.ModuleType | None, skip: str | None) -> list[str]:
    """Source that rebuilds the names a `__main__` class may use from its module's globals:
    imports (modules, and classes or functions of importable modules), literal constants, and
    the functions and classes defined in `__main__` outside the file or cell `skip` (another
    notebook cell)."""
    lines, defined = ["from robots.api import *"], []
    for name, value in sorted(vars(module).items() if module else ()):
        if name.startswith("_"):
            continue
        home = getattr(value, "__module__", None)
        qual = getattr(value, "__qualname__", None)
        if isinstance(value, types.ModuleType):
            lines.append(f"import {value.__name__} as {name}" if value.__name__ != name else f"import {name}")
        elif isinstance(value, (bool, int, float, str)) and ast.literal_eval(repr(value)) == value:
            lines.append(f"{name} = {value!r}")
        elif (
            not (inspect.isclass(value) or inspect.isfunction(value) or inspect.isbuiltin(value))
            or not home
            or not qual
            or "." in qual
            or home == "builtins"
        ):
            continue
        elif home != "__main__":
            lines.append(f"from {home} import {qual} as {name}")
        elif (_source_file(value) or "") != skip:
            try:
                defined.append(
                    inspect.cleandoc("\n" + inspect.getsource(value))
                    if inspect.isfunction(value)
                    else _definition(value)
                )
            except (OSError, TypeError, SyntaxError):
                continue  # left out: the team's code meets a NameError, reported as its fault
    return lines + defined


def _source_file(cls: object) -> str | None:
    """The file or notebook cell that defines `cls`, from its methods' code objects (a class
    in `__main__` has no module file to ask), or None."""
    if inspect.isfunction(cls):
        return cls.__code__.co_filename
    for value in vars(cls).values():
        code = getattr(getattr(value, "__func__", value), "__code__", None)
        if code is not None:
            return code.co_filename
    return None


def _definitions(text: str) -> str:
    """A module's definitions only: imports, functions, classes and literal constants; any
    statement that does something (running a match, say) is left out."""
    kept: list[ast.stmt] = []
    for node in ast.parse(text).body:
        if isinstance(node, (ast.Import, ast.ImportFrom, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            kept.append(node)
        elif (
            isinstance(node, (ast.Assign, ast.AnnAssign))
            and node.value is not None
            and all(isinstance(t, ast.Name) for t in getattr(node, "targets", [getattr(node, "target", None)]))
        ):
            try:
                ast.literal_eval(node.value)
            except ValueError:
                continue
            kept.append(node)
    return "\n\n".join(ast.get_source_segment(text, n, padded=True) or ast.unparse(n) for n in kept) + "\n"


def _definition(cls: object) -> str:
    """The source of a class defined in `__main__`, found in its file or cell."""
    filename = _source_file(cls)
    name = getattr(cls, "__name__", "")
    text = "".join(linecache.getlines(filename)) if filename else ""
    for node in ast.parse(text).body:
        if isinstance(node, ast.ClassDef) and node.name == name:
            return ast.get_source_segment(text, node) or ast.unparse(node)
    raise OSError(f"no source for {name}")


def _class_source(cls: type) -> str:
    """Source that defines `cls` in a fresh module. A class from an importable module: that
    module's file. A class from a script or a notebook (`__main__`): the definitions of its
    file or cell (`_definitions`), after the imports its module's globals show."""
    module = inspect.getmodule(cls)
    if cls.__module__ != "__main__" and module is not None:
        try:
            return inspect.getsource(module)
        except (OSError, TypeError):
            pass
    filename = _source_file(cls)
    lines = linecache.getlines(filename) if filename else []
    if not lines:
        raise TeamError(
            f"team {cls.__name__}: its source cannot be found; define it in a file "
            f"or a notebook cell, or pass isolate=False"
        )
    try:
        body = _definitions("".join(lines))
    except SyntaxError as e:
        raise TeamError(f"team {cls.__name__}: {filename} cannot be parsed: {e}") from None
    return "\n".join(_context(module, filename)) + "\n\n\n" + body


def _class_team(cls: type, isolate: bool, folder: Path) -> Team:
    """A Team for a Controller class: its source shipped (isolated) or the class itself."""
    if not (inspect.isclass(cls) and issubclass(cls, Controller)):
        raise UserError(f"a team must be a spec string or a Controller class, got {cls!r:.80}")
    if not isolate:
        return Team(
            cls.__name__,
            f"python:{cls.__module__}.{cls.__qualname__}",
            "sha256:" + hashlib.sha256(f"{cls.__module__}.{cls.__qualname__}".encode()).hexdigest(),
            factory=cls,
        )
    source = _class_source(cls)
    digest = hashlib.sha256(source.encode()).hexdigest()
    path = folder / f"team_{cls.__name__.lower()}_{digest[:8]}.py"
    path.write_text(source, encoding="utf-8")
    path.chmod(0o644)
    return Team(
        cls.__name__, f"{path}:{cls.__name__}", "sha256:" + digest, ((path.name, path),), f"{path.name}:{cls.__name__}"
    )


def _level(level: str | Path | Level) -> Level:
    if isinstance(level, Level):
        return level
    if isinstance(level, Path):
        return load_level(level)
    if isinstance(level, str):
        return find_level(level)
    raise UserError(f"level must be a name, a path or a Level, got {type(level).__name__}")


def run_match(
    level: str | Path | Level,
    teams: list[str | type] | None = None,
    seed: int | None = None,
    ideal: bool = False,
    isolate: bool = True,
    replay: str | Path | None = None,
    logs: str | Path | None = None,
) -> MatchResult:
    """Run one match and return its typed result (`r.robots[0].score.total`).

    `level`: a built-in name, a YAML path or a Level; `teams`: one per slot, in order, each a
    spec string (`ref:NAME`, `FILE.py[:Class]`, `DIR[:Class]`, `module:Class`) or a Controller
    class; slots left over get the level's default controller. `isolate=False` runs the
    controllers in this process (a debugger can stop in them)."""
    from referee.match.loop import run_match as run  # the match loop loads pymunk: only when called

    lv = _level(level)
    given = list(teams or [])
    if len(given) > len(lv.robots):
        raise UserError(f"{lv.name} has {len(lv.robots)} robot slot(s); got {len(given)} teams")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise UserError(f"seed must be a whole number >= 0, got {seed!r}")
    given += [lv.default_controller] * (len(lv.robots) - len(given))
    folder = Path(tempfile.mkdtemp(prefix="laserarena-api-"))
    try:
        folder.chmod(0o755)  # the controller, another user, reads the shipped source
        ship = isolate and isolation_unavailable() is None  # else the match warns and runs them here
        resolved = [resolve(t) if isinstance(t, str) else _class_team(t, ship, folder) for t in given]
        if logs is not None:
            Path(logs).mkdir(parents=True, exist_ok=True)
        return run(
            lv,
            resolved,
            seed=seed,
            replay=replay,
            ideal=ideal,
            isolate=isolate,
            logs=Path(logs) if logs is not None else None,
        )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
