"""Compiling a loop with NumPy's own numbers (decision 0025): numba's `njit` with NumPy's
division rule, and the scalar forms of the NumPy calls the compiled loops of the arena share
(maximum, minimum, sign, and arena.angles' wrap), in one place.

- arithmetic is written in NumPy's order of operations; numba neither reorders nor fuses it
  (no fast-math, no fused multiply-add), and `hypot`, `sqrt` and `rint` are the C library's,
  as NumPy's are;
- `arctan2`, `arcsin`, `exp2` and `cos` stay NumPy calls between kernels: NumPy takes its own
  SIMD code for most of them on most processors, which differs from the C library's in the
  last bit;
- `np.maximum` and `np.minimum` keep their NaN rule (`maximum`, `minimum`), and a division by
  zero gives an infinity or a NaN, as in NumPy (`error_model="numpy"`), not an exception.

How it works, in detail: docs/internals.md, `arena/compiled.py`.
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
from typing import Any, Literal, TypeVar, cast

import llvmlite
import numba
import numpy as np
from llvmlite import binding as llvm
from llvmlite.binding import ffi
from numba import njit
from numba.core import entrypoints, environment, errors, types
from numba.core.caching import FunctionCache, NullCache
from numba.core.compiler_lock import global_compiler_lock
from numba.core.runtime import nrtdynmod, rtsys
from numba.np import numpy_support

from arena._elf import defined_symbols
from arena.angles import TWO_PI

F = TypeVar("F", bound=Callable)

PER_TURN = 1.0 / TWO_PI


def compiled(inline: Literal["never", "always"] = "never") -> Callable[[F], F]:
    """numba's `njit` with NumPy's division rule, cached beside the function's module (or in
    the user's cache folder); where neither can be written, compiled afresh in each process instead."""

    def wrap(f: F) -> F:
        kernel: Any = njit(error_model="numpy", inline=inline)(f)
        if hasattr(kernel, "_compilation_chain_init_hook") and hasattr(kernel, "_types_active_call"):
            kernel._cache = _Cache(kernel.py_func)
            kernel._compilation_chain_init_hook = _no_extensions_yet
            kernel.typeof_pyval = functools.partial(_typeof_argument, kernel)
        else:  # a numba laid out otherwise: its own cache, where it finds a folder
            with suppress(RuntimeError):  # "cannot cache function ...: no locator available"
                kernel.enable_caching()
        return cast(F, kernel)

    return wrap


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
    part = path.with_name(f"{path.name}.{os.getpid()}")
    try:
        part.write_bytes(pickle.dumps(library.serialize_using_object_code()))
        os.replace(part, path)  # whole or not at all, whoever writes beside
    except OSError:  # a cache folder this process cannot write: compiled again next time
        part.unlink(missing_ok=True)
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

    One environment serves a function's every copy. A kernel linked into another (spin.laser_phases
    into sweep.sense) holds fewer constants there than alone, where returning an array needs
    its dtype too; numba keeps the first one loaded, so a kernel called alone after a kernel
    that links it failed to return ("'descr' is NULL"). The longer list is kept: the copies
    number their constants alike, the shorter list a prefix of the longer."""
    env = environment.lookup_environment(env_name)
    if env is None:
        module = sys.modules.get(modname)
        env = environment.Environment(module.__dict__ if module is not None else {})
        env.consts[:] = consts
        env.env_name = env_name
        environment.Environment._memo[env_name] = env
    elif len(env.consts) < len(consts):
        env.consts[:] = consts
    return env


def cached(kernel: Any) -> bool | None:
    """Whether numba's cache holds machine code of `kernel` (a `compiled` function) for its
    source as installed: False where its first call compiles it, None where that cannot be
    told (no cache, or a numba whose cache is laid out otherwise)."""
    cache: Any = getattr(kernel, "_cache", None)
    index: Any = getattr(cache, "_cache_file", None)
    if not hasattr(index, "_load_index") or not hasattr(cache, "_guard_against_spurious_io_errors"):
        return None
    with cache._guard_against_spurious_io_errors():
        return bool(index._load_index())  # empty when missing, of another numba, or of another source


@compiled(inline="always")
def maximum(a: float, b: float) -> float:
    """np.maximum of two floats: a NaN in either wins."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@compiled(inline="always")
def minimum(a: float, b: float) -> float:
    """np.minimum of two floats: a NaN in either wins."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@compiled(inline="always")
def sign(v: float) -> float:
    """np.sign of one float: 0, -0 and NaN are their own sign."""
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v


@compiled(inline="always")
def wrap_angle(a: float) -> float:
    """arena.angles.wrap_angle of one angle, to [-pi, pi], in a compiled loop."""
    return a - TWO_PI * np.rint(a * PER_TURN)
