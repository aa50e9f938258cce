"""Small dense linear algebra for the solvers: NumPy's own LAPACK routines, called directly.

`np.linalg` checks and converts its arguments on every call, which costs several times what
LAPACK takes for a 3 x 3 system; a controller solving a fix at every laser pulse pays it
thousands of times per simulated second. These call the same routines (NumPy's
`_umath_linalg` gufuncs) with the same arguments, so the numbers are the same bits, for
float64 matrices the caller has already built. Where that private module is missing or
differs, the public functions are used. A Newton iteration's least-squares solve, once per
step, goes further: LAPACK's routine itself, through ctypes, with buffers made once
(`lstsq_solver`).
"""

from __future__ import annotations

import ctypes
import struct
import sys
import threading
from collections.abc import Callable

import numpy as np

try:
    from numpy.linalg import _umath_linalg as _gufuncs

    _DIRECT = all(hasattr(_gufuncs, name) for name in ("lstsq", "svd", "inv"))
except ImportError:  # a NumPy without the module: the public functions, same routines
    _DIRECT = False

_EPS = float(np.finfo(np.float64).eps)
# LAPACK's least-squares routine as NumPy's own wheels link it (scipy-openblas, 64-bit integers)
_DGELSD = "scipy_dgelsd_64_"
_per_thread = threading.local()  # each thread's solvers (`lstsq_solver`)


def _raise(kind: str, flag: int) -> None:
    raise np.linalg.LinAlgError("a LAPACK routine did not converge or met a singular matrix")


def _guard() -> np.errstate:
    """NumPy's rule for these routines: a failure (signalled as invalid) raises LinAlgError."""
    return np.errstate(call=_raise, invalid="call", over="ignore", divide="ignore", under="ignore")


def lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least-squares solution x of a x = b (a: m x n float64, b: m), as
    `np.linalg.lstsq(a, b, rcond=None)[0]`."""
    if not _DIRECT:
        return np.linalg.lstsq(a, b, rcond=None)[0]
    m, n = a.shape
    with _guard():
        x = _gufuncs.lstsq(a, b[:, None], _EPS * max(n, m), signature="ddd->ddid")[0]
    return x[:, 0]


class _Dgelsd:
    """dgelsd for m x n systems with one right-hand side, called through ctypes with its
    arguments, buffers and workspace made once: what NumPy's lstsq passes (rcond eps * max(m, n),
    the workspace LAPACK asks for), without the gufunc's copies, workspace query and checks on
    every call."""

    def __init__(self, routine: Callable[..., None], m: int, n: int):
        ld = max(m, n)
        self.routine = routine
        # m, n, nrhs, lda, ldb, rank, lwork (-1: ask), info
        self.ints = np.array([m, n, 1, m, ld, 0, -1, 0], dtype=np.int64)
        self.a, self.b = np.zeros(m * n), np.zeros(ld)
        self.s, self.rcond = np.zeros(min(m, n)), np.array([_EPS * ld])
        self.work, self.iwork = np.zeros(1), np.zeros(1, dtype=np.int64)
        routine(*self._arguments())  # the workspace query
        self.work = np.zeros(max(1, int(self.work[0])))
        self.iwork = np.zeros(max(1, int(self.iwork[0])), dtype=np.int64)
        self.ints[6] = len(self.work)
        self.args = self._arguments()
        self.a_bytes, self.b_bytes = self.a.data.cast("B"), self.b.data.cast("B")
        self.a_packing, self.b_packing = struct.Struct(f"{m * n}d"), struct.Struct(f"{m}d")
        self.x_packing = struct.Struct(f"{n}d")

    def _arguments(self) -> tuple[int, ...]:
        """dgelsd's fourteen arguments, every one a pointer (Fortran passes all by reference)."""
        i = [self.ints.ctypes.data + 8 * k for k in range(8)]
        a, b, s, rcond = self.a.ctypes.data, self.b.ctypes.data, self.s.ctypes.data, self.rcond.ctypes.data
        return (
            i[0],
            i[1],
            i[2],
            a,
            i[3],
            b,
            i[4],
            s,
            rcond,
            i[5],
            self.work.ctypes.data,
            i[6],
            self.iwork.ctypes.data,
            i[7],
        )

    def solve(self, columns: list[float], b: list[float]) -> tuple[float, ...]:
        self.a_packing.pack_into(self.a_bytes, 0, *columns)
        self.b_packing.pack_into(self.b_bytes, 0, *b)
        self.routine(*self.args)
        if self.ints[7]:
            raise np.linalg.LinAlgError("a LAPACK routine did not converge or met a singular matrix")
        return self.x_packing.unpack_from(self.b_bytes)


def _gufunc_solver(m: int, n: int) -> Callable[[list[float], list[float]], tuple[float, ...]]:
    def solve(columns: list[float], b: list[float]) -> tuple[float, ...]:
        return tuple(lstsq(np.array(columns).reshape(n, m).T, np.array(b)).tolist())

    return solve


def _dgelsd() -> Callable[..., None] | None:
    """NumPy's own dgelsd, where its LAPACK is the one its wheels ship (else None)."""
    if not _DIRECT or sys.byteorder != "little":
        return None
    try:
        routine = getattr(ctypes.CDLL(_gufuncs.__file__), _DGELSD)  # found among the module's own libraries
    except (OSError, AttributeError):
        return None
    routine.argtypes, routine.restype = [ctypes.c_void_p] * 14, None
    return routine


def lstsq_solver(m: int, n: int) -> Callable[[list[float], list[float]], tuple[float, ...]]:
    """A solver of m x n least-squares systems a x = b, for a Newton iteration that solves one
    at every step: `solve(columns, b)` takes a's columns one after the other as a flat list
    (a[:, 0], a[:, 1], ...) and b, and gives x as `np.linalg.lstsq(a, b, rcond=None)[0]` does,
    bit for bit. NumPy's own LAPACK routine is called directly where it can be found and gives
    NumPy's answers on a probe; otherwise through NumPy. Each thread has solvers of its own
    (they keep buffers)."""
    solvers = _per_thread.__dict__.setdefault("solvers", {})
    solve = solvers.get((m, n))
    if solve is None:
        solve = solvers[(m, n)] = _new_solver(m, n)
    return solve


def _new_solver(m: int, n: int) -> Callable[[list[float], list[float]], tuple[float, ...]]:
    routine = _dgelsd()
    if routine is None:
        return _gufunc_solver(m, n)
    direct = _Dgelsd(routine, m, n)
    probe = np.random.default_rng(m * 1000 + n).normal(size=(m, n + 1))
    columns, b = probe[:, :n].T.ravel().tolist(), probe[:, n].tolist()
    if direct.solve(columns, b) != _gufunc_solver(m, n)(columns, b):
        return _gufunc_solver(m, n)
    return direct.solve


def condition(a: np.ndarray) -> float:
    """The 2-norm condition number of `a` (float64, 2-D), as `np.linalg.cond(a)`: the largest
    singular value over the smallest; infinite where that is 0/0 and `a` holds no NaN."""
    if not _DIRECT:
        return float(np.linalg.cond(a))
    with _guard():
        s = _gufuncs.svd(a, signature="d->d")
    with np.errstate(all="ignore"):
        r = s[0] / s[-1]
    if np.isnan(r) and not np.isnan(a).any():
        return float("inf")
    return float(r)


def inverse(a: np.ndarray) -> np.ndarray:
    """The inverse of a square float64 matrix, as `np.linalg.inv`; LinAlgError if singular."""
    if not _DIRECT:
        return np.linalg.inv(a)
    with _guard():
        return _gufuncs.inv(a, signature="d->d")
