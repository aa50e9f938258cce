"""Many floats as the replay's text holds them, in one compiled call: each as `%.9f` writes it
(DECIMALS places), its trailing zeros dropped (one kept after the point), a newline after each
(referee.records.replay_lines `numbers`, decision 0042).

`%.9f` is correctly rounded, ties to even: the decimal nearest the float's exact value at nine
places. So is this: the product of a float and 1e9 is taken exactly (its rounded value plus the
rounding's error, by Dekker's product: 1e9 has 21 significant bits, so each partial product is
exact), and the integer nearest it chosen from the two, a tie going to the even one. Values it
does not write (a `number` of their own writes them): a NaN or an infinity, a magnitude of 1e6
or more, and one whose text would start 0.0000 (zero, or nonzero but below 1e-4 once rounded),
which JSON writes in its own form.
"""

from __future__ import annotations

import numpy as np

from arena.compiled import compiled
from referee.records.canonical import DECIMALS

NOT_FINITE = -2  # a NaN or an infinity among the values
OWN_FORM = -1  # a value this does not write: each is written by `number`
MOST = 1e6  # values written are smaller than this in magnitude
LEAST = 100_000  # and, rounded, at least this many billionths (1e-4)
WIDTH = 10 + DECIMALS  # bytes a value may take: sign, 7 digits, point, the places, newline
_SPLIT = 134217729.0  # 2**27 + 1, Veltkamp's splitting constant for doubles
_PLACES = 10**DECIMALS  # 5**9 has 21 significant bits: Dekker's partial products stay exact
_SCALE = float(_PLACES)


@compiled()
def write_fixed(values: np.ndarray, out: np.ndarray) -> int:
    """Write every value of `values` into `out` (uint8, WIDTH bytes a value at least), as
    described above; the bytes written, or NOT_FINITE or OWN_FORM (nothing usable written)."""
    at = 0
    digits = np.empty(16, np.uint8)
    for v in values:
        if not np.isfinite(v):
            return NOT_FINITE
        a = abs(v)
        if a >= MOST:
            return OWN_FORM
        p = a * _SCALE  # rounded; its error, exactly:
        c = _SPLIT * a
        high = c - (c - a)
        low = a - high
        error = (high * _SCALE - p) + low * _SCALE
        whole = np.floor(p)
        half = (p - whole) - 0.5  # exact: both are multiples of p's last place
        r = np.int64(whole)
        if half > -error or (half == -error and r % 2 == 1):
            r += 1
        if r < LEAST:
            return OWN_FORM
        if v < 0:
            out[at] = 45  # -
            at += 1
        units, fraction = r // _PLACES, r % _PLACES
        n = 0
        while True:
            digits[n] = 48 + units % 10
            units //= 10
            n += 1
            if units == 0:
                break
        for k in range(n - 1, -1, -1):
            out[at] = digits[k]
            at += 1
        out[at] = 46  # .
        at += 1
        places = DECIMALS
        while places > 1 and fraction % 10 == 0:
            fraction //= 10
            places -= 1
        for k in range(places - 1, -1, -1):
            out[at + k] = 48 + fraction % 10
            fraction //= 10
        at += places
        out[at] = 10  # newline
        at += 1
    return at
