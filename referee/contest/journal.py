"""The SQLite journal of finished matches: one file (0600) per grading or tournament run, held by
one run at a time, every finished match committed at once so a killed run resumes where it
stopped. `matches` holds grading's one-team matches, `heats` a tournament's heats; a row is
keyed by everything its result depends on, so an edited team or level is run again and an old
row never mixes in. The run's noise secret lives in `meta` (docs/integrity.md).

The journal keeps SQLite's rollback journal (`journal_mode=DELETE`), never a write-ahead log:
once a commit returns, the `.sqlite` file alone holds it, so a copy of that one file, even
of a run killed with SIGKILL, holds every finished match. A journal left in WAL mode by an
older version is turned back when it is opened.
"""

from __future__ import annotations

import json
import os
import secrets
import sqlite3
import time
import warnings
from collections.abc import Iterable, Iterator
from contextlib import closing, contextmanager
from pathlib import Path
from typing import Protocol, TypeVar

from referee.errors import LaserArenaWarning, UserError
from referee.interrupts import Interrupted
from referee.terminal import safe

SCHEMA_VERSION = 2
SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS matches (
    level TEXT NOT NULL, level_hash TEXT NOT NULL, team TEXT NOT NULL, code_hash TEXT NOT NULL,
    seed INTEGER NOT NULL, software TEXT NOT NULL, ideal INTEGER NOT NULL, secret_id TEXT NOT NULL,
    result TEXT NOT NULL, replay TEXT NOT NULL, wall_seconds REAL NOT NULL, graded_at REAL NOT NULL,
    PRIMARY KEY (level_hash, team, code_hash, seed, software, ideal, secret_id)
);
CREATE TABLE IF NOT EXISTS heats (
    level TEXT NOT NULL, level_hash TEXT NOT NULL, lineup TEXT NOT NULL, seed INTEGER NOT NULL,
    software TEXT NOT NULL, ideal INTEGER NOT NULL, secret_id TEXT NOT NULL,
    result TEXT NOT NULL, replay TEXT NOT NULL, wall_seconds REAL NOT NULL, graded_at REAL NOT NULL,
    PRIMARY KEY (level_hash, lineup, seed, software, ideal, secret_id)
);
"""
BUSY_SECONDS = 60  # how long a commit waits for a reader of the file (a backup, a query) to finish
KEY = "level_hash, team, code_hash, seed, software, ideal, secret_id"


HEAT_KEY = "level_hash, lineup, seed, software, ideal, secret_id"


class Keyed(Protocol):
    """A graded match as the journal files it: its level's name and its KEY tuple."""

    @property
    def level(self) -> str: ...

    def key(self) -> tuple: ...


J = TypeVar("J", bound=Keyed)


def _private_file(path: Path) -> None:
    """Create `path` (0600) unless it exists; tighten it to 0600 if it does."""
    try:
        os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
    except FileExistsError:
        if not path.is_file():
            raise UserError(f"{path}: not a journal file") from None
        os.chmod(path, 0o600)


