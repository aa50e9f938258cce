"""numba's side of the compiled kernels (arena.compiled): making a kernel's dispatcher, loading
its cached machine code faster than numba does (decisions 0045, 0052, 0054), and writing what a
later process needs to run that code without numba (`export`, arena._machine, decision 0055).

Imported only where a kernel must be compiled, or loaded numba's way.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import llvmlite
import numba
import numpy as np
from llvmlite import binding as llvm
from llvmlite.binding import ffi
from numba import njit
from numba.core import entrypoints, environment, errors, intrinsics, types
from numba.core.caching import FunctionCache, NullCache
from numba.core.compiler_lock import global_compiler_lock
from numba.core.runtime import nrtdynmod, rtsys
from numba.core.typing.typeof import typeof_impl
from numba.np import numpy_support

from arena import _machine
from arena._elf import defined_symbols

__all__ = ["cached", "dispatcher", "export"]


def dispatcher(kernel: Any) -> Any:
    """numba's dispatcher of `kernel` (an arena.compiled.Kernel): `njit` with NumPy's division
    rule, cached beside the function's module (or in the user's cache folder); where neither
    can be written, compiled afresh in each process instead."""
    _know_kernels(type(kernel))
    if kernel.names is not None:
        kernel.py_func.__globals__.update(kernel.names())
    made: Any = njit(error_model="numpy", inline=kernel.inline)(kernel.py_func)
    if hasattr(made, "_compilation_chain_init_hook") and hasattr(made, "_types_active_call"):
        made._cache = _Cache(kernel.py_func)
        made._compilation_chain_init_hook = _no_extensions_yet
        made.typeof_pyval = functools.partial(_typeof_argument, made)
    else:  # a numba laid out otherwise: its own cache, where it finds a folder
        with suppress(RuntimeError):  # "cannot cache function ...: no locator available"
            made.enable_caching()
    return made


def _know_kernels(kind: type) -> None:
    """numba types a kernel named in another's code as the dispatcher it stands for."""
    if kind not in typeof_impl.registry:
        typeof_impl.register(kind)(lambda kernel, context: types.Dispatcher(kernel.dispatcher))


class _Cache:
    """numba's cache of one kernel (its `FunctionCache`), made at the kernel's first call:
    making it looks for a folder it may write and writes a file there to be sure (0.13 ms),
    and a run calls 7 of the 48 kernels from Python. Its machine code loads by `_load_cached`;
    numba's extensions load only where none is found, before numba compiles."""

    def __init__(self, py_func: Callable):
        self._py_func = py_func
        self._made: Any = None

    def _cache(self) -> Any:
        if self._made is None:
            try:
                self._made = FunctionCache(self._py_func)
            except RuntimeError:  # "cannot cache function ...: no locator available"
                self._made = NullCache()  # compiled afresh in each process
        return self._made

    def __getattr__(self, name: str) -> Any:  # what numba asks of its cache, but loading
        if name in ("_py_func", "_made"):
            raise AttributeError(name)
        return getattr(self._cache(), name)

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        """The kernel's machine code for `sig` from the cache (`_load_cached`), or None."""
        cache, loaded = self._cache(), None
        if hasattr(cache, "_load_overload") and hasattr(cache, "_guard_against_spurious_io_errors"):
            loaded = _load_cached(cache, sig, target_context)
        if loaded is None:
            entrypoints.init_all()  # numba compiles next: its extensions first, as its own hook would
        return loaded


def _typeof_argument(kernel: Any, value: Any) -> Any:
    """numba's `Dispatcher.typeof_pyval` (an argument's type, where the kernel's compiled
    dispatch has not met its kind yet), without the import of numpy.ma that numba's typeof of
    an array makes to refuse masked arrays (10-20 ms of a run's start). No masked array exists
    before numpy.ma is imported, so until then a plain array is typed here as numba types it."""
    if type(value) is not np.ndarray or "numpy.ma" in sys.modules:
        return type(kernel).typeof_pyval(kernel, value)
    try:
        dtype = numpy_support.from_dtype(value.dtype)
    except errors.NumbaNotImplementedError:
        return type(kernel).typeof_pyval(kernel, value)  # numba's own error
    kind = types.Array(dtype, value.ndim, numpy_support.map_layout(value), readonly=not value.flags.writeable)
    kernel._types_active_call.add(kind)
    return kind


def _no_extensions_yet() -> None:
    """A kernel's `_compilation_chain_init_hook`: numba loads its extensions (every installed
    package's entry points scanned: 3-10 ms of a run's start) before a kernel's first call,
    so that a compile knows their types. Loading cached code needs none (`_Cache`)."""


