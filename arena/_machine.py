"""A kernel's machine code run without numba (decision 0055): importing numba takes a tenth
of a second of every process that calls a kernel, and running code numba compiled needs
llvmlite and numba's three C extensions alone.

- Once numba has compiled or loaded a kernel for some argument types, `arena._numba` writes
  its `Entry` into the kernel's `Table`, a file beside numba's cache (`write`).
- A later process reads the table (`read`) and loads an entry (`load`): the same object
  code in an LLVM engine of this module's own, linked to numba's C helpers and runtime as
  numba links it.
- A table is ignored where a kernel module's source, numba's extensions, Python, llvmlite or
  the processor differ from the writer's.
- `type_name` names an argument's type as numba does; `caller` puts an entry behind the test
  that a call's arguments are of its types.
"""

from __future__ import annotations

import builtins
import ctypes
import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import pickle
import re
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from arena._elf import defined_symbols

__all__ = ["Entry", "Table", "caller", "keep_constants", "load", "path", "read", "type_name", "write", "write_whole"]

SUFFIX = ".machine"  # a table's file name: numba's cache file's base, this suffix
# numba's C extensions the code calls into: its helpers, its function objects, its runtime
EXTENSIONS = ("numba._helperlib", "numba._dynfunc", "numba.core.runtime._nrt_python")


@dataclass(frozen=True)
class Entry:
    """One compiled form of a kernel: its object code (the kernels it calls linked in), the
    symbol of the CPython wrapper numba made for it, its environment's symbol, and the
    constants of every environment its code reads (NumPy dtypes), by symbol."""

    code: bytes
    wrapper: str
    environment: str
    constants: dict[str, list]


@dataclass(frozen=True)
class Table:
    """A kernel's entries, by the names of their argument types (`type_name`), and what
    running them needs: numba's runtime functions' object code, the names of the C library's
    math functions numba binds to its helpers' copies; and what they were made for (`stamps`)."""

    machine: tuple
    sources: dict[str, str]
    runtime: bytes
    math: tuple[str, ...]
    entries: dict[tuple[str, ...], Entry]


def path(py_func: Callable) -> Path:
    """Where `py_func`'s table is: numba's cache folder for it (under NUMBA_CACHE_DIR as numba
    names it, else `__pycache__` beside its module), its cache files' base name."""
    source = os.path.abspath(py_func.__code__.co_filename)
    given = os.environ.get("NUMBA_CACHE_DIR")
    if given:
        folder = os.path.dirname(source)
        hashed = hashlib.sha1(folder.encode()).hexdigest()
        where = Path(given) / f"{os.path.basename(folder)}_{hashed}"
    else:
        where = Path(source).parent / "__pycache__"
    name = py_func.__qualname__.replace("<", "").replace(">", "")
    stem = Path(source).stem
    return where / f"{stem}.{name}-{py_func.__code__.co_firstlineno}{SUFFIX}"


def source_stamp(file: str) -> str:
    """A source file's content hash (numba's stamp of a kernel's source), hashed once a
    process while the file's time and size stay."""
    status = os.stat(file)
    return _content_hash(file, status.st_mtime_ns, status.st_size)


@functools.cache
def _content_hash(file: str, mtime_ns: int, size: int) -> str:
    return hashlib.sha256(Path(file).read_bytes()).hexdigest()


@functools.cache
def _extension_files() -> tuple[Path, ...] | None:
    """numba's C extensions, found without importing numba (None where one is missing)."""
    spec = importlib.util.find_spec("numba")
    if spec is None or not spec.submodule_search_locations:
        return None
    root, found = Path(spec.submodule_search_locations[0]), []
    for name in EXTENSIONS:
        folder, stem = root.joinpath(*name.split(".")[1:-1]), name.rsplit(".", 1)[1]
        files = [folder / f"{stem}{suffix}" for suffix in importlib.machinery.EXTENSION_SUFFIXES]
        existing = [f for f in files if f.exists()]
        if not existing:
            return None
        found.append(existing[0])
    return tuple(found)


