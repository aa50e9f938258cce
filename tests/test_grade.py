"""Grading: a killed run resumes with nothing lost or run twice; results do not depend on the
number of workers, nor on whether a Dask cluster or the local pool ran them."""

import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from referee.contest.grade import interval
from conftest import run_cli

ARGS = ["bac-line", "--team", "ref:bac", "--team", "ref:dead-reckoning", "--seeds", "3", "--quiet"]


def journal(db):
    with sqlite3.connect(db) as c:
        return sorted(c.execute("SELECT level_hash, team, seed, result, graded_at FROM matches"))


def grade(tmp_path, *extra):
    proc = run_cli("grade", *ARGS, "--db", str(tmp_path / "r.sqlite"), "--out", str(tmp_path / "lb.csv"), *extra)
    assert proc.returncode == 0, proc.stderr
    return (tmp_path / "lb.csv").read_text()


def test_worker_count_does_not_change_the_results(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir(), two.mkdir()
    a = grade(one, "--workers", "1")
    b = grade(two, "--workers", "2")
    assert a == b and len(a.splitlines()) == 3  # header + 2 teams on 1 level
    assert [r[:4] for r in journal(one / "r.sqlite")] == [r[:4] for r in journal(two / "r.sqlite")]
    assert len(list((one / "replays").glob("*.replay"))) == 6
    assert (one / "lb.md").read_text().startswith("| level | team |")


def test_a_killed_run_resumes_with_nothing_lost_or_run_twice(tmp_path):
    full, killed = tmp_path / "full", tmp_path / "killed"
    full.mkdir(), killed.mkdir()
    grade(full, "--workers", "1")
    db = killed / "r.sqlite"
    proc = subprocess.Popen([sys.executable, "-m", "referee", "grade", *ARGS, "--workers", "1",
                             "--db", str(db), "--out", str(killed / "lb.csv")], start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        time.sleep(0.1)
        if db.exists():
            try:
                if len(journal(db)) >= 2:
                    break
            except sqlite3.OperationalError:
                pass
    os.killpg(proc.pid, signal.SIGKILL)  # the grader and everything it started
    proc.wait()
    before = journal(db)
    assert 2 <= len(before) < 6, "the kill came mid-way"
    grade(killed, "--workers", "1")  # resume
    after = journal(db)
    assert [r[:4] for r in after] == [r[:4] for r in journal(full / "r.sqlite")]
    kept = {r[:3]: r[4] for r in before}
    assert all(r[4] == kept[r[:3]] for r in after if r[:3] in kept)  # finished ones were not run again
    assert (killed / "lb.csv").read_text() == (full / "lb.csv").read_text()


def test_dask_cluster_gives_the_same_leaderboard(tmp_path):
    from dask import distributed  # the dask extra, which `make test` installs
    local, remote = tmp_path / "local", tmp_path / "dask"
    local.mkdir(), remote.mkdir()
    expected = grade(local, "--workers", "2")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        got = grade(remote, "--scheduler", cluster.scheduler_address)
    assert got == expected


def test_interval_is_the_student_t_95_percent_interval():
    mean, half = interval([1.0, 2.0, 3.0])
    assert mean == 2.0 and half == pytest.approx(4.303 * 1.0 / 3 ** 0.5)
    assert interval([5.0]) == (5.0, 0.0)


def test_grade_rejects_a_bad_team_before_running(tmp_path):
    proc = run_cli("grade", "bac-line", "--team", "ref:nobody", "--db", str(tmp_path / "r.sqlite"))
    assert proc.returncode == 2 and "ref:nobody" in proc.stderr and not (tmp_path / "r.sqlite").exists()