def _load_cached(cache: Any, sig: Any, target_context: Any) -> Any:
    """numba's `Cache.load_overload` (the kernel's machine code for `sig` from its cache, or
    None) without its refresh of the target context: numba refreshes the context (importing
    and installing every typing and lowering registry) so that it could compile, and compiling
    refreshes it anyway; rebuilding cached code needs only the runtime (NRT) it links to. Its
    environments are rebuilt without importing modules (`_environment`), LLVM is called
    without numba's event at each call (`_unobserved`), the runtime's own functions come
    from the cache too (`_start_runtime`), and the machine code loads without its bitcode
    parsed (`_from_object`)."""
    loaded = None
    with _unobserved():
        codegen = target_context.codegen()
        if "unserialize_library" not in vars(codegen):  # this process's codegen: one per target
            codegen.unserialize_library = functools.partial(_from_object, codegen)
        _start_runtime(target_context, Path(cache._cache_path))
        with cache._guard_against_spurious_io_errors():
            rebuild = environment._rebuild_env  # what the cache's pickles call, looked up as they load
            environment._rebuild_env = _environment
            try:
                loaded = cache._load_overload(sig, target_context)
            finally:
                environment._rebuild_env = rebuild
    return loaded


def _from_object(codegen: Any, serialized: tuple) -> Any:
    """numba's `unserialize_library` for a cached kernel's machine code, without parsing the
    LLVM bitcode cached beside it: numba parses it (0.7 MB for a match's kernels, 40-50 ms of
    every run's start) to list the symbols the code defines, and to link the kernel into
    another being compiled. The symbols are read from the object file's own table
    (arena._elf); the bitcode is parsed only if a compile links the kernel (`_linkable`).
    numba's own way where the code is no ELF object this reads."""
    name, kind, data = serialized
    symbols = defined_symbols(data[0]) if kind == "object" else None
    if symbols is None:
        return type(codegen).unserialize_library(codegen, serialized)
    library = codegen.create_library(name)
    library.enable_object_caching()
    library._set_compiled_object(data[0])
    library._laserarena_code = data[0]  # numba lets go of it once loaded; `export` writes it
    library._finalize_final_module()
    codegen._engine._defined_symbols |= symbols
    library._get_module_for_linking = functools.partial(_linkable, library, data[1])
    return library


def _linkable(library: Any, bitcode: bytes) -> Any:
    """A kernel loaded by `_from_object`, as numba links it into another: its bitcode, parsed
    on first need (numba's `_get_module_for_linking` of a library loaded from its cache)."""
    if library._shared_module is None:
        library._shared_module = llvm.parse_bitcode(bitcode)
    return library._shared_module


def _start_runtime(target_context: Any, folder: Path) -> None:
    """numba's runtime (`rtsys.initialize`), its few LLVM functions (reference counts, the
    meminfo's data) loaded from the machine code an earlier process compiled into `folder`
    (the kernels' cache): compiling them took 25-40 ms of every process that loads a kernel."""
    if getattr(rtsys, "_init", True):
        return
    compile_functions = nrtdynmod.compile_nrt_functions
    nrtdynmod.compile_nrt_functions = lambda context: _runtime_functions(context, folder)
    try:
        rtsys.initialize(target_context)
    finally:
        nrtdynmod.compile_nrt_functions = compile_functions


def _runtime_functions(target_context: Any, folder: Path) -> Any:
    """The library `nrtdynmod.compile_nrt_functions` makes, from `folder` where an earlier
    process left it for this numba, LLVM and processor; else compiled, and left there."""
    codegen = target_context.codegen()
    key = repr((numba.__version__, llvmlite.__version__, codegen.magic_tuple()))
    path = folder / f"numba-runtime-{hashlib.sha256(key.encode()).hexdigest()[:16]}.nbo"
    try:
        return codegen.unserialize_library(pickle.loads(path.read_bytes()))
    except Exception:  # none yet, or unreadable (a write cut short, a numba laid out otherwise): compiled
        pass
    module, library = nrtdynmod.create_nrt_module(target_context)
    library.enable_object_caching()
    library.add_ir_module(module)
    with global_compiler_lock:
        library.finalize()
    _machine.write_whole(path, pickle.dumps(library.serialize_using_object_code()))
    return library


@contextmanager
def _unobserved() -> Iterator[None]:
    """LLVM's calls without the callbacks numba hangs on its lock: at each call, numba makes
    two events for its compile-time statistics. Loading a cached kernel makes a few hundred
    calls; their events were a sixth of the loading's time, and no one reads them then."""
    lock = getattr(getattr(ffi, "lib", None), "_lock", None)
    callbacks = list(getattr(lock, "_cblist", ()))
    for callback in callbacks:
        ffi.unregister_lock_callback(*callback)
    try:
        yield
    finally:
        for callback in callbacks:
            ffi.register_lock_callback(*callback)


