"""Grading: a killed run leaves nothing running and resumes with nothing lost or run twice;
results do not depend on the number of workers, nor on whether a Dask cluster or the local
pool ran them; a journal row belongs to the exact code, level and noise that produced it."""

import os
import signal
import sqlite3
import subprocess
import sys
import time

import pytest
from helpers import alive, run_cli, secret_file, stop_point

from referee.contest.grading import interval

ARGS = [
    "bac-line",
    "--team",
    "ref:bac",
    "--team",
    "ref:dead-reckoning",
    "--seeds",
    "3",
    "--quiet",
    "--secret-file",
    secret_file("a shared secret"),
]  # one secret: journals compared across runs draw the same noise


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


def test_dask_cluster_gives_the_same_leaderboard(tmp_path):
    from dask import distributed  # the dask extra, which `make test` installs

    local, remote = tmp_path / "local", tmp_path / "dask"
    local.mkdir(), remote.mkdir()
    expected = grade(local, "--workers", "2")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        got = grade(remote, "--scheduler", cluster.scheduler_address, "--insecure-cluster")
    assert got == expected
    assert "any machine could join (--insecure-cluster): tcp://" in (remote / "lb.md").read_text()


def test_interval_is_the_student_t_95_percent_interval():
    mean, half = interval([1.0, 2.0, 3.0])
    assert mean == 2.0 and half == pytest.approx(4.303 * 1.0 / 3**0.5)
    assert interval([5.0]) == (5.0, 0.0)


def test_grade_rejects_a_bad_team_before_running(tmp_path):
    proc = run_cli("grade", "bac-line", "--team", "ref:nobody", "--db", str(tmp_path / "r.sqlite"))
    assert proc.returncode == 2 and "ref:nobody" in proc.stderr and not (tmp_path / "r.sqlite").exists()


# ---- records that cannot lie ----------------------------------------------------------------

SLOW_TEAM = """
import time
from robots.api import Command, Controller

class Slow(Controller):  # never finishes: every match runs to its time limit
    def step(self, obs):
        time.sleep(PAUSE)
        return Command(SPEED, 0.03)
"""


def team(folder, name="team.py", speed="0.02", pause="0"):
    path = folder / name
    path.write_text(SLOW_TEAM.replace("SPEED", speed).replace("PAUSE", pause))
    return str(path)


def rows(db):
    with sqlite3.connect(db) as c:
        return sorted(c.execute("SELECT team, code_hash, seed, result, replay, graded_at FROM matches"))


def run_grade(folder, *args):
    return run_cli(
        "grade", "bac-line", "--db", str(folder / "r.sqlite"), "--out", str(folder / "lb.csv"), "--quiet", *args
    )


def test_an_edited_team_is_graded_again_and_old_rows_never_mix_in(shared_dir, tmp_path):
    spec = team(shared_dir)
    assert (
        run_grade(
            tmp_path, "--team", spec, "--seeds", "2", "--secret-file", secret_file("s"), "--workers", "1"
        ).returncode
        == 0
    )
    first = rows(tmp_path / "r.sqlite")
    team(shared_dir, speed="0.025")  # the team edits its file
    assert run_grade(tmp_path, "--team", spec, "--seeds", "2", "--secret-file", secret_file("s")).returncode == 0
    both = rows(tmp_path / "r.sqlite")
    assert len(first) == 2 and len(both) == 4 and len({r[1] for r in both}) == 2  # two code hashes
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    assert run_grade(fresh, "--team", spec, "--seeds", "2", "--secret-file", secret_file("s")).returncode == 0
    assert (tmp_path / "lb.csv").read_text() == (fresh / "lb.csv").read_text()  # the new code's only
    new = [r[3] for r in both if r[1] != first[0][1]]
    assert new == [r[3] for r in rows(fresh / "r.sqlite")] and new != [r[3] for r in first]


