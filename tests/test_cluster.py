"""A Dask cluster admits only the organizer's workers, and the organizer's process trusts none
of them. docs/cluster.md is followed as written (its `<!-- cluster: ... -->` blocks, with only
the address put in) with real `dask scheduler` and `dask worker` processes and real keys on
localhost; a worker without the organizer's key never joins; a rogue worker that holds one
can neither run code in the organizer's process nor get a bad or forged result journaled."""

import contextlib
import json
import os
import pwd
import re
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from helpers import run_cli

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "cluster.md"
ROGUE = Path(__file__).resolve().parent / "rogue_worker.py"
IDLE = """
from robots.api import Command, Controller

class StandStill(Controller):
    def step(self, observation):
        return Command(0.0, 0.0)
"""
WAIT = 60  # seconds, for any one process to be ready


def blocks() -> dict[str, str]:
    """The page's marked shell blocks by name (keys, scheduler, worker, client)."""
    found = re.findall(r"<!-- cluster: (\w+) -->\n```sh\n(.*?)^```", DOC.read_text(), re.S | re.M)
    return dict(found)


def here(code: str, port: int) -> str:
    """A block with the page's address made this machine's (the only change made to it)."""
    return code.replace("10.0.0.5", "127.0.0.1").replace("8786", str(port))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def env(**extra: str) -> dict[str, str]:
    return dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}", **extra)


def start(code: str, cwd: Path, log: Path, **extra: str) -> subprocess.Popen:
    with open(log, "wb") as out:
        return subprocess.Popen(
            ["bash", "-eu", "-c", code], cwd=cwd, env=env(**extra), stdout=out, stderr=out, start_new_session=True
        )


def stop(proc: subprocess.Popen) -> None:
    """End a process group this test started: SIGTERM, then SIGKILL after a bounded wait."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=20)


def security(keys: Path):
    from distributed.security import Security

    return Security(
        require_encryption=True,
        tls_ca_file=str(keys / "ca.pem"),
        tls_client_cert=str(keys / "client.pem"),
        tls_client_key=str(keys / "client-key.pem"),
    )


def workers(address: str, keys: Path) -> set[str]:
    """The workers the scheduler knows now, asked as the organizer's client."""
    from distributed import Client

    with Client(address, security=security(keys), timeout=WAIT) as client:
        return set(client.scheduler_info(n_workers=-1)["workers"])


def scheduler(folder: Path, port: int, name: str) -> subprocess.Popen:
    """The page's scheduler, on `port`, up and answering."""
    log = folder / f"{name}.log"
    proc = start(here(blocks()["scheduler"], port), folder, log)
    deadline = time.monotonic() + WAIT
    while "Scheduler at:" not in log.read_text(errors="replace"):
        assert proc.poll() is None and time.monotonic() < deadline, log.read_text()
        time.sleep(0.1)
    return proc


def wait_for(address: str, keys: Path, n: int) -> set[str]:
    from distributed import Client

    with Client(address, security=security(keys), timeout=WAIT) as client:
        client.wait_for_workers(n, timeout=WAIT)
        return set(client.scheduler_info(n_workers=-1)["workers"])


@dataclass(frozen=True)
class Cluster:
    folder: Path
    address: str
    port: int
    workers: set[str]


