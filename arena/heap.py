"""Objects a process keeps to its end (the modules it imports, numba's loaded kernels) kept out
of the cyclic garbage collector's way (decision 0043).

Importing numba and loading its compiled kernels makes several hundred thousand objects that
live until the process exits. Each full collection walks all of them, and the interpreter's
shutdown walks them again: a single `laserarena run` spent about 0.5 s of its 2 s on that.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def lasting() -> Iterator[None]:
    """Make objects that live as long as the process: the collector pauses while they are made
    (they are not garbage, so a collection would find nothing), and everything alive then is
    frozen (`gc.freeze`), so that no later collection walks it. Nested, the outermost one
    turns the collector back on."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was_on:
            gc.enable()