def test_two_teams_whose_names_clean_up_alike_keep_their_own_replays(shared_dir, tmp_path):
    a, b = team(shared_dir, "a b.py"), team(shared_dir, "a_b.py", speed="0.025")
    assert (
        run_grade(tmp_path, "--team", a, "--team", b, "--seeds", "1", "--secret-file", secret_file("s")).returncode == 0
    )
    from referee.records.replay_reader import load

    got = {load(r[4]).header["teams"][0]["spec"]: r[0] for r in rows(tmp_path / "r.sqlite")}
    assert got == {a: a, b: b}  # each row's replay holds that row's team
    assert len(list((tmp_path / "replays").glob("*.replay"))) == 2


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_a_stopped_grade_leaves_nothing_running_and_resumes(shared_dir, tmp_path, sig):
    args = [
        "--team",
        team(shared_dir, pause="0.01"),
        "--seeds",
        "4",
        "--workers",
        "2",
        "--secret-file",
        secret_file("s"),
    ]
    full, stopped = tmp_path / "full", tmp_path / "stopped"
    full.mkdir(), stopped.mkdir()
    assert run_grade(full, *args).returncode == 0
    db = stopped / "r.sqlite"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "referee",
            "grade",
            "bac-line",
            "--db",
            str(db),
            "--out",
            str(stopped / "lb.csv"),
            "--quiet",
            *args,
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    below = stop_point(proc, db)
    assert proc.poll() is None, "the kill came mid-way"
    assert len(below) >= 3  # two workers and the resource tracker at least, controllers too
    os.kill(proc.pid, sig)  # the grader alone: what it started must follow by itself
    code = proc.wait(timeout=60)
    assert code == (-9 if sig == signal.SIGKILL else 130)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and any(alive(p, s) for p, s in below.items()):
        time.sleep(0.05)
    assert not [p for p, s in below.items() if alive(p, s)]
    before = rows(db)
    assert 1 <= len(before) < 4
    if sig == signal.SIGTERM:  # the interrupted matches discarded their unfinished replays
        assert not list((stopped / "replays").glob(".*.part"))
    assert run_grade(stopped, *args).returncode == 0  # resume
    after = rows(db)
    assert [r[:4] for r in after] == [r[:4] for r in rows(full / "r.sqlite")]
    kept = {r[:3]: r[5] for r in before}
    assert all(r[5] == kept[r[:3]] for r in after if r[:3] in kept)  # finished ones were not run again
    assert (stopped / "lb.csv").read_text() == (full / "lb.csv").read_text()
    assert not list((stopped / "replays").glob(".*.part"))
    assert len(list((stopped / "replays").glob("*.replay"))) == 4


def test_a_corrupt_journal_is_one_line(tmp_path):
    (tmp_path / "r.sqlite").write_bytes(b"not a database at all " * 500)
    proc = run_grade(tmp_path, "--team", "ref:bac", "--seeds", "1")
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "r.sqlite" in proc.stderr
    assert "Traceback" not in proc.stderr
    old = tmp_path / "old"
    old.mkdir()
    with sqlite3.connect(old / "r.sqlite") as c:  # a journal of the previous schema
        c.execute("CREATE TABLE matches (level TEXT, level_hash TEXT, team TEXT, seed INTEGER)")
    proc = run_grade(old, "--team", "ref:bac", "--seeds", "1")
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "new --db" in proc.stderr
    (tmp_path / "folder.sqlite").mkdir(mode=0o755)
    proc = run_cli("grade", "bac-line", "--team", "ref:bac", "--db", str(tmp_path / "folder.sqlite"))
    assert proc.returncode == 2 and "not a journal file" in proc.stderr
    assert (tmp_path / "folder.sqlite").stat().st_mode & 0o777 == 0o755  # left as it was


