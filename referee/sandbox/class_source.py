"""A Controller class given to the Python API, as a team the sandbox can run: its SOURCE
shipped as a file, never the live object (docs/decisions/0019-ship-class-source.md). The file
of the class's module when it has one, else (a notebook, a script, `python -c`) the class's
own definitions after the imports its module's globals show, kept to what a sandboxed
controller can import.
"""

from __future__ import annotations

import ast
import hashlib
import inspect
import linecache
import types
from pathlib import Path

from referee.errors import TeamError, UserError
from referee.sandbox.kernel import importable_in_sandbox
from referee.sandbox.teams import Team
from robots.api import Controller


def _context(module: types.ModuleType | None, skip: str | None) -> list[str]:
    """Source that rebuilds the names a `__main__` class may use from its module's globals:
    imports (modules, and classes or functions of modules a sandboxed controller can import),
    literal constants, and the functions and classes defined in `__main__` outside the file or
    cell `skip` (another notebook cell)."""
    lines, defined = ["from robots.api import *"], []
    for name, value in sorted(vars(module).items() if module else ()):
        if name.startswith("_"):
            continue
        home = getattr(value, "__module__", None)
        qual = getattr(value, "__qualname__", None)
        if isinstance(value, types.ModuleType):
            if not importable_in_sandbox(value.__name__):
                continue  # the referee, a plotting library: out of a controller's reach
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
            if not importable_in_sandbox(home):
                continue
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
    """A module's definitions only: imports of what a sandboxed controller can import,
    functions, classes and literal constants; any statement that does something (running a
    match, say) is left out."""
    kept: list[ast.stmt] = []
    for node in ast.parse(text).body:
        if isinstance(node, ast.Import):
            names = [alias for alias in node.names if importable_in_sandbox(alias.name)]
            if names:
                kept.append(node if names == node.names else ast.Import(names=names))
        elif isinstance(node, ast.ImportFrom):
            if node.level or importable_in_sandbox(node.module or ""):
                kept.append(node)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
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


def class_team(cls: type, isolate: bool, folder: Path) -> Team:
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
        cls.__name__,
        f"{path}:{cls.__name__}",
        "sha256:" + digest,
        ((path.name, source.encode()),),
        f"{path.name}:{cls.__name__}",
        home=str(folder),
    )