@pytest.fixture(scope="module")
def cluster():
    """docs/cluster.md's keys, scheduler and workers (one per core), as written."""
    folder = Path(tempfile.mkdtemp(prefix="laserarena-cluster-", dir="/tmp"))
    folder.chmod(0o755)  # controllers run as `nobody` and read the team files here
    done = subprocess.run(
        ["bash", "-eu", "-c", blocks()["keys"]], cwd=folder, env=env(), capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    port = free_port()
    sched = scheduler(folder, port, "scheduler")
    worker = None
    try:
        worker = start(here(blocks()["worker"], port), folder, folder / "worker.log")
        address = f"tls://127.0.0.1:{port}"
        yield Cluster(folder, address, port, wait_for(address, folder / "keys", os.cpu_count() or 1))
    finally:
        if worker:
            stop(worker)
        stop(sched)
        shutil.rmtree(folder, ignore_errors=True)


def rows(db: Path) -> int:
    with sqlite3.connect(db) as c:
        return c.execute("SELECT count(*) FROM matches").fetchone()[0]


def test_the_page_as_written_grades_as_the_local_pool(cluster):
    import robots.controllers.starter as starter

    teams = cluster.folder / "teams"
    teams.mkdir(mode=0o755)
    shutil.copyfile(starter.__file__, teams / "a.py")
    (teams / "b.py").write_text(IDLE)
    for f in teams.iterdir():
        f.chmod(0o644)
    done = subprocess.run(
        ["bash", "-eu", "-c", here(blocks()["client"], cluster.port)],
        cwd=cluster.folder,
        env=env(),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert rows(cluster.folder / "contest.sqlite") == 6
    with sqlite3.connect(cluster.folder / "contest.sqlite") as c:
        secret = c.execute("SELECT value FROM meta WHERE key='secret'").fetchone()[0]
    (cluster.folder / "secret").write_text(secret)
    local = ["--workers", "2", "--secret-file", "secret", "--db", "local.sqlite", "--out", "local.csv", "--quiet"]
    assert (
        run_cli(
            "grade",
            "asabe-race",
            "--team",
            "teams/a.py",
            "--team",
            "teams/b.py",
            "--seeds",
            "3",
            *local,
            cwd=cluster.folder,
        ).returncode
        == 0
    )
    assert (cluster.folder / "leaderboard.csv").read_text() == (cluster.folder / "local.csv").read_text()
    assert "Note:" not in (cluster.folder / "leaderboard.md").read_text()  # nothing insecure, nothing unsandboxed


def test_a_machine_without_the_organizers_key_never_joins(cluster):
    folder = cluster.folder
    assert run_cli("cluster-keys", "other", cwd=folder).returncode == 0
    worker = blocks()["worker"]
    strangers = [
        start(here(worker.split("\\\n")[0].strip().rstrip("\\"), cluster.port), folder, folder / "plain.log"),
        start(here(worker.replace("keys/", "other/"), cluster.port), folder, folder / "other-ca.log"),
    ]
    try:
        deadline = time.monotonic() + 15  # they keep trying meanwhile
        while time.monotonic() < deadline:
            assert workers(cluster.address, folder / "keys") == cluster.workers
            time.sleep(1)
    finally:
        for proc in strangers:
            stop(proc)
    log = (folder / "scheduler.log").read_text(errors="replace").lower()
    assert "certificate" in log or "handshake" in log  # the scheduler refused the other CA's worker
    # a client with another CA's key is refused in one line, before any match
    out = run_cli(
        "grade", "bac-line", "--team", "ref:idle", "--seeds", "1", "--scheduler", cluster.address,
        "--cluster-keys", "other", "--db", "other.sqlite", "--out", "other.csv", cwd=folder,
    )  # fmt: skip
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "cannot reach" in out.stderr, out.stderr
    assert rows(folder / "other.sqlite") == 0


def test_tcp_is_refused_in_one_line_and_tls_needs_the_keys(tmp_path):
    for address, words in [
        ("tcp://127.0.0.1:1", "--insecure-cluster"),
        ("127.0.0.1:1", "--insecure-cluster"),
        ("tls://127.0.0.1:1", "--cluster-keys DIR"),
        ("ws://127.0.0.1:1", "tls://HOST:PORT"),
    ]:
        out = run_cli(
            "grade", "bac-line", "--team", "ref:idle", "--scheduler", address, "--db", "g.sqlite", cwd=tmp_path
        )
        assert out.returncode == 2 and out.stderr.count("\n") == 1 and words in out.stderr, out.stderr
        assert "Traceback" not in out.stderr and not (tmp_path / "g.sqlite").exists()
    out = run_cli("cluster-keys", "keys", cwd=tmp_path)
    assert out.returncode == 0
    assert oct((tmp_path / "keys").stat().st_mode & 0o777) == "0o700"
    assert {p.name: oct(p.stat().st_mode & 0o777) for p in (tmp_path / "keys").glob("*-key.pem")} == {
        f"{r}-key.pem": "0o600" for r in ("scheduler", "worker", "client")
    }
    again = run_cli("cluster-keys", "keys", cwd=tmp_path)  # never over keys in use
    assert again.returncode == 2 and again.stderr.count("\n") == 1 and "already exists" in again.stderr


def test_the_sandbox_note_is_the_organizers_policy(cluster):
    """Workers here have their sandboxes; `--unsandboxed` still notes the journal, because it
    is the organizer's choice that is recorded, not what a worker says of itself."""
    folder = cluster.folder
    args = ["grade", "bac-line", "--team", "ref:bac", "--seeds", "1", "--scheduler", cluster.address]
    out = run_cli(*args, "--cluster-keys", "keys", "--unsandboxed", "--db", "u.sqlite", "--out", "u.csv", cwd=folder)
    assert out.returncode == 0, out.stderr
    assert "played without a kernel sandbox (--unsandboxed)" in (folder / "u.md").read_text()
    with sqlite3.connect(folder / "u.sqlite") as c:
        assert c.execute("SELECT count(*) FROM meta WHERE key='unsandboxed'").fetchone()[0] == 1


@pytest.fixture(scope="module")
def rogue_scheduler(cluster):
    """A second scheduler of the page's, for rogue workers that hold the organizer's key."""
    folder = cluster.folder / "rogue"
    folder.mkdir(mode=0o777)
    folder.chmod(0o777)
    port = free_port()
    sched = scheduler(cluster.folder, port, "rogue-scheduler")
    try:
        yield folder, port
    finally:
        stop(sched)


@contextlib.contextmanager
def rogue_worker(cluster: Cluster, port: int, folder: Path, mode: str):
    """One worker of the page's on `port`, made rogue by tests/rogue_worker.py in `mode`."""
    (folder / "mode").write_text(mode)
    (folder / "mode").chmod(0o644)
    code = here(blocks()["worker"], port).replace("--nworkers -1", "--nworkers 1").rstrip() + f" --preload {ROGUE}"
    worker = start(
        code,
        cluster.folder,
        folder / f"{mode}-worker.log",
        ROGUE_MODE=str(folder / "mode"),
        ROGUE_MARKER=str(folder / "marker"),
        PYTHONPATH=str(ROOT / "tests"),
    )
    try:
        (name,) = wait_for(f"tls://127.0.0.1:{port}", cluster.folder / "keys", 1)
        yield name
    finally:
        stop(worker)
        deadline = time.monotonic() + WAIT  # gone from the scheduler too, before the next rogue joins
        while workers(f"tls://127.0.0.1:{port}", cluster.folder / "keys") and time.monotonic() < deadline:
            time.sleep(0.2)


@pytest.mark.parametrize(
    "mode, words",
    [
        ("pickle", "its reply was not plain data"),
        ("raise", "the match's task failed on its worker"),
        ("forge", "sent a bad result"),
        ("forge-both", "failed its audit"),
    ],
)
def test_a_rogue_worker_runs_no_code_here_and_gets_nothing_journaled(cluster, rogue_scheduler, mode, words):
    folder, port = rogue_scheduler
    (folder / "marker").unlink(missing_ok=True)
    db = folder / f"{mode}.sqlite"
    cmd = [sys.executable, "-m", "referee", "grade", "bac-line", "--team", "ref:bac", "--seeds", "1"]
    where = ["--scheduler", f"tls://127.0.0.1:{port}", "--cluster-keys", "keys"]
    with rogue_worker(cluster, port, folder, mode) as name:
        proc = subprocess.Popen(
            [*cmd, *where, "--db", str(db), "--out", str(folder / f"{mode}.csv")],
            cwd=cluster.folder,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert words in err and name in err  # the worker named as the scheduler knows it
    assert rows(db) == 0 and not list((folder / "replays").glob("*.replay"))
    loaded = (folder / "marker").read_text().split() if (folder / "marker").exists() else []
    if mode == "raise":  # Dask's client loads a task's exception, in the courier alone: as nobody
        assert all(int(uid) == pwd.getpwnam("nobody").pw_uid for uid in loaded[1::2]), loaded
    else:  # a reply in pickle is loaded nowhere: neither the organizer's process nor its courier
        assert loaded == []


def test_an_honest_worker_holding_a_key_is_trusted_after_its_audit(cluster, rogue_scheduler):
    folder, port = rogue_scheduler
    with rogue_worker(cluster, port, folder, "honest"):
        out = run_cli(
            "grade", "bac-line", "--team", "ref:bac", "--seeds", "2", "--scheduler", f"tls://127.0.0.1:{port}",
            "--cluster-keys", "keys", "--audit", "1", "--db", str(folder / "honest.sqlite"),
            "--out", str(folder / "honest.csv"), cwd=cluster.folder,
        )  # fmt: skip
    assert out.returncode == 0, out.stderr + (folder / "honest-worker.log").read_text()[-3000:]
    assert rows(folder / "honest.sqlite") == 2
    assert json.loads((folder / "honest.json").read_text())[0]["matches"] == 2
