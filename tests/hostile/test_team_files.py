"""A team's files are read once, as plain files of its own: a link (hard or symbolic), a fifo,
a file closed to the team's owner, a package too deep or too large, or a module name that
would shadow Python's own is refused in one line, and a grade goes on with the other teams."""

import gzip
import os
import sqlite3
import threading
from pathlib import Path

import pytest
from helpers import edited, run_cli, secret_file

from referee.errors import TeamError
from referee.sandbox.team_files import MAX_DEPTH, MAX_FILES
from referee.sandbox.teams import resolve

MARKER = "laserarena-root-only-marker-7f3a"
CONTROLLER = "from robots.api import Command, Controller\n\nclass Team(Controller):\n    def step(self, obs):\n        return Command(0.05, 0.05)\n"


def refusal(spec: str) -> str:
    """The one-line TeamError `resolve(spec)` ends with, waited for at most 60 s (a fifo must never stall it)."""
    found: list[BaseException | None] = []
    worker = threading.Thread(target=lambda: found.append(_error(spec)), daemon=True)
    worker.start()
    worker.join(60)
    assert found, f"resolving {spec} did not finish"
    error = found[0]
    assert isinstance(error, TeamError), error
    message = str(error)
    assert "\n" not in message and "Traceback" not in message and MARKER not in message, message
    return message


def _error(spec: str) -> BaseException | None:
    try:
        resolve(spec)
    except BaseException as e:
        return e
    return None


def package(folder: Path, name: str = "teampkg") -> Path:
    """A package team whose __init__ exports a Controller."""
    root = folder / name
    root.mkdir()
    (root / "__init__.py").write_text(CONTROLLER)
    return root


@pytest.fixture
def deep_folders():
    """Make folders `depth` deep below a folder, one by one (pathlib and shutil recurse once
    per level, past Python's recursion limit at this depth), and remove them the same way."""
    made: list[Path] = []

    def make(top: Path, depth: int = 1100) -> Path:
        path = top
        for _ in range(depth):
            path = path / "d"
            os.mkdir(path)
            made.append(path)
        return path

    yield make
    for path in reversed(made):
        for entry in os.scandir(path):
            if not entry.is_dir(follow_symlinks=False):
                os.unlink(entry.path)
        os.rmdir(path)


def root_only(folder: Path) -> Path:
    """A file only root may read, holding MARKER (a stand-in for /etc/shadow)."""
    secret = folder / "shadow"
    secret.write_text(MARKER + "\n")
    secret.chmod(0o600)
    return secret


def test_a_hard_link_in_a_package_is_refused_and_never_read(tmp_path):
    root = package(tmp_path)
    os.link(root_only(tmp_path), root / "data.txt")
    message = refusal(str(root))
    assert "teampkg/data.txt" in message and "2 hard links" in message


def test_a_symlinked_file_team_is_refused(tmp_path):
    real = tmp_path / "real.py"
    real.write_text(CONTROLLER)
    (tmp_path / "link.py").symlink_to(real)
    message = refusal(str(tmp_path / "link.py"))
    assert "link.py" in message and "symbolic link" in message


@pytest.mark.parametrize("target", ["file", "folder", "package"])
def test_a_symlink_inside_or_as_a_package_is_refused(tmp_path, target):
    root = package(tmp_path)
    if target == "file":
        (root / "helper.py").symlink_to(root_only(tmp_path))
        spec, where = str(root), "teampkg/helper.py"
    elif target == "folder":
        (root / "sub").symlink_to("/etc", target_is_directory=True)
        spec, where = str(root), "teampkg/sub"
    else:
        (tmp_path / "aliased").symlink_to(root, target_is_directory=True)
        spec, where = str(tmp_path / "aliased"), "aliased"
    message = refusal(spec)
    assert where in message and "symbolic link" in message


def test_a_fifo_in_a_package_is_refused_without_waiting_for_a_writer(tmp_path):
    root = package(tmp_path)
    os.mkfifo(root / "pipe")
    message = refusal(str(root))
    assert "teampkg/pipe" in message and "not a regular file" in message


def test_a_file_closed_to_the_team_folders_owner_is_refused_as_root(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("only a root referee reads what the team's owner cannot")
    root = package(tmp_path)
    os.rename(root_only(tmp_path), root / "data.txt")  # one link only: the old /etc/shadow of a rename
    os.chown(root, 65534, 65534)  # the team belongs to someone else (nobody)
    message = refusal(str(root))
    assert "teampkg/data.txt" in message and "closed to the team folder's owner" in message


def test_a_package_too_deep_is_refused_early(tmp_path, deep_folders):
    root = package(tmp_path)
    (deep_folders(root) / "leaf.py").write_text("X = 1\n")
    message = refusal(str(root))
    assert f"more than {MAX_DEPTH} folders deep" in message and "d/" * MAX_DEPTH in message


def test_a_package_with_too_many_files_is_refused(tmp_path):
    root = package(tmp_path)
    for i in range(1500):
        (root / f"m{i:04}.py").write_text("")
    message = refusal(str(root))
    assert f"over {MAX_FILES} files and folders" in message and "teampkg" in message


@pytest.mark.parametrize("name", ["json", "sitecustomize", "robots"])
def test_a_team_named_like_a_module_python_or_laserarena_imports_is_refused(tmp_path, name):
    (tmp_path / f"{name}.py").write_text(CONTROLLER)
    assert f"module name {name!r} is taken" in refusal(str(tmp_path / f"{name}.py"))
    folder = tmp_path / "pkgs"
    folder.mkdir()
    assert f"module name {name!r} is taken" in refusal(str(package(folder, name)))


def test_a_grade_refuses_bad_teams_in_one_line_and_grades_the_others(tmp_path, deep_folders):
    (tmp_path / "short.yaml").write_text(edited("bac-line", {"time_limit": 2}))
    linked = package(tmp_path, "linked")
    os.link(root_only(tmp_path), linked / "data.txt")
    deep = package(tmp_path, "deep")
    deep_folders(deep)
    proc = run_cli(
        "grade",
        "short.yaml",
        "--team",
        "linked",
        "--team",
        "ref:idle",
        "--team",
        "deep",
        "--seeds",
        "1",
        "--workers",
        "1",
        "--secret-file",
        secret_file("s"),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    notes = [line for line in proc.stdout.splitlines() if line.startswith("Note: refused team")]
    assert len(notes) == 2 and "linked/data.txt" in notes[0] and "folders deep" in notes[1], proc.stdout
    with sqlite3.connect(tmp_path / "results.sqlite") as db:
        assert [r[0] for r in db.execute("SELECT team FROM matches")] == ["ref:idle"]
    outputs = [p for p in tmp_path.glob("*/*") if p.is_file()] + [p for p in tmp_path.glob("*") if p.is_file()]
    outputs = [p for p in outputs if not p.is_relative_to(linked) and p.name != "shadow"]
    assert any(p.suffix == ".replay" for p in outputs) and any(p.suffix == ".sqlite" for p in outputs)
    for path in outputs:  # the journal, the leaderboard, the replays (gzip)
        data = path.read_bytes()
        assert MARKER.encode() not in (gzip.decompress(data) if path.suffix == ".replay" else data), path
    assert MARKER not in proc.stdout + proc.stderr
