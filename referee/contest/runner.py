"""Playing many matches: in this process, on a local pool whose workers die with it, or on a
Dask cluster (`referee.contest.remote`). A job carries everything a match needs as data (the
level's text, each team's code as bytes, the seed and noise key); a worker returns the result
and the replay's bytes, and only the client writes files and the journal -- so Dask workers
need no shared folder, and a worker that dies mid-match is retried without its match ever
being counted twice.
"""

from __future__ import annotations

import ctypes
import functools
import os
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Generator, Hashable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from arena.heap import lasting
from referee.contest.shipping import arrived
from referee.errors import SandboxError, UserError
from referee.interrupts import Catcher
from referee.sandbox import forkserver, kernel
from referee.sandbox.teams import Team
from referee.version import __version__

if TYPE_CHECKING:
    from levels.model import Level

K = TypeVar("K", bound=Hashable)  # what the caller names each job by
LEVELS_KEPT = 8  # levels a worker keeps parsed: a grading run plays each level's matches in turn


@dataclass(frozen=True)
class MatchJob:
    """One match as data: the level file's name, bytes and sha256, the team of each slot (its
    code's bytes with it), the
    seed, the secret noise key (hex), ideal or not, the software version that must run it, and
    whether the organizer allows it to run without a kernel sandbox (`sandbox_missing`)."""

    level: str
    level_text: bytes
    level_hash: str
    teams: tuple[Team, ...]
    seed: int
    noise_key: str
    ideal: bool
    software: str
    unsandboxed: bool = False


@dataclass(frozen=True)
class Played:
    """A finished match: its canonical result JSON, the replay's bytes, the wall time it took,
    and why its controllers may have run without a kernel sandbox ("" when they ran in one):
    this machine's own reason, or on a cluster the organizer's `--unsandboxed`, never a
    worker's word."""

    result: str
    replay: bytes
    wall: float
    unsandboxed: str = ""


def sandbox_missing(allowed: bool) -> str:
    """Why no kernel sandbox can hold this machine's controllers ("" where one can). A contest
    fails closed: SandboxError (one line) unless the organizer `allowed` playing without one."""
    reason = kernel.unavailable() or ""
    if reason and not allowed:
        raise SandboxError(
            f"no kernel sandbox on this machine ({reason}); fix that, or pass --unsandboxed "
            "(unsandboxed=True in Python) to play without one, which the results then say"
        )
    return reason


class VersionMismatch(UserError):
    """A worker runs another LaserArena than the client: its results would not be comparable."""


@functools.lru_cache(maxsize=LEVELS_KEPT)
def _parsed(text: bytes, name: str) -> Level:
    """The level of a job, parsed once per worker for all the matches it plays on it (a Level
    is immutable all the way down; parsing and checking its YAML was a match's largest fixed
    cost after its controllers' start)."""
    from levels.loader import parse_level

    return parse_level(text, name)


def play(job: MatchJob) -> Played:
    """Run one job (in a worker), its replay in a scratch folder of its own."""
    forkserver.start()  # a root referee's template boots on the other CPU while a first match's modules load
    with lasting():  # numba's objects live as long as this process (arena.heap)
        from referee.match.loop import play_match
    from referee.records.canonical import dumps

    if job.software != __version__:
        raise VersionMismatch(f"a worker runs laserarena {__version__}, the client {job.software}; install the same")
    unsandboxed = sandbox_missing(job.unsandboxed)  # asked where the match runs: a Dask worker may differ
    start = time.perf_counter()
    level = _parsed(job.level_text, job.level)
    if level.hash != job.level_hash:
        raise UserError(f"{job.level}: the level arrived damaged")
    global _playing
    with tempfile.TemporaryDirectory(prefix="laserarena-job-") as scratch:
        teams = [arrived(team) for team in job.teams]
        replay = Path(scratch) / "match.replay"
        try:
            _playing = True
            result = play_match(level, teams, seed=job.seed, replay=replay, ideal=job.ideal, noise_key=job.noise_key)
        finally:
            _playing = False
            if STOP.raised:  # the match has stopped its controllers on the way out (a clean-up cut
                os._exit(143)  # short may raise something else); leave now, not back into the
                # pool's loop, which would wait for work for ever (so too if the stop was lost)
        data = replay.read_bytes()
    return Played(dumps(result), data, time.perf_counter() - start, unsandboxed)


