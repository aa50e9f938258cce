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

import threading
from collections.abc import Callable
from inspect import CO_VARARGS, CO_VARKEYWORDS
from typing import Any, Literal, TypeVar, cast

import numpy as np

from arena import _machine
from arena.angles import TWO_PI

__all__ = ["Kernel", "cached", "compiled", "maximum", "minimum", "sign", "wrap_angle"]

F = TypeVar("F", bound=Callable)

PER_TURN = 1.0 / TWO_PI

_kernels: list[Kernel] = []  # every kernel made in this process (their sources stamp the tables)


def compiled(
    inline: Literal["never", "always"] = "never", names: Callable[[], dict[str, Any]] | None = None
) -> Callable[[F], F]:
    """numba's `njit` with NumPy's division rule (`Kernel`): cached beside the function's
    module (or in the user's cache folder), and run without numba where an earlier process
    left its machine code for the arguments' types (arena._machine). `names` gives what the
    function's code names from numba itself (intrinsics), bound into its module where numba
    compiles it."""

    def wrap(f: F) -> F:
        own = type(f.__name__, (Kernel,), {})  # its call, its own (`Kernel._serve`)
        return cast(F, own(f, inline, names))

    return wrap


class Kernel:
    """A compiled function. A call runs the machine code of the arguments' types: loaded
    without numba from the kernel's table (arena._machine) where it holds them, else numba's
    (`dispatcher`, made on first need: importing numba takes a tenth of a second). Once numba
    has served a kernel in a process, it serves all its calls there, and what it compiled or
    loaded is added to the table (arena._numba.export).

    Each kernel is of a class of its own, whose `__call__` is the way its last call went
    (`_serve`): a form's caller, straight to its code (arena._machine.caller), or numba."""

    def __init__(
        self, py_func: Callable, inline: Literal["never", "always"], names: Callable[[], dict[str, Any]] | None = None
    ):
        self.py_func, self.inline, self.names = py_func, inline, names
        self.__name__, self.__qualname__ = py_func.__name__, py_func.__qualname__
        self.__doc__, self.__module__, self.__wrapped__ = py_func.__doc__, py_func.__module__, py_func
        self._dispatcher: Any = None
        self._table: _machine.Table | None | bool = False  # False: not read yet
        self._forms: dict[tuple[str, ...], tuple[Callable, Callable]] = {}  # loaded: caller, code
        code = py_func.__code__  # positional parameters alone, none with a default: a form's caller takes them
        self._plain = not (
            py_func.__defaults__ or code.co_kwonlyargcount or code.co_flags & (CO_VARARGS | CO_VARKEYWORDS)
        )
        self._lock = threading.Lock()
        _kernels.append(self)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:  # the first call's way
        return self._miss(args, kwargs)

    def __repr__(self) -> str:
        return f"<compiled kernel {self.__module__}.{self.__qualname__}>"

    @property
    def dispatcher(self) -> Any:
        """numba's dispatcher of this kernel (numba imported, and its cache made, on first use)."""
        if self._dispatcher is None:
            from arena import _numba

            with self._lock:
                if self._dispatcher is None:
                    self._dispatcher = _numba.dispatcher(self)
        return self._dispatcher

    @property
    def targetoptions(self) -> dict:
        """The options numba compiled it with (numba inlines a callee by them)."""
        return self.dispatcher.targetoptions

    def table(self) -> _machine.Table | None:
        """Its table of machine code (arena._machine), read once; None where there is none for
        this machine and these sources."""
        if self._table is False:
            self._table = _machine.read(self.py_func)
        return cast("_machine.Table | None", self._table)

    def _serve(self, way: Callable) -> None:
        """Make `way` this kernel's call (a method of its own class)."""
        if type(self) is not Kernel:
            type(self).__call__ = way  # type: ignore[method-assign]

    def _miss(self, args: tuple, kwargs: dict) -> Any:
        """A call the last way does not take: the form of its arguments' types, loaded on first
        need, else numba, from now on."""
        if self._dispatcher is None and self._plain and not kwargs:
            code = self._form(args)
            if code is not None:
                return code(*args)
        self._serve(Kernel._by_numba)
        return self._by_numba(*args, **kwargs)

    def _form(self, args: tuple) -> Callable | None:
        """The code of the table's form for the types of `args`, loaded on first need (its
        caller then serves this kernel's calls); None where the table has none."""
        named = tuple(map(_machine.type_name, args))
        if None in named:
            return None
        names = cast(tuple[str, ...], named)
        form = self._forms.get(names)
        if form is None:
            table = self.table()
            if table is None or names not in table.entries:
                return None
            try:
                loaded = _machine.load(table, names, self.py_func)
            except Exception:  # code LLVM cannot link here (a table of another numba's layout): numba's way
                self._table = None
                return None
            form = self._forms[names] = (_machine.caller(names, args, loaded, self._miss), loaded)
        self._serve(form[0])
        return form[1]

    def _by_numba(self, *args: Any, **kwargs: Any) -> Any:
        """numba's call; what it compiled or loaded for it is then added to the table."""
        made = self.dispatcher
        known = len(made.overloads)
        try:
            return made(*args, **kwargs)
        finally:  # a first call that raises has compiled the kernel all the same
            if len(made.overloads) != known:
                from arena import _numba

                _numba.export(self, made, _kernels)


def cached(kernel: Any) -> bool | None:
    """Whether `kernel` (a `compiled` function) runs from machine code already made for its
    source as installed: its table, else numba's cache (None where that cannot be told)."""
    table = kernel.table()
    if table is not None and table.entries:
        return True
    from arena import _numba

    return _numba.cached(kernel)


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
