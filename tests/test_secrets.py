"""Secrets and replays that cannot be forged: `secret new` writes 256 random bits no one else
may read; a weak secret is refused wherever one is read; `verify` checks a replay's noise key
against the run's secret and names a forged one, and without a secret says it did not check."""

import gzip
import hashlib
import hmac
import json
import os
import sqlite3
import stat
import subprocess
import sys

import pytest
from helpers import MINI_LEVEL, run_cli, secret_file

from referee import api
from referee.errors import UserError

WEAK = {  # a class of weak secret -> an example of it
    "a word and a year": "Dragon2019",
    "short": "x7#Kq2!v",
    "repeated characters": "z" * 48,
    "a keyboard walk": "1qaz2wsx3edc4rfv5tgb6yhn7ujm8ik,9ol.",
    "a l33t word": "P@55w0rd!P@55w0rd!",
    "a phrase": "our contest secret for the spring round 2024",
}
STRONG = {  # drawn once from `secrets` and kept, so that the test means the same every run
    "32 random hex digits": "0c5e83f29a1d47b6e8f4a0d93c27b51e",
    "64 random hex digits": "9f1c4be07a2d58e36b90c1f4d7a2e85b3c6f09d1e4a7b2c58d3f60e91a4b7c2d",
    "a 43-character base64url token": "kI9hABfqfPcLviK9ofiqQVL1_OmmEl-QbIkXJWPLJpU",
}


def write(folder, name, text):
    path = folder / name
    path.write_text(text + "\n")
    return str(path)


def one_line(proc, *words):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert all(w in proc.stderr for w in words), proc.stderr


# ---- secret new ------------------------------------------------------------------------------


