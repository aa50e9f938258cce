"""The host uids controllers run as under a root referee: one per slot, leased, never derived
from a pid.

The kernel counts processes, keys and other per-user quotas by uid, so no two live controllers
may share one: not two slots of a match, not two matches that two threads of a referee play at
once, not two referees on one machine. Each thread of a referee leases the uids its slots use
at their first use, picked at random from `SLOT_UIDS` (no account uses them) and held by a lock
(`leases`) for as long as the referee process lives: two referees never hold the same, even in
PID namespaces of their own, and a killed referee's uids are free again at once. (Referees in
containers whose /run is private too each hold their own locks: they pick from 2^20 uids at
random.)
"""

from __future__ import annotations

import os
import secrets
import threading

from referee.sandbox import leases

SLOT_UIDS = range(1_800_000_000, 1_800_000_000 + (1 << 20))
KIND = "uids"  # the leases' folder
TRIES = 64  # uids drawn before giving up (each one held by another referee)
_thread = threading.local()


def _lease() -> leases.Lease:
    for _ in range(TRIES):
        held = leases.take(KIND, str(SLOT_UIDS[secrets.randbelow(len(SLOT_UIDS))]))
        if held is not None:
            return held
    raise OSError(f"no free uid among {TRIES} drawn from {SLOT_UIDS.start}..{SLOT_UIDS.stop - 1}")


def slot_uid(slot: int) -> int:
    """The uid controller `slot` of a match this thread plays runs as: leased on first use and
    held while this process lives (a forked child leases its own)."""
    if getattr(_thread, "pid", None) != os.getpid():
        _thread.pid, _thread.held = os.getpid(), list[leases.Lease]()
    held: list[leases.Lease] = _thread.held
    while len(held) <= slot:
        held.append(_lease())
    return int(held[slot].name)
