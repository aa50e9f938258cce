"""What a detector's electronics read, whatever its kind: the event clock (a counter, or none),
the encoder's angle latch, and when spurious pulses come (shiny surfaces, stray light,
electrical noise).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from arena.angles import TWO_PI
from arena.compiled import compiled


def quantize_angle(phase: np.ndarray, steps: float) -> np.ndarray:
    """Relative laser angle in [0, 2 pi), truncated to `steps` per turn (0: exact)."""
    rel = np.mod(phase, TWO_PI)
    if steps:
        q = TWO_PI / steps
        rel = np.floor(rel / q + 1e-9) * q
    return rel


def counter_clock(t: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Event times truncated to whole ticks of a `clock_hz` counter (none if 0)."""
    if p.get("clock_hz", 0.0) > 0:
        t = np.floor(t * p["clock_hz"] + 1e-6) / p["clock_hz"]
    return t


@compiled(inline="always")
def first_tick_after(t: float, clock_hz: float) -> float:
    """The earliest time after `t` that the event clock (a counter of `clock_hz`, or none if 0)
    can read: the next counter tick, or the next float. Compiled: a period's kernel reckons it
    too (sweep.sense_period)."""
    if clock_hz > 0:
        return (np.floor(t * clock_hz + 1e-6) + 1.0) / clock_hz
    return np.nextafter(t, np.inf)


def false_times(g: np.random.Generator, rate: float, t0: float, t1: float) -> np.ndarray:
    """When spurious pulses come between `t0` and `t1`: a Poisson process in time at `rate`
    (per s), sorted; none drawn past the count when there are none."""
    count = g.poisson(rate * (t1 - t0))
    if not count:
        return np.zeros(0)
    return np.sort(g.uniform(t0, t1, size=count))


_QUIET = np.zeros(0)  # no spurious pulse in a window
_MULT_BELOW = 10.0  # NumPy's Poisson draws by multiplying uniforms below this mean (above: PTRS)


class FalseClock:
    """`false_times` window after window from one stream (`g`), the same numbers and the same
    draws, at a fraction of a Generator call per window: most windows are quiet.

    Below a mean of 10, NumPy's Poisson multiplies uniforms until the product is at most
    exp(-mean): the count is 0 exactly when the first uniform is, and that uniform is the double
    `Generator.random` gives. So a block of them is drawn ahead (the stream's state kept from
    before it), and each quiet window takes the next. A window that is not quiet puts the stream
    back where its draws begin (the saved state, then one double per quiet window before it) and
    draws as `false_times` does; so may whatever the caller draws from `g` after it.

    The block and the count of it taken may live in the caller's arrays (`block`, a row of
    `ahead`; `used`, one element; `ahead` taken: none left), so that a compiled pass takes its
    quiet windows itself (`quiet`: sweep.sense_period) and calls nothing here."""

    def __init__(
        self,
        g: np.random.Generator,
        rate: float,
        ahead: int = 256,
        block: np.ndarray | None = None,
        used: np.ndarray | None = None,
    ):
        self.g, self.rate, self.ahead = g, rate, ahead
        self._saved: Mapping[str, Any] = {}
        self.block = np.zeros(ahead) if block is None else block  # uniforms drawn ahead from `_saved` on
        self.used = np.zeros(1, np.int64) if used is None else used  # of them, by quiet windows
        self.used[0] = ahead  # none drawn yet
        self._drawn = False  # whether the stream has moved past a block not yet given back (`times`)

    def times(self, t0: float, t1: float) -> np.ndarray:
        """`false_times(g, rate, t0, t1)`: when spurious pulses come between `t0` and `t1`."""
        mean = self.rate * (t1 - t0)
        if mean == 0.0:  # NumPy draws nothing for a mean of 0
            return _QUIET
        used = int(self.used[0])
        if mean < _MULT_BELOW:
            if used == self.ahead:
                self._saved = self.g.bit_generator.state
                self.g.random(out=self.block)
                self._drawn, used = True, 0
            if self.block[used] <= math.exp(-mean):
                self.used[0] = used + 1
                return _QUIET
        if self._drawn:  # the stream back to where this window's draws begin
            self.g.bit_generator.state = self._saved
            if used:
                self.g.random(used)
            self._drawn = False
        self.used[0] = self.ahead
        return false_times(self.g, self.rate, t0, t1)


@compiled(inline="always")
def quiet(blocks: np.ndarray, used: np.ndarray, rate: float, t0: float, t1: float) -> bool:
    """Whether the window from `t0` to `t1` is quiet for every `FalseClock` of `blocks` (a row
    each, `used[r]` of it taken), as `FalseClock.times` would find it; if so, each takes its
    uniform. All or none: where one window is not quiet, or a block is used up, nothing is
    taken, and `FalseClock.times` of each clock says what comes."""
    mean = rate * (t1 - t0)
    if blocks.shape[0] == 0 or mean == 0.0:
        return True
    if not mean < _MULT_BELOW:
        return False
    limit = math.exp(-mean)
    for r in range(blocks.shape[0]):
        if used[r] >= blocks.shape[1] or not blocks[r, used[r]] <= limit:
            return False
    for r in range(blocks.shape[0]):
        used[r] += 1
    return True