def test_secret_new_writes_256_random_bits_that_only_its_owner_may_read(tmp_path):
    path = tmp_path / "contest.key"
    # even with a umask that would let everyone read, the file is 0600 from its creation
    made = subprocess.run(
        [sys.executable, "-m", "referee", "secret", "new", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=lambda: os.umask(0),
    )
    assert made.returncode == 0, made.stderr
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    first = path.read_text()
    assert first.endswith("\n") and len(first.strip()) == 64 and int(first, 16) >= 0  # 256 bits, hex
    one_line(run_cli("secret", "new", str(path)), "exists", "--force")  # never overwritten unasked
    assert path.read_text() == first
    assert run_cli("secret", "new", str(path), "--force").returncode == 0
    assert path.read_text() != first and stat.S_IMODE(path.stat().st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["contest.key"]  # nothing left beside it
    # a link planted where the secret is to go is not followed: its target stays untouched
    target = tmp_path / "target"
    target.write_text("theirs\n")
    (tmp_path / "link.key").symlink_to(target)
    one_line(run_cli("secret", "new", str(tmp_path / "link.key")), "link.key", "exists")
    assert target.read_text() == "theirs\n"


def test_what_secret_new_writes_is_accepted(tmp_path):
    for i in range(3):
        path = tmp_path / f"k{i}"
        assert run_cli("secret", "new", str(path)).returncode == 0
        proc = run_cli("verify", str(tmp_path / "nosuch.replay"), "--secret-file", str(path))
        assert "weak" not in proc.stderr and "nosuch.replay" in proc.stderr  # the secret passed


# ---- weak secrets refused --------------------------------------------------------------------


@pytest.mark.parametrize("kind", WEAK)
def test_a_weak_secret_file_is_refused_in_one_line(tmp_path, kind):
    path = write(tmp_path, "secret", WEAK[kind])
    proc = run_cli(
        "grade", "bac-line", "--team", "ref:bac", "--secret-file", path, "--db", str(tmp_path / "r.sqlite"), "--quiet"
    )
    one_line(proc, path, "weak secret", "128", "laserarena secret new")
    assert WEAK[kind] not in proc.stderr  # the secret itself is never printed
    assert not (tmp_path / "r.sqlite").exists()  # refused before anything was made


def test_every_command_that_reads_a_secret_refuses_a_weak_one(tmp_path):
    path = write(tmp_path, "secret", WEAK["a word and a year"])
    for args in (
        ["grade", "bac-line", "--team", "ref:bac", "--db", str(tmp_path / "g.sqlite")],
        ["tournament", "bac-line", "--team", "ref:bac", "--db", str(tmp_path / "t.sqlite")],
        ["verify", str(tmp_path / "any.replay")],
    ):
        one_line(run_cli(*args, "--secret-file", path), path, "weak secret")
    for bad, words in ((b"", "empty"), (b"\xff\xfe" * 40, "UTF-8"), (b"a" * 5000, "4096 bytes")):
        (tmp_path / "bad").write_bytes(bad)
        one_line(run_cli("verify", "x.replay", "--secret-file", str(tmp_path / "bad")), "bad", words)


def test_the_python_api_refuses_a_weak_secret_before_any_match(tmp_path):
    from robots.api import Command, Controller

    class Still(Controller):  # a class team: its source would be shipped beside the journal
        def step(self, observation):
            return Command(0.0, 0.0)

    with pytest.raises(UserError, match="secret: a weak secret") as refused:
        api.grade("bac-line", ["ref:bac", Still], seeds=1, workers=1, db=tmp_path / "r.sqlite", secret="Summer2024")
    assert "Summer2024" not in str(refused.value)
    with pytest.raises(UserError, match="secret: a weak secret"):
        api.tournament("bac-line", ["ref:bac"], workers=1, db=tmp_path / "t.sqlite", secret="qwertyuiop")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("kind", STRONG)
def test_strong_secret_files_are_accepted(tmp_path, kind):
    path = write(tmp_path, "secret", STRONG[kind])
    proc = run_cli("verify", str(tmp_path / "nosuch.replay"), "--secret-file", path)
    assert "weak" not in proc.stderr and "nosuch.replay: No such file" in proc.stderr, proc.stderr


# ---- verify checks the noise key -------------------------------------------------------------


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    """A real `laserarena grade` of a short level (the journal makes its secret), its replay,
    and that secret read straight from the journal."""
    folder = tmp_path_factory.mktemp("graded")
    folder.chmod(0o755)
    (folder / "mini.yaml").write_text(MINI_LEVEL)
    proc = run_cli(
        "grade", "mini.yaml", "--team", "ref:dead-reckoning", "--seeds", "1", "--workers", "1", "--quiet",
        "--db", "j.sqlite", "--out", "lb.csv",
        cwd=folder,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    with sqlite3.connect(folder / "j.sqlite") as db:
        (secret,) = db.execute("SELECT value FROM meta WHERE key='secret'").fetchone()
        (replay,) = db.execute("SELECT replay FROM matches").fetchone()
    (folder / "run.key").write_text(secret + "\n")
    return folder, replay, secret


def header(replay):
    with gzip.open(replay, "rt") as f:
        return json.loads(f.readline())


def forge(folder, replay, key):
    """The replay of the same match played again with noise of the forger's choosing: the
    public API can do it, and the result re-simulates bit for bit."""
    from levels.loader import parse_level
    from referee.match.loop import play_match
    from referee.sandbox.teams import resolve

    h = header(replay)
    level = parse_level(h["level"]["text"].encode(), "mini.yaml")
    out = folder / f"forged-{key[:6]}.replay"
    play_match(level, [resolve(t["spec"]) for t in h["teams"]], seed=h["seed"], replay=out, noise_key=key)
    return str(out)


def test_a_genuine_noise_key_is_the_hmac_of_the_secret_and_verify_says_so(graded):
    folder, replay, secret = graded
    h = header(replay)
    expected = hmac.new(
        secret.encode(), f"laserarena-noise:{h['level']['hash']}:{h['seed']}".encode(), hashlib.sha256
    ).hexdigest()
    assert h["noise_key"] == expected
    for source in (["--secret-file", str(folder / "run.key")], ["--db", str(folder / "j.sqlite")]):
        proc = run_cli("verify", replay, *source)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "identical" in proc.stdout and "noise key genuine" in proc.stdout
    proc = run_cli("verify", replay)  # no secret: identical, and it says the key went unchecked
    assert proc.returncode == 0 and "identical" in proc.stdout and "noise key not checked" in proc.stdout
    assert "--secret-file" in proc.stdout and "genuine" not in proc.stdout


def test_a_forged_noise_key_is_named(graded):
    folder, replay, secret = graded
    key = hashlib.sha256(b"a key of the forger's choosing").hexdigest()
    forged = forge(folder, replay, key)
    assert header(forged)["noise_key"] == key
    proc = run_cli("verify", forged)  # the hole: re-simulated with its own key, it is identical
    assert proc.returncode == 0 and "identical" in proc.stdout and "not checked" in proc.stdout
    for source in (["--secret-file", str(folder / "run.key")], ["--db", str(folder / "j.sqlite")]):
        proc = run_cli("verify", forged, *source)
        assert proc.returncode == 1 and proc.stdout.count("\n") == 1, proc.stdout + proc.stderr
        assert "forged noise key" in proc.stdout and "identical" not in proc.stdout
    # the genuine replay checked against another secret is refused the same way
    proc = run_cli("verify", replay, "--secret-file", secret_file("another contest"))
    assert proc.returncode == 1 and "forged noise key" in proc.stdout
    # a local run has no key: not a graded match of this secret
    local = folder / "local.replay"
    assert run_cli("run", "mini.yaml", "--seed", "1", "--replay", str(local), "--quiet", cwd=folder).returncode == 0
    proc = run_cli("verify", str(local), "--db", str(folder / "j.sqlite"))
    assert proc.returncode == 1 and "no noise key" in proc.stdout
    proc = run_cli("verify", str(local))
    assert proc.returncode == 0 and "no noise key" in proc.stdout


def test_verify_from_a_journal_without_a_secret_of_its_own_is_one_line(tmp_path, graded):
    folder, replay, _ = graded
    with sqlite3.connect(tmp_path / "given.sqlite") as db:  # a journal whose runs had --secret-file
        db.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
    one_line(run_cli("verify", replay, "--db", str(tmp_path / "given.sqlite")), "no secret of its own")
    one_line(run_cli("verify", replay, "--db", str(tmp_path / "nosuch.sqlite")), "nosuch.sqlite")
    proc = run_cli("verify", replay, "--db", str(folder / "j.sqlite"), "--secret-file", str(folder / "run.key"))
    assert proc.returncode == 2 and "not allowed with" in proc.stderr
