"""A journal that is whole: after `grade` or `tournament`, even one stopped by a signal, the
`.sqlite` file alone (copied without any -wal, -shm or -journal beside it) holds every finished
match; a journal an older version left in WAL mode is made whole when opened; `journal
backup` copies one safely."""

import os
import re
import shutil
import signal
import sqlite3
import stat
import subprocess
import sys
import time

import pytest
from helpers import MINI_LEVEL, alive, run_cli, secret_file, stop_point

SIDE_FILES = ("-wal", "-shm", "-journal")
SLOW_TEAM = """
import time
from robots.api import Command, Controller

class Slow(Controller):
    def step(self, obs):
        time.sleep(0.01)
        return Command(0.02, 0.03)
"""


@pytest.fixture
def folder(shared_dir):
    """A folder holding the short level and a slow team (controllers, as `nobody`, read it)."""
    (shared_dir / "mini.yaml").write_text(MINI_LEVEL)
    (shared_dir / "slow.py").write_text(SLOW_TEAM)
    for p in shared_dir.iterdir():
        p.chmod(0o755)
    return shared_dir


def alone(db):
    """The journal file copied alone into a folder of its own, as an organizer copies "the
    journal"; what it holds is read from the copy."""
    assert not [s for s in SIDE_FILES if os.path.exists(f"{db}{s}")], os.listdir(os.path.dirname(db))
    copy = db.parent / "copied" / db.name
    copy.parent.mkdir()
    shutil.copyfile(db, copy)
    return copy


def rows(db, table="matches"):
    with sqlite3.connect(db) as c:
        column = "team" if table == "matches" else "lineup"
        return sorted(c.execute(f"SELECT level_hash, {column}, seed, graded_at FROM {table}"))


def reported(proc, what):
    """The count the command's last line reports (`N matches in the journal ...`)."""
    return int(re.search(rf"(\d+) {what} .*in the journal", proc.stderr).group(1))


