"""The audit of a Dask cluster's workers: a share of their matches played again on the
organizer's machine and compared byte for byte (the result JSON and the replay), which works
because a match is deterministic (the same job gives the same bytes on the same kind of
processor, docs/cluster.md).

- Each match that comes back is audited with the given probability, drawn with `secrets`
  when it arrives: a worker cannot tell which of its matches will be.
- A worker's results are held until one of its matches has passed an audit; a worker whose
  results are all in without one has one of them, drawn with `secrets`, audited then. So
  every worker that played is audited at least once, and so is every run that used a cluster.
- A failed audit fails closed (`AuditFailed`): the worker's held results are dropped, and the
  caller removes those it kept earlier in the run (`discard`) before the one-line exit.
"""

from __future__ import annotations

import secrets
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from referee.contest.runner import MatchJob, Played
from referee.errors import UserError
from referee.terminal import safe

K = TypeVar("K", bound=Hashable)
RESOLUTION = 1_000_000  # the audit share is drawn in steps of one in a million


class AuditFailed(UserError, Generic[K]):
    """A worker's match differs from the organizer's re-simulation (one line, exit 2); `discard`:
    the keys of the results of that worker already handed out in this run."""

    def __init__(self, message: str, discard: list[K]):
        super().__init__(message)
        self.discard = discard


@dataclass
class _Worker(Generic[K]):
    """What the audit knows of one worker: whether one of its matches passed, its results
    held until one does, and the keys of those handed out."""

    trusted: bool = False
    held: list[tuple[K, MatchJob, Played]] = field(default_factory=list)
    kept: list[K] = field(default_factory=list)


class Audit(Generic[K]):
    """The audit of one run's matches on a cluster; `here` plays a job on this machine."""

    def __init__(self, share: float, here: Callable[[MatchJob], Played]):
        self.share = share
        self.here = here
        self.workers: dict[str, _Worker[K]] = {}

    def take(self, worker: str, key: K, job: MatchJob, played: Played) -> list[tuple[K, Played]]:
        """A checked result from `worker`: the results that may be kept now (this one, and
        the worker's held ones once it is trusted). AuditFailed when its audit fails."""
        w = self.workers.setdefault(worker, _Worker())
        w.held.append((key, job, played))
        if secrets.randbelow(RESOLUTION) < self.share * RESOLUTION:
            self._audit(worker, w, key, job, played)
        return self._release(w) if w.trusted else []

    def kept(self, worker: str) -> list[K]:
        """The keys of `worker`'s results handed out so far in this run."""
        w = self.workers.get(worker)
        return list(w.kept) if w else []

    def finish(self) -> list[tuple[K, Played]]:
        """Every result still held: for each worker never audited, one of its matches drawn
        at random is audited now. AuditFailed when one fails."""
        out = []
        for worker, w in self.workers.items():
            if w.held and not w.trusted:
                key, job, played = w.held[secrets.randbelow(len(w.held))]
                self._audit(worker, w, key, job, played)
            out += self._release(w)
        return out

    def _release(self, w: _Worker[K]) -> list[tuple[K, Played]]:
        out = [(key, played) for key, _, played in w.held]
        w.kept += [key for key, _ in out]
        w.held.clear()
        return out

    def _audit(self, worker: str, w: _Worker[K], key: K, job: MatchJob, played: Played) -> None:
        ours = self.here(job)
        differs = [
            name
            for name, a, b in (("result", ours.result, played.result), ("replay", ours.replay, played.replay))
            if a != b
        ]
        if differs:
            dropped = len(w.held) + len(w.kept)
            w.held.clear()
            raise AuditFailed(
                f"worker {safe(worker, 200)} failed its audit: its {' and '.join(differs)} of {safe(job.level, 60)} "
                f"seed {job.seed} differ from this machine's re-simulation; its {dropped} result(s) of this run "
                "were discarded; take it out of the cluster and run the command again (trusted results are kept)",
                list(w.kept),
            )
        w.trusted = True
