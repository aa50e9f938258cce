"""A contest's Dask cluster as the organizer names it: the scheduler's address, the client's
keys, and the share of matches audited. Only `tls://` with the organizer's keys admits the
organizer's workers alone; a plain `tcp://` scheduler admits any machine that reaches it, so
it is refused unless the organizer says so (`--insecure-cluster`), and the results then say so.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from referee.contest.cluster_keys import Credentials, credentials
from referee.errors import UserError
from referee.terminal import safe

AUDIT_SHARE = 0.05  # the default share of a cluster's matches played again on the organizer's machine


@dataclass(frozen=True)
class Cluster:
    """Where a contest's matches run: the scheduler's address; the client's TLS material (None
    on an insecure `tcp://` cluster); the share of matches audited (0..1; at least one per run
    and one per worker whatever it is)."""

    address: str
    keys: Credentials | None
    audit: float = AUDIT_SHARE

    @property
    def insecure(self) -> bool:
        """Whether any machine that reaches the scheduler may join (`tcp://`, no keys)."""
        return self.keys is None


def cluster(
    address: str, keys: str | Path | None = None, insecure: bool = False, audit: float = AUDIT_SHARE
) -> Cluster:
    """The cluster at `address` (`tls://HOST:PORT` with the organizer's `keys` folder, or
    `tcp://HOST:PORT` with `insecure`), checked before any match: UserError (one line) else."""
    shown = safe(address, 200)
    if isinstance(audit, bool) or not isinstance(audit, (int, float)) or not 0 <= audit <= 1:
        raise UserError(f"--audit {audit!r}: a share of the matches, from 0 to 1 (0.05 is 5 %)")
    scheme, sep, _ = address.partition("://")
    scheme = scheme if sep else "tcp"  # Dask reads a bare HOST:PORT as tcp://
    if scheme == "tls":
        if keys is None:
            raise UserError(
                f"--scheduler {shown}: give --cluster-keys DIR, the keys `laserarena cluster-keys DIR` made"
            )
        return Cluster(address, credentials(Path(keys)), float(audit))
    if scheme == "tcp":
        if not insecure:
            raise UserError(
                f"--scheduler {shown}: a plain tcp:// cluster admits any machine that reaches it; "
                "use tls:// with --cluster-keys DIR (docs/cluster.md), or pass --insecure-cluster to accept that"
            )
        if keys is not None:
            raise UserError(f"--scheduler {shown}: tcp:// uses no --cluster-keys; give a tls:// address")
        return Cluster(address, None, float(audit))
    raise UserError(f"--scheduler {shown}: give tls://HOST:PORT (or tcp:// with --insecure-cluster)")