def test_after_a_grade_the_journal_file_alone_holds_every_match(folder):
    proc = run_cli(
        "grade", "mini.yaml", "--team", "ref:dead-reckoning", "--team", "ref:idle", "--seeds", "3",
        "--workers", "2", "--db", "j.sqlite", "--out", "lb.csv", "--secret-file", secret_file("whole"),
        cwd=folder,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = rows(alone(folder / "j.sqlite"))
    assert len(got) == reported(proc, "matches") == 6
    assert sorted((r[1], r[2]) for r in got) == sorted(
        (t, s) for t in ("ref:dead-reckoning", "ref:idle") for s in (1, 2, 3)
    )
    with sqlite3.connect(folder / "copied" / "j.sqlite") as c:
        assert c.execute("PRAGMA journal_mode").fetchone() == ("delete",)


def test_after_a_tournament_the_journal_file_alone_holds_every_heat(folder):
    proc = run_cli(
        "tournament", "mini.yaml", "--team", "ref:dead-reckoning", "--team", "ref:idle", "--rounds", "2",
        "--db", "t.sqlite", "--out", "site", "--secret-file", secret_file("whole"),
        cwd=folder,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    heats = rows(alone(folder / "t.sqlite"), "heats")
    published = {line.split(",")[0] for line in (folder / "site" / "heats.csv").read_text().splitlines()[1:]}
    assert len(heats) == reported(proc, "heats") == len(published) == 4


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_a_stopped_grade_leaves_every_finished_match_in_the_file_alone(folder, sig):
    args = ["grade", "mini.yaml", "--team", "slow.py", "--seeds", "6", "--workers", "2", "--quiet"]
    args += ["--db", "j.sqlite", "--out", "lb.csv", "--secret-file", secret_file("stopped")]
    db = folder / "j.sqlite"
    proc = subprocess.Popen([sys.executable, "-m", "referee", *args], cwd=folder, stderr=subprocess.PIPE, text=True)
    below = stop_point(proc, db)
    assert proc.poll() is None, "the stop came mid-way"
    stopped_at = time.time()
    os.kill(proc.pid, sig)  # the grader alone
    assert proc.wait(timeout=60) == (-9 if sig == signal.SIGKILL else 130)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and any(alive(p, s) for p, s in below.items()):
        time.sleep(0.05)
    copied = db
    if sig == signal.SIGKILL and os.path.exists(f"{db}-journal"):
        # the kill cut a commit (two workers' matches end together): the file alone is whole
        # once SQLite has undone it from the hot journal, as `journal backup` does (docs/integrity.md)
        assert run_cli("journal", "backup", "j.sqlite", "saved.sqlite", cwd=folder).returncode == 0
        copied = folder / "saved.sqlite"
    kept = rows(alone(copied))
    assert 1 <= len(kept) < 6
    # a second, independent account: the run resumed to the end keeps every match that finished
    # before the stop (never run again) and plays the others after it
    assert run_cli(*args, cwd=folder).returncode == 0
    final = rows(db)
    assert len(final) == 6 and [r for r in final if r[3] < stopped_at] == kept


def test_a_journal_left_in_wal_mode_is_made_whole_when_opened(folder):
    args = ["grade", "mini.yaml", "--team", "ref:idle", "--workers", "1", "--quiet", "--db", "j.sqlite"]
    args += ["--secret-file", secret_file("wal")]
    assert run_cli(*args, "--seeds", "1", cwd=folder).returncode == 0
    # as an older version left it: WAL mode, a finished match in the -wal file only
    older = """
import os, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("PRAGMA journal_mode=WAL")
db.execute("PRAGMA wal_autocheckpoint=0")
db.execute("INSERT INTO meta VALUES ('older', 'kept in the wal')")
db.commit()
os._exit(0)  # killed: no checkpoint
"""
    subprocess.run([sys.executable, "-c", older, str(folder / "j.sqlite")], check=True, timeout=60)
    assert (folder / "j.sqlite-wal").stat().st_size > 0
    assert run_cli(*args, "--seeds", "2", cwd=folder).returncode == 0
    copy = alone(folder / "j.sqlite")
    with sqlite3.connect(copy) as c:
        assert c.execute("SELECT value FROM meta WHERE key='older'").fetchone() == ("kept in the wal",)
        assert c.execute("SELECT COUNT(*) FROM matches").fetchone() == (2,)
        assert c.execute("PRAGMA journal_mode").fetchone() == ("delete",)


CUT_COMMIT = """
import os, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("PRAGMA cache_size=1")  # pages spill into the file mid-transaction, the old ones in -journal
db.execute("BEGIN")
for i in range(2000):
    db.execute("INSERT INTO meta VALUES (?, ?)", (f"cut-{i}", "x" * 200))
os._exit(0)  # killed in the middle of the commit
"""


def test_a_commit_cut_by_a_kill_is_undone_in_the_backup(folder):
    args = ["grade", "mini.yaml", "--team", "ref:idle", "--seeds", "1", "--workers", "1", "--quiet"]
    assert run_cli(*args, "--db", "j.sqlite", cwd=folder).returncode == 0
    db = folder / "j.sqlite"
    subprocess.run([sys.executable, "-c", CUT_COMMIT, str(db)], check=True, timeout=60)
    assert (folder / "j.sqlite-journal").stat().st_size > 0  # a hot journal beside the file
    proc = run_cli("journal", "backup", "j.sqlite", "saved.sqlite", cwd=folder)
    assert proc.returncode == 0 and "1 match, 0 heats" in proc.stdout, proc.stdout + proc.stderr
    with sqlite3.connect(alone(folder / "saved.sqlite")) as c:
        assert c.execute("SELECT COUNT(*) FROM meta WHERE key LIKE 'cut-%'").fetchone() == (0,)
        assert c.execute("PRAGMA integrity_check").fetchone() == ("ok",)


def test_journal_backup_copies_the_journal_whole_and_private(folder):
    assert run_cli(
        "grade", "mini.yaml", "--team", "ref:idle", "--seeds", "2", "--workers", "1", "--quiet", "--db", "j.sqlite",
        cwd=folder,
    ).returncode == 0  # fmt: skip
    proc = run_cli("journal", "backup", "j.sqlite", "saved.sqlite", cwd=folder)
    assert proc.returncode == 0 and "2 matches, 0 heats" in proc.stdout, proc.stdout + proc.stderr
    saved = alone(folder / "saved.sqlite")
    assert stat.S_IMODE((folder / "saved.sqlite").stat().st_mode) == 0o600  # it holds the secret
    assert rows(saved) == rows(folder / "j.sqlite")
    with sqlite3.connect(saved) as a, sqlite3.connect(folder / "j.sqlite") as b:
        assert a.execute("SELECT * FROM meta").fetchall() == b.execute("SELECT * FROM meta").fetchall()
    before = (folder / "saved.sqlite").read_bytes()
    for args, words in (
        (["j.sqlite", "saved.sqlite"], "exists"),  # never overwritten
        (["nosuch.sqlite", "other.sqlite"], "no such journal"),
        (["mini.yaml", "other.sqlite"], "not a readable LaserArena journal"),
    ):
        proc = run_cli("journal", "backup", *args, cwd=folder)
        assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and words in proc.stderr, proc.stderr
    assert (folder / "saved.sqlite").read_bytes() == before and not (folder / "other.sqlite").exists()
