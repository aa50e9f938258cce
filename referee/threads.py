"""One BLAS thread in every LaserArena process: the referee's and the controllers' arrays are
small, and each spare OpenBLAS thread spins for about a tenth of a second of CPU once NumPy
loads (and after each threaded call), on a machine the controllers share."""

from __future__ import annotations

import os

ONE_BLAS_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def one_blas_thread() -> None:
    """Ask for one BLAS thread in this process, unless the user set a number: call it before
    NumPy loads (later, it still reaches the processes this one starts)."""
    for name, value in ONE_BLAS_THREAD.items():
        if name not in os.environ:
            os.environ[name] = value