@functools.cache
def stamps() -> tuple | None:
    """What a table's code was made for: Python, llvmlite, numba's extensions (their content
    hashes), LLVM's name and features of this processor; None where numba is not installed."""
    files = _extension_files()
    if files is None:
        return None
    import llvmlite
    from llvmlite import binding as ll

    return (
        sys.version,
        llvmlite.__version__,
        tuple(source_stamp(str(f)) for f in files),
        ll.get_host_cpu_name(),
        ll.get_host_cpu_features().flatten(),
    )


def read(py_func: Callable) -> Table | None:
    """`py_func`'s table, if there is one made for this machine and for the sources as they
    are now; else None."""
    try:
        table = pickle.loads(path(py_func).read_bytes())
    except Exception:  # none, or unreadable (a write cut short, another layout): numba's way
        return None
    if not isinstance(table, Table) or table.machine != stamps():
        return None
    try:
        if any(source_stamp(file) != stamp for file, stamp in table.sources.items()):
            return None
    except OSError:
        return None
    return table


def write(py_func: Callable, table: Table) -> None:
    """Write `py_func`'s table (`write_whole`)."""
    write_whole(path(py_func), pickle.dumps(table, protocol=pickle.HIGHEST_PROTOCOL))


def write_whole(target: Path, data: bytes) -> None:
    """Write `data` to `target` whole or not at all, whoever writes beside; nothing where its
    folder cannot be written (a cache this process cannot keep: made again next time)."""
    part = target.with_name(f"{target.name}.{os.getpid()}")
    try:
        part.write_bytes(data)
        os.replace(part, target)
    except OSError:
        part.unlink(missing_ok=True)


def keep_constants(environment: Any, constants: list) -> None:
    """Give one environment, which serves all copies of a function, the longer list of its
    constants: a copy linked into another kernel holds fewer than the function alone, and
    the copies number them alike (the shorter a prefix of the longer)."""
    if len(environment.consts) < len(constants):
        environment.consts[:] = constants


_UNPICKLE = ctypes.CFUNCTYPE(ctypes.py_object, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p)