def _environment(modname: str, consts: list, env_name: str) -> Any:
    """numba's `_rebuild_env` (the environment of one compiled function in a cached kernel),
    without importing `modname` where no one has: an environment holds its module's globals
    only for code in object mode, which no kernel here has, and the modules of numba's own
    array functions (arrayobj, arraymath, npyimpl) take a tenth of a second to import.

    One environment serves a function's every copy, with the longer list of its constants
    (`_machine.keep_constants`). numba keeps the first one loaded: a kernel linked into another
    (spin.laser_phases into sweep.sense) and then called alone failed to return an array, its
    dtype missing ("'descr' is NULL")."""
    env = environment.lookup_environment(env_name)
    if env is None:
        module = sys.modules.get(modname)
        env = environment.Environment(module.__dict__ if module is not None else {})
        env.consts[:] = consts
        env.env_name = env_name
        environment.Environment._memo[env_name] = env
    else:
        _machine.keep_constants(env, consts)
    return env


def cached(kernel: Any) -> bool | None:
    """Whether numba's cache holds machine code of `kernel` for its source as installed:
    False where its first call compiles it, None where that cannot be told (no cache, or a
    numba whose cache is laid out otherwise)."""
    cache: Any = getattr(kernel.dispatcher, "_cache", None)
    index: Any = getattr(cache, "_cache_file", None)
    if not hasattr(index, "_load_index") or not hasattr(cache, "_guard_against_spurious_io_errors"):
        return None
    with cache._guard_against_spurious_io_errors():
        return bool(index._load_index())  # empty when missing, of another numba, or of another source


def export(kernel: Any, made: Any, kernels: list) -> None:
    """Add to `kernel`'s table (arena._machine) each form of it numba has compiled or loaded
    here and the table lacks. The table holds the stamps of the sources its code comes from:
    the kernel's module, those of the functions linked into it, and every module of this
    project's among `kernels` (those inlined). Nothing where numba's cache folder is not the
    table's, or a form's machine code or constants are not at hand."""
    cache = getattr(made, "_cache", None)
    folder = getattr(getattr(cache, "_made", None), "_cache_path", None)
    runtime = _object_code(getattr(rtsys, "_library", None))
    stamps = _machine.stamps()
    if folder is None or Path(folder) != _machine.path(kernel.py_func).parent or runtime is None or stamps is None:
        return
    table = _machine.read(kernel.py_func)
    entries = dict(table.entries) if table is not None else {}
    project = Path(__file__).resolve().parent.parent
    sources = {kernel.py_func.__code__.co_filename} | set(table.sources if table is not None else ())
    sources |= {
        k.py_func.__code__.co_filename
        for k in kernels
        if Path(k.py_func.__code__.co_filename).resolve().is_relative_to(project)
    }
    for signature, result in made.overloads.items():
        names = tuple(str(t) for t in signature)
        entry = None if names in entries else _entry(result)
        if entry is not None:
            entries[names] = entry
            for env in (result.environment, *_environments(result)):
                module = env.globals or {}  # numba's own functions: stamped as numba's extensions are
                source = module.get("__file__")
                if source and os.path.exists(source) and module.get("__name__", "numba").split(".")[0] != "numba":
                    sources.add(source)
    if not entries or (table is not None and len(entries) == len(table.entries)):
        return
    _machine.write(
        kernel.py_func,
        _machine.Table(
            machine=stamps,
            sources={file: _machine.source_stamp(file) for file in sorted(sources)},
            runtime=runtime,
            math=tuple(intrinsics.INTR_MATH),
            entries=entries,
        ),
    )


def _object_code(library: Any) -> bytes | None:
    """A library's machine code: as loaded (`_from_object`), or as compiled in this process
    where numba kept it for its cache; None where neither."""
    code = getattr(library, "_laserarena_code", None)
    if code is None and library is not None:
        with suppress(Exception):
            code = library.serialize_using_object_code()[2][0]
    return code


def _environments(result: Any) -> list:
    """The environments a compiled form's code reads: as cached, or, compiled in this
    process, found as numba finds them to cache it."""
    envs = result.referenced_envs
    return list(envs) if envs is not None else result._find_referenced_environments()


def _entry(result: Any) -> _machine.Entry | None:
    """A compiled form's `Entry`, or None where its machine code is not at hand or one of its
    constants is numba's own (loading it would import numba)."""
    code = _object_code(result.library)
    if code is None:
        return None
    constants = {env.env_name: list(env.consts) for env in _environments(result)}
    constants[result.environment.env_name] = list(result.environment.consts)
    try:
        if b"numba" in pickle.dumps(list(constants.values()), protocol=pickle.HIGHEST_PROTOCOL):
            return None
    except Exception:
        return None
    return _machine.Entry(
        code=code,
        wrapper=result.fndesc.llvm_cpython_wrapper_name,
        environment=result.environment.env_name,
        constants=constants,
    )