class Journal:
    """The SQLite journal of finished matches (0600), held by one grading run at a time."""

    def __init__(self, path: Path):
        self.path = path
        try:
            _private_file(path)
            self.lock = open(path, "rb")
        except OSError as e:
            raise UserError(f"{path}: cannot open the journal: {e.strerror or e}") from None
        try:
            import fcntl  # POSIX only: without it (Windows) two runs on one journal are not kept apart

            fcntl.flock(self.lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:
            warnings.warn(f"{path}: no file locks here; run one grading per journal", LaserArenaWarning, stacklevel=2)
        except BlockingIOError:
            raise UserError(f"{path}: another grading run is using this journal") from None
        try:
            self.db = sqlite3.connect(path, timeout=BUSY_SECONDS)
            version = self.db.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if version != SCHEMA_VERSION and tables:
                raise UserError(
                    f"{path}: a journal of another LaserArena version (schema {version}, "
                    f"this is {SCHEMA_VERSION}); grade into a new --db"
                )
            self.db.execute("PRAGMA journal_mode=DELETE")  # the file alone holds every commit (module doc)
            self.db.executescript(SCHEMA)
            self.db.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
            self.db.commit()
        except sqlite3.DatabaseError as e:
            raise UserError(f"{path}: not a readable LaserArena journal ({e})") from None

    def close(self) -> None:
        """Close the database and let go of the run's lock."""
        self.db.close()
        self.lock.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _query(self, sql: str, args: tuple = ()) -> list:
        try:
            return self.db.execute(sql, args).fetchall()
        except sqlite3.DatabaseError as e:
            raise UserError(f"{self.path}: a damaged journal ({e})") from None

    def secret(self, given: str | None) -> str:
        """The run's noise secret: `given`, else the journal's own (made on first use with
        `secrets`, kept in the journal so a resumed run draws the same noise)."""
        if given:
            return given
        row = self._query("SELECT value FROM meta WHERE key='secret'")
        if row:
            return row[0][0]
        made = secrets.token_hex(32)
        self.db.execute("INSERT INTO meta VALUES ('secret', ?)", (made,))
        self.db.commit()
        return made

    def note_unsandboxed(self, reason: str) -> None:
        """Record that a match of this journal ran without a kernel sandbox, and why (for good:
        every leaderboard or report made from it says so)."""
        self.db.execute("INSERT OR REPLACE INTO meta VALUES ('unsandboxed', ?)", (reason,))
        self.db.commit()

    def unsandboxed(self) -> str | None:
        """Why some match of this journal ran without a kernel sandbox, or None if none did."""
        row = self._query("SELECT value FROM meta WHERE key='unsandboxed'")
        return row[0][0] if row else None

    def note_insecure_cluster(self, address: str) -> None:
        """Record that matches of this journal were played on a Dask cluster any machine could
        join (`--insecure-cluster`), and where (for good, as `note_unsandboxed`)."""
        self.db.execute("INSERT OR REPLACE INTO meta VALUES ('insecure_cluster', ?)", (address,))
        self.db.commit()

    def insecure_cluster(self) -> str | None:
        """The insecure cluster's address some match of this journal was played on, or None."""
        row = self._query("SELECT value FROM meta WHERE key='insecure_cluster'")
        return row[0][0] if row else None

    def forget(self, keys: Iterable[tuple], heats: bool = False) -> None:
        """Delete the rows of these keys (of `heats`, else of graded matches): results found
        untrustworthy after they were recorded (a worker that failed its audit)."""
        table, columns = ("heats", HEAT_KEY) if heats else ("matches", KEY)
        where = " AND ".join(f"{k.strip()}=?" for k in columns.split(","))
        self.db.executemany(f"DELETE FROM {table} WHERE {where}", list(keys))
        self.db.commit()

    def done(self) -> set[tuple]:
        return {tuple(r) for r in self._query(f"SELECT {KEY} FROM matches")}

    def record(self, job: Keyed, result: str, replay: str, wall: float) -> None:
        """Commit one finished graded match."""
        self.db.execute(
            "INSERT OR REPLACE INTO matches VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (job.level, *job.key(), result, replay, wall, time.time()),
        )
        self.db.commit()  # at once: a killed run loses nothing that finished

    def results(self, jobs: Iterable[J]) -> list[tuple[J, dict]]:
        out = []
        where = " AND ".join(f"{k.strip()}=?" for k in KEY.split(","))
        for job in jobs:
            key = job.key()
            row = self._query(f"SELECT result FROM matches WHERE {where}", key)
            if row:
                try:
                    out.append((job, json.loads(row[0][0])))
                except ValueError:
                    raise UserError(f"{self.path}: a damaged result for {safe(key[1])} seed {key[3]}") from None
        return out

    def heats_done(self) -> set[tuple]:
        """The keys of the tournament heats already in the journal."""
        return {tuple(r) for r in self._query(f"SELECT {HEAT_KEY} FROM heats")}

    def record_heat(self, level: str, key: tuple, result: str, replay: str, wall: float) -> None:
        """Commit one finished heat; `key` is its HEAT_KEY tuple."""
        self.db.execute(
            "INSERT OR REPLACE INTO heats VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (level, *key, result, replay, wall, time.time()),
        )
        self.db.commit()  # at once: a killed run loses nothing that finished

    @contextmanager
    def keeping(self, keys: list[tuple], noun: str, heats: bool = False) -> Iterator[None]:
        """Run the block; a Ctrl-C (or SIGTERM) in it ends it as `Interrupted`, saying how
        many of `keys` (of `heats`, else of graded matches) finished and are kept: what the
        same command resumes."""
        try:
            yield
        except Interrupted:
            raise
        except KeyboardInterrupt:
            self.db.rollback()  # a row whose commit the interrupt cut short is not kept
            done = self.heats_done() if heats else self.done()
            kept = counted(sum(k in done for k in keys), f"finished {noun}")
            raise Interrupted(f"{kept} kept in the journal {self.path}; the same command resumes") from None

    def heat(self, key: tuple) -> tuple[dict, str, float] | None:
        """A finished heat's result, replay path and wall time, or None if it has not run."""
        where = " AND ".join(f"{k.strip()}=?" for k in HEAT_KEY.split(","))
        row = self._query(f"SELECT result, replay, wall_seconds FROM heats WHERE {where}", key)
        if not row:
            return None
        try:
            return json.loads(row[0][0]), row[0][1], row[0][2]
        except ValueError:
            raise UserError(f"{self.path}: a damaged heat result ({safe(key[0])} seed {key[2]})") from None


def counted(n: int, noun: str) -> str:
    """`1 match`, `2 matches`, `3 heats`."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}{'es' if noun.endswith('ch') else 's'}"


def account(total: int, noun: str, ran: int, path: str | Path) -> str:
    """What a grade or tournament says of its journal once done, in the same words for both:
    `9 heats in the journal t.sqlite (4 resumed, 5 run now)`; `resumed`: found there finished,
    not run again (left out when none was)."""
    resumed = f"{total - ran} resumed, " if total > ran else ""
    return f"{counted(total, noun)} in the journal {path} ({resumed}{ran} run now)"


def _existing(path: Path) -> sqlite3.Connection:
    """The journal at `path`, opened to be read (a run may be writing it meanwhile) but never
    made: writable where the file is, so that SQLite can undo a commit a kill cut short (a hot
    `-journal` beside it), which a read-only connection cannot read past."""
    if not path.is_file():
        raise UserError(f"{path}: no such journal")
    return sqlite3.connect(f"{path.resolve().as_uri()}?mode=rw", uri=True, timeout=BUSY_SECONDS)


def stored_secret(path: Path) -> str:
    """The noise secret the journal at `path` made for itself (what its runs without
    --secret-file drew their noise from); UserError if it holds none."""
    with closing(_existing(path)) as db:
        try:
            row = db.execute("SELECT value FROM meta WHERE key='secret'").fetchone()
        except sqlite3.DatabaseError as e:
            raise UserError(f"{path}: not a readable LaserArena journal ({e})") from None
    if row is None:
        raise UserError(f"{path}: the journal holds no secret of its own (its runs were given --secret-file)")
    return row[0]


def backup(path: Path, out: Path) -> tuple[int, int]:
    """Copy the journal at `path` into the new file `out` with SQLite's online backup, which
    copies a consistent state even while a run commits to it; return the copy's finished
    matches and heats. `out` is made 0600 (it holds the secret) and never replaces a file."""
    with closing(_existing(path)) as db:
        try:
            fd = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        except FileExistsError:
            raise UserError(f"{out}: exists; give a new file for the backup") from None
        os.close(fd)
        try:
            with closing(sqlite3.connect(out)) as copy:
                db.backup(copy)
                copy.execute("PRAGMA journal_mode=DELETE")  # a copy of a WAL journal is one file too
                matches, heats = (copy.execute(f"SELECT COUNT(*) FROM {t}").fetchone()[0] for t in ("matches", "heats"))
                return matches, heats
        except sqlite3.DatabaseError as e:
            out.unlink()
            raise UserError(f"{path}: not a readable LaserArena journal ({e})") from None
        except BaseException:
            out.unlink()
            raise