class _Linker:
    """This process's LLVM engine for the tables' code, with numba's C extensions loaded
    under their own names (numba, imported later, finds them loaded) and their functions
    bound as numba binds them (numba.core.base, externals, runtime.nrt)."""

    def __init__(self, table: Table):
        from llvmlite import binding as ll

        files = _extension_files()
        assert files is not None
        helpers, functions, runtime = (_extension(name, file) for name, file in zip(EXTENSIONS, files))
        ll.initialize_native_target()
        ll.initialize_native_asmprinter()
        ll.add_symbol("_Py_NoneStruct", id(None))
        for table_of in (helpers.c_helpers, functions.c_helpers):
            for name, address in table_of.items():
                ll.add_symbol(f"numba_{name}", address)
        for value in vars(builtins).values():
            if isinstance(value, type) and issubclass(value, BaseException):
                ll.add_symbol(f"PyExc_{value.__name__}", id(value))
        for name in table.math:
            ll.add_symbol(name, helpers.c_helpers[name])
        for name, address in runtime.c_helpers.items():
            ll.add_symbol(name if name.startswith("_") else f"NRT_{name}", address)
        runtime.memsys_use_cpython_allocator()  # as numba.core.runtime.nrt does at its import
        self.unpickle = _UNPICKLE(self._unpickled)  # kept: LLVM's code calls it
        ll.add_symbol("numba_unpickle", ctypes.cast(self.unpickle, ctypes.c_void_p).value)
        target = ll.Target.from_triple(ll.get_process_triple())
        machine = target.create_target_machine(
            cpu=ll.get_host_cpu_name(),
            features=ll.get_host_cpu_features().flatten(),
            reloc="static",
            codemodel="jitdefault",
        )
        self.ll, self.make_function = ll, functions.make_function
        self.engine = ll.create_mcjit_compiler(ll.parse_assembly(""), machine)
        if defined_symbols(table.runtime) is None:  # LLVM would crash on an object that is none
            raise ValueError("the runtime's machine code is no object file")
        self.engine.add_object_file(ll.ObjectFileRef.from_data(table.runtime))
        self.new_environment = functions.Environment  # what numba's code reads: its constants
        self.memo: dict[int, Any] = {}
        self.environments: dict[str, Any] = {}  # one per symbol, as numba keeps them

    def _unpickled(self, data: int, size: int, _hashed: int) -> Any:
        """numba's `numba_unpickle`, without numba where it can: an object the code names (the
        array type it returns, an exception), pickled in it at compile time, once per place.
        numba's helper imports numba to unpickle (numba.core.serialize); most such objects are
        NumPy's or Python's own, which pickle unpickles alone."""
        found = self.memo.get(data)
        if found is None:
            found = self.memo[data] = pickle.loads(ctypes.string_at(data, size))
        return found

    def load(self, entry: Entry, py_func: Callable) -> Callable:
        """`entry`'s code linked, its environments set, and numba's wrapper of it as a function."""
        symbols = defined_symbols(entry.code)  # LLVM would crash on an object that is none
        if symbols is None or entry.wrapper not in symbols or not symbols.issuperset(entry.constants):
            raise ValueError(f"the machine code of {py_func.__qualname__} does not define its entry")
        self.engine.add_object_file(self.ll.ObjectFileRef.from_data(entry.code))
        self.engine.finalize_object()
        for name, constants in entry.constants.items():
            env = self.environments.get(name)
            if env is None:
                env = self.environments[name] = self.new_environment({})
            keep_constants(env, constants)
            address = self.engine.get_global_value_address(name)
            (ctypes.c_void_p * 1).from_address(address)[0] = id(env)
        function = self.engine.get_function_address(entry.wrapper)
        module = sys.modules.get(py_func.__module__)
        doc = f"compiled wrapper for {py_func.__qualname__!r}"
        keep = (self.engine, self.environments[entry.environment])
        return self.make_function(module, py_func.__name__, doc, function, self.environments[entry.environment], keep)


def _extension(name: str, file: Path) -> Any:
    """numba's C extension `name`, loaded from `file` without importing numba, and left in
    sys.modules under its name (a numba imported later uses it, not a second copy)."""
    loaded = sys.modules.get(name)
    if loaded is not None:
        return loaded
    loader = importlib.machinery.ExtensionFileLoader(name, str(file))
    spec = importlib.util.spec_from_file_location(name, str(file), loader=loader)
    assert spec is not None
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    sys.modules[name] = module
    return module


_linker: _Linker | None = None
_lock = threading.Lock()


def load(table: Table, types: tuple[str, ...], py_func: Callable) -> Callable:
    """The entry of `table` for arguments of `types`, loaded: numba's wrapper of it, called
    as the kernel is (it unboxes, runs and boxes as under numba)."""
    global _linker
    with _lock:
        if _linker is None:
            _linker = _Linker(table)
        return _linker.load(table.entries[types], py_func)


# numba's names of NumPy's scalar and array dtypes it takes; others go numba's way
_DTYPES = {
    np.dtype(name): name
    for name in (
        "bool",
        "int8",
        "int16",
        "int32",
        "int64",
        "uint8",
        "uint16",
        "uint32",
        "uint64",
        "float32",
        "float64",
        "complex64",
        "complex128",
    )
}
_SCALARS = {dtype.type: name for dtype, name in _DTYPES.items()}
_INT64 = (-(2**63), 2**63)


