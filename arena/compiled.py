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

import sys
from collections.abc import Callable
from typing import Any, Literal, TypeVar, cast

import numpy as np
from numba import njit
from numba.core import environment
from numba.core.runtime import rtsys

from arena.angles import TWO_PI

F = TypeVar("F", bound=Callable)

PER_TURN = 1.0 / TWO_PI


def compiled(inline: Literal["never", "always"] = "never") -> Callable[[F], F]:
    """numba's `njit` with NumPy's division rule, cached beside the function's module (or in
    the user's cache folder); where neither can be written, compiled afresh in each process instead."""

    def wrap(f: F) -> F:
        try:
            kernel = njit(cache=True, error_model="numpy", inline=inline)(f)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return cast(F, njit(error_model="numpy", inline=inline)(f))
        cache: Any = getattr(kernel, "_cache", None)  # numba's cache of this kernel
        if hasattr(cache, "_load_overload") and hasattr(cache, "_guard_against_spurious_io_errors"):
            cache.load_overload = lambda sig, target_context: _load_cached(cache, sig, target_context)
        return cast(F, kernel)

    return wrap


def _load_cached(cache: Any, sig: Any, target_context: Any) -> Any:
    """numba's `Cache.load_overload` (the kernel's machine code for `sig` from its cache, or
    None) without its refresh of the target context: numba refreshes the context (importing
    and installing every typing and lowering registry) so that it could compile, and compiling
    refreshes it anyway; rebuilding cached code needs only the runtime (NRT) it links to. Its
    environments are rebuilt without importing modules (`_environment`)."""
    rtsys.initialize(target_context)
    with cache._guard_against_spurious_io_errors():
        rebuild = environment._rebuild_env  # what the cache's pickles call, looked up as they load
        environment._rebuild_env = _environment
        try:
            return cache._load_overload(sig, target_context)
        finally:
            environment._rebuild_env = rebuild


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
