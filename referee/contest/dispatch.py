"""Where a run's matches are played: in this process, on a local pool whose workers die with it
(`referee.contest.runner`), or on the organizer's Dask cluster (`referee.contest.remote`)."""

from __future__ import annotations

from collections.abc import Generator, Hashable
from typing import TYPE_CHECKING, TypeVar

from referee.contest.runner import MatchJob, Played, on_pool, play

if TYPE_CHECKING:
    from referee.contest.cluster import Cluster

K = TypeVar("K", bound=Hashable)


def run_jobs(
    todo: list[tuple[K, MatchJob]], workers: int = 1, cluster: Cluster | None = None
) -> Generator[tuple[K, Played]]:
    """Play every (key, job), yielding (key, played) as each finishes. Close the generator to
    stop: a local pool's workers end at once, and so do their matches; a cluster's courier too."""
    if cluster is not None:
        from referee.contest.remote import on_cluster  # Dask's courier: only where a cluster is named

        return on_cluster(todo, cluster)
    if workers <= 1:
        return ((key, play(job)) for key, job in todo)
    return on_pool(todo, workers)