def type_name(value: Any) -> str | None:
    """numba's name of `value`'s type, as its dispatcher types an argument (numba.typeof);
    None for a kind this does not name."""
    kind = type(value)
    if kind is np.ndarray:
        name = _DTYPES.get(value.dtype)
        if name is None:
            return None
        flags = value.flags
        layout = "C" if flags.c_contiguous else "F" if flags.f_contiguous else "A"
        array = f"array({name}, {value.ndim}d, {layout})"
        return array if flags.writeable else f"readonly {array}"
    if kind is float:
        return "float64"
    if kind is bool:
        return "bool"
    if kind is int:
        if _INT64[0] <= value < _INT64[1]:
            return "int64"
        return "uint64" if 0 <= value < 2**64 else None
    return _SCALARS.get(kind)


_NOT_GIVEN = object()  # an argument a call left out
_ARRAY = re.compile(r"(readonly )?array\((\w+), (\d+)d, ([CFA])\)")  # numba's name of an array type
_LAYOUTS = {  # numba's layout of an array by its flags `f` (numpy_support.map_layout)
    "C": "f.c_contiguous",
    "F": "not f.c_contiguous and f.f_contiguous",
    "A": "not f.c_contiguous and not f.f_contiguous",
}


def caller(types: tuple[str, ...], last: tuple, function: Callable, miss: Callable[[tuple, dict], Any]) -> Callable:
    """`function` (an entry) behind a test of each call's arguments, as a method (its first
    argument, the kernel, is passed over), made to run at every call: arguments not of
    `types`, or given by keyword, go to `miss` as a tuple. An array passes as the very one
    last checked at its place (first `last`; no code here reassigns an array's dtype, shape
    or flags), or by its dtype, dimensions, layout and writeability; a scalar by a kind
    `type_name` names so."""
    terms, arrays = [], []
    names = {"ndarray": np.ndarray, "function": function, "miss": miss, "int": int, "N": _NOT_GIVEN}
    for i, name in enumerate(types):
        a, array = f"a{i}", _ARRAY.fullmatch(name)
        if array:
            readonly, dtype, ndim, layout = array.groups()
            names[f"D{i}"] = np.dtype(dtype)
            writeable = f"{'not ' if readonly else ''}(f := {a}.flags).writeable"
            same = f"{a}.dtype is D{i} and {a}.ndim == {ndim} and {writeable} and {_LAYOUTS[layout]}"
            terms.append(f"({a} is L{i} or (type({a}) is ndarray and {same} and (L{i} := {a}) is {a}))")
            arrays.append(f"L{i}")
            continue
        names[f"S{i}"] = np.dtype(name).type if name in _SCALARS.values() else None
        if name == "float64":
            terms.append(f"(type({a}) is float or type({a}) is S{i})")
        elif name == "bool":
            terms.append(f"(type({a}) is bool or type({a}) is S{i})")
        elif name == "int64":
            terms.append(f"((type({a}) is int and {_INT64[0]} <= {a} < {_INT64[1]}) or type({a}) is S{i})")
        elif name == "uint64":
            terms.append(f"((type({a}) is int and {_INT64[1]} <= {a} < {2**64}) or type({a}) is S{i})")
        else:
            terms.append(f"type({a}) is S{i}")
    arguments = ", ".join(f"a{i}" for i in range(len(types)))
    parameters = "".join(f", a{i}=N" for i in range(len(types)))  # positional only: fewer go to `miss`
    held = ", ".join(f"L{i}" for i in range(len(types)))
    source = (  # the arrays last checked held as the closure's cells: the cheapest to read
        f"def make({held}):\n"
        f"    def call(_{parameters}, /, **keywords):\n"
        f"        {'nonlocal ' + ', '.join(arrays) if arrays else 'pass'}\n"
        f"        if not keywords and {' and '.join(terms) or 'True'}:\n"
        f"            return function({arguments})\n"
        f"        return miss(tuple(a for a in ({arguments}{',' if types else ''}) if a is not N), keywords)\n"
        f"    return call\n"
    )
    exec(compile(source, f"<a call of ({', '.join(types)})>", "exec"), names)
    make = cast(Callable[..., Callable], names["make"])
    return make(*last)
