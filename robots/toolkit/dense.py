"""Small dense linear algebra for the solvers: NumPy's own LAPACK routines, called directly.

`np.linalg` checks and converts its arguments on every call, which costs several times what
LAPACK takes for a 3 x 3 system; a controller solving a fix at every laser pulse pays it
thousands of times per simulated second. These call the same routines (NumPy's
`_umath_linalg` gufuncs) with the same arguments, so the numbers are the same bits, for
float64 matrices the caller has already built. Where that private module is missing or
differs, the public functions are used.
"""

from __future__ import annotations

import numpy as np

try:
    from numpy.linalg import _umath_linalg as _gufuncs

    _DIRECT = all(hasattr(_gufuncs, name) for name in ("lstsq", "svd", "inv"))
except ImportError:  # a NumPy without the module: the public functions, same routines
    _DIRECT = False

_EPS = float(np.finfo(np.float64).eps)


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