def test_graded_noise_comes_from_the_secret_not_the_seed(tmp_path):
    import gzip
    import hashlib
    import hmac
    import stat

    from referee.records.replay_reader import load

    assert run_grade(tmp_path, "--team", "ref:bac", "--seeds", "1").returncode == 0
    db = tmp_path / "r.sqlite"
    with sqlite3.connect(db) as c:
        secret = c.execute("SELECT value FROM meta WHERE key='secret'").fetchone()[0]
        (replay,) = c.execute("SELECT replay FROM matches").fetchone()
    assert len(secret) == 64 and int(secret, 16)  # 256 bits from `secrets`
    header = load(replay).header
    expected = hmac.new(
        secret.encode(), f"laserarena-noise:{header['level']['hash']}:1".encode(), hashlib.sha256
    ).hexdigest()
    assert header["noise_key"] == expected
    assert secret.encode() not in gzip.open(replay).read()  # the replay holds one match's key only
    assert stat.S_IMODE(os.stat(replay).st_mode) == 0o600 and stat.S_IMODE(os.stat(db).st_mode) == 0o600
    assert stat.S_IMODE(os.stat(tmp_path / "replays").st_mode) == 0o700
    # the public seed alone gives other noise: a local run of the same seed differs in its events
    local = tmp_path / "local.replay"
    assert (
        run_cli("run", "bac-line", "--team", "ref:bac", "--seed", "1", "--replay", str(local), "--quiet").returncode
        == 0
    )
    graded_events, local_events = load(replay).events, load(local).events
    assert graded_events and local_events and graded_events != local_events
    # ... and verify re-simulates the graded match bit for bit from its replay
    proc = run_cli("verify", replay)
    assert proc.returncode == 0 and "identical" in proc.stdout, proc.stdout + proc.stderr
    # the journal's secret is the one the run used: a new journal given it grades the same
    again = tmp_path / "again"
    again.mkdir()
    (again / "secret").write_text(secret + "\n")
    assert run_grade(again, "--team", "ref:bac", "--seeds", "1", "--secret-file", str(again / "secret")).returncode == 0
    assert (again / "lb.csv").read_text() == (tmp_path / "lb.csv").read_text()


def test_team_names_reach_the_terminal_escaped(shared_dir, tmp_path):
    evil = shared_dir / "evil\x1b[2J\x1b[31mred\nsecond line.py"
    evil.write_text(SLOW_TEAM.replace("SPEED", "0.02").replace("PAUSE", "0"))
    proc = run_cli("run", "bac-line", "--team", str(evil), "--seed", "1")
    assert proc.returncode == 0, proc.stderr
    assert "\x1b" not in proc.stdout and "evil\\x1b[2J\\x1b[31mred\\nsecond line.py" in proc.stdout
    assert len(proc.stdout.splitlines()) == 3  # the heading, the column names, one robot
    proc = run_cli(
        "grade",
        "bac-line",
        "--team",
        str(evil),
        "--seeds",
        "1",
        "--db",
        str(tmp_path / "r.sqlite"),
        "--out",
        str(tmp_path / "lb.csv"),
    )
    assert proc.returncode == 0 and "\x1b" not in proc.stdout + proc.stderr
    assert len(proc.stdout.splitlines()) == 3  # the markdown header, its rule, one team
    proc = run_cli("run", "bac-line", "--team", str(shared_dir / "no\x1b[2Jsuch.py"))
    assert proc.returncode == 2 and "\x1b" not in proc.stderr and proc.stderr.count("\n") == 1


def test_one_grading_run_per_journal(tmp_path):
    import fcntl

    db = tmp_path / "r.sqlite"
    db.touch(mode=0o600)
    with open(db, "rb") as held:
        fcntl.flock(held, fcntl.LOCK_EX)  # as a running grade holds it
        proc = run_grade(tmp_path, "--team", "ref:bac", "--seeds", "1")
    assert proc.returncode == 2 and "another grading run" in proc.stderr and proc.stderr.count("\n") == 1
    assert run_grade(tmp_path, "--team", "ref:bac", "--seeds", "1").returncode == 0  # free again