def serve(job: MatchJob) -> dict[str, Any]:
    """`play` as a Dask worker runs it: only plain data goes back (msgpack's strings, bytes and
    floats; the client unpickles nothing a worker sends), and an error is a one-line reason
    rather than an exception, whose pickle the client would load."""
    try:
        played = play(job)
    except Exception as e:
        return {"error": " ".join(str(e).split())[:1000] or type(e).__name__}
    return {"result": played.result, "replay": played.replay, "wall": played.wall}


def file_part(text: str) -> str:
    """`text` (a level's or team's name) as part of a file name: letters, digits, `-`, `_` and
    `.` kept, anything else (`/`, a control character, a space) as `_`, no leading dot."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text).lstrip(".") or "_"


def write_replay(folder: Path, name: str, data: bytes) -> Path:
    """Write a replay (0600) into `folder` whole or not at all; return its path. `name` is a
    plain file name (its parts made with `file_part`): never a path into another folder."""
    if Path(name).name != name or name.startswith("."):
        raise ValueError(f"not a plain file name: {name!r}")
    path = folder / name
    part = folder / f".laserarena-{name}.part"
    fd = os.open(part, os.O_CREAT | os.O_TRUNC | os.O_WRONLY, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.replace(part, path)
    return path


def replay_folder(db: Path) -> Path:
    """The journal's replay folder (0700), cleared of replays a killed run left unfinished."""
    folder = db.resolve().parent / "replays"
    folder.mkdir(mode=0o700, exist_ok=True)
    os.chmod(folder, 0o700)
    for part in folder.glob(".laserarena-*.part"):  # we hold the journal's lock: no run writes these
        part.unlink(missing_ok=True)
    return folder


PR_SET_PDEATHSIG = 1
STOP_GRACE = 10.0  # seconds a stopped worker's match has to end its controllers; then it leaves regardless
_playing = False  # a pool worker is inside a match


class _Stopped(BaseException):
    """A pool worker was told to stop (SIGTERM) in the middle of a match."""


def _stopping() -> None:
    """A pool worker told to stop: out of a match, it leaves at once; in one, it leaves within
    STOP_GRACE seconds whatever the match's clean-up does (which `_Stopped` starts)."""
    if not _playing:
        os._exit(143)
    leave = threading.Timer(STOP_GRACE, os._exit, (143,))
    leave.daemon = True
    leave.start()


STOP = Catcher(_Stopped, (signal.SIGTERM,), before=_stopping)  # installed in each pool worker


def die_with_parent(parent: int) -> None:
    """Have the kernel send this process SIGTERM when its parent (pid `parent`) dies, however
    it dies (SIGKILL too); leave at once if it has died already. Linux only (elsewhere nothing)."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
        if os.getppid() != parent:  # the parent died before the line above: follow it now
            os._exit(143)


def _worker_init(parent: int) -> None:
    """In each pool worker: die with the grading process, however it ends (even SIGKILL).
    The kernel sends SIGTERM when the parent goes; SIGTERM ends the match cleanly (its
    controllers are stopped by the match's own clean-up). Ctrl-C is the parent's to handle.
    (No parent-death signal outside Linux: there the pool's own shutdown ends the workers.)
    Then import what its matches need, once, out of the collector's way (arena.heap)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    STOP.install()
    die_with_parent(parent)
    with lasting():
        import referee.match.loop  # noqa: F401


def on_pool(todo: list[tuple[K, MatchJob]], workers: int) -> Generator[tuple[K, Played]]:
    # spawn, never fork: a forked worker would inherit the parent's state
    pool = ProcessPoolExecutor(
        max_workers=workers, mp_context=get_context("spawn"), initializer=_worker_init, initargs=(os.getpid(),)
    )
    try:
        futures = {pool.submit(play, job): key for key, job in todo}
        for f in as_completed(futures):
            yield futures[f], f.result()
    except BaseException:
        # stop now, not after the running matches: end the workers (each stops its match)
        for proc in list(getattr(pool, "_processes", {}).values()):
            proc.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def worker_version() -> str:
    """The LaserArena version installed where this runs (asked of every Dask worker)."""
    return __version__
