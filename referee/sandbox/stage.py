"""What a sandbox is given of the installation, staged where its names tell nothing of the host.

A bind mount shows in /proc/self/mountinfo where its folder lies on the host (the mount's root
in its file system): binding the installation itself would tell every controller the
organizer's folder names (a checkout under /home/NAME, a pyenv under /root). So what a
controller needs of the installation, `robots` and the packages it may import (`ALLOWED`), and
an interpreter that lies outside /usr (a pyenv, a build under /opt) with its standard library,
is staged once in a folder of the referee's own (`home`): as hard links where one file system
holds both (nothing copied), else as copies. The sandbox binds the stage: what it can read
and name is the stage's, at neutral paths (LIB_DIR, PYTHON_DIR). An interpreter under /usr
is used where it is, since the system's /usr is bound whole.

How it works, in detail: docs/internals.md, `referee/sandbox/stage.py`.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import shutil
import stat
import sys
import sysconfig
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import robots
from robots._host.loading import STANDARD_VIEW

LIB_DIR = "/laserarena"  # the packages a controller may import besides the standard library
PYTHON_DIR = "/python"  # an interpreter that lies outside /usr, with its standard library
ALLOWED = STANDARD_VIEW  # besides `robots` (each with its wheel's `.libs` folder, where it has one)
LIB = "lib"  # the stage's folder of what goes to LIB_DIR
SKIPPED = ("site-packages", "dist-packages", "test")  # of a staged standard library (and its config-* folders)
KEEP_HOURS = 24
FORMAT = 2  # what a stage holds and how, in its name: 2, compiled modules of its own
_held: dict[str, int] = {}  # each stage this process uses, and the descriptor of its shared lock


@dataclass(frozen=True)
class Stage:
    """The staged installation: the interpreter as a sandbox runs it, what to bind where
    (host folder, its path in the sandbox), and the environment the interpreter needs."""

    python: str
    binds: tuple[tuple[str, str], ...]
    env: tuple[tuple[str, str], ...] = ()


def _allowed() -> list[tuple[str, str]]:
    """(folder on the host, its name in LIB_DIR) of `robots`, each package of `ALLOWED` and the
    folder of shared libraries its wheel brings beside it (numpy.libs)."""
    out = [(str(Path(robots.__file__).resolve().parent), "robots")]
    for name in ALLOWED:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.submodule_search_locations:
            continue
        folder = Path(list(spec.submodule_search_locations)[0]).resolve()
        out.append((str(folder), name))
        libs = folder.parent / f"{name}.libs"
        if libs.is_dir():
            out.append((str(libs.resolve()), libs.name))
    return out


def _interpreter() -> tuple[Path, Path, bool]:
    """The base interpreter (a virtual environment's own), its installation's prefix, and
    whether it runs on a shared libpython."""
    exe = Path(os.path.realpath(getattr(sys, "_base_executable", None) or sys.executable))
    return exe, Path(os.path.realpath(sys.base_prefix)), bool(sysconfig.get_config_var("Py_ENABLE_SHARED"))


def _sources() -> tuple[list[tuple[str, str]], str, dict[str, str]]:
    """(host path, its path in the stage) of everything staged, the interpreter's path in the
    sandbox, and the environment it needs."""
    sources = [(host, f"{LIB}/{name}") for host, name in _allowed()]
    exe, prefix, shared = _interpreter()
    if exe.is_relative_to("/usr"):
        return sources, str(exe), {}
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    sources += [(str(exe), f"python/bin/{exe.name}"), (str(prefix / "lib" / version), f"python/lib/{version}")]
    if shared:  # its libpython, which the interpreter finds by a path of the host's (its runpath)
        sources += [(str(p), f"python/lib/{p.name}") for p in sorted((prefix / "lib").glob("libpython*.so*"))]
    env = {"LD_LIBRARY_PATH": f"{PYTHON_DIR}/lib"} if shared else {}
    return sources, f"{PYTHON_DIR}/bin/{exe.name}", env


def _identity(host: str, every_file: bool) -> list[str]:
    """What names this source's content: the folder's (or file's) inode and time; with
    `every_file`, those of each file below it too (compiled `__pycache__` aside)."""
    info = os.stat(host)
    out = [f"{host}:{info.st_ino}:{info.st_mtime_ns}:{info.st_size}"]
    if every_file and stat.S_ISDIR(info.st_mode):
        for folder, folders, files in os.walk(host):
            folders[:] = sorted(f for f in folders if f != "__pycache__")
            for name in sorted(files):
                f = os.stat(os.path.join(folder, name), follow_symlinks=False)
                out.append(f"{os.path.relpath(folder, host)}/{name}:{f.st_ino}:{f.st_mtime_ns}:{f.st_size}")
    return out


def _own_folder(path: Path) -> bool:
    """Make `path` (0755: its stages are read by every slot's uid) unless it exists; whether it
    is a folder of this user's that no one else may write."""
    try:
        path.mkdir(mode=0o755, parents=True, exist_ok=True)
        info = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.geteuid() and not info.st_mode & 0o022


def home() -> Path:
    """The folder stages are made in: /var/cache/laserarena for root, the user's cache folder
    otherwise, else a folder of this user's own in the temporary folder. OSError if none."""
    user = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    places = ["/var/cache/laserarena/stage"] if os.geteuid() == 0 else [f"{user}/laserarena/stage"]
    places.append(os.path.join(tempfile.gettempdir(), f"laserarena-stage-{os.geteuid()}"))
    for place in places:
        if _own_folder(Path(place)):
            return Path(place)
    raise OSError(f"no folder of this user's to stage the sandbox's view in (tried {', '.join(places)})")


def _copy(host: str, target: Path) -> None:
    """`host` (a file or a folder; of a standard library, SKIPPED left out) at `target`: hard
    links where they can be made, else copies; symbolic links as links."""
    if not os.path.isdir(host):
        _file(host, target)
        return
    stdlib = target.parent.name == LIB and target.name.startswith("python")
    for folder, folders, files in os.walk(host):
        if stdlib and folder == host:
            folders[:] = [f for f in folders if f not in SKIPPED and not f.startswith("config-")]
        folders[:] = [f for f in folders if f != "__pycache__"]  # compiled at the host's paths
        inside = target / os.path.relpath(folder, host)
        inside.mkdir(mode=0o755, parents=True, exist_ok=True)
        os.chmod(inside, 0o755)
        for name in files + [f for f in folders if os.path.islink(os.path.join(folder, f))]:
            if stdlib and name.startswith("_sysconfigdata_"):
                _renamed(os.path.join(folder, name), inside / name)
            else:
                _file(os.path.join(folder, name), inside / name)


def _renamed(host: str, target: Path) -> None:
    """A copy of the build configuration `host` in which the interpreter's prefix reads PYTHON_DIR."""
    prefix = str(_interpreter()[1])
    target.write_text(Path(host).read_text().replace(prefix, PYTHON_DIR))


def _file(host: str, target: Path) -> None:
    target.parent.mkdir(mode=0o755, parents=True, exist_ok=True)
    if os.path.islink(host):
        os.symlink(os.readlink(host), target)
        return
    try:
        os.link(host, target, follow_symlinks=False)
    except OSError:
        shutil.copy2(host, target)


def _compile(part: Path) -> None:
    """Compile every module of the stage `part` as the sandbox names it (LIB_DIR/..., PYTHON_DIR/...):
    no compiled module holds a folder name of the host's."""
    import compileall
    import warnings

    places = [(part / LIB, LIB_DIR), (part / "python", PYTHON_DIR)]
    for folder, inside in places:
        if folder.is_dir():
            for entry in sorted(folder.iterdir()):
                if entry.is_dir() and not entry.is_symlink():
                    with warnings.catch_warnings():  # a library's test data may warn as it compiles
                        warnings.simplefilter("ignore")
                        compileall.compile_dir(entry, ddir=f"{inside}/{entry.name}", quiet=2)


def _sweep(folder: Path, keep: str) -> None:
    """Remove the stages no referee holds and none has used for KEEP_HOURS (never `keep`), and
    what a referee killed while staging left."""
    old = time.time() - KEEP_HOURS * 3600
    for entry in folder.iterdir():
        try:
            if entry.name == keep or not entry.is_dir() or entry.stat().st_mtime >= old:
                continue
            if entry.name.endswith(".part"):
                shutil.rmtree(entry, ignore_errors=True)
                continue
            fd = _lock(folder, entry.name, exclusive=True)
            if fd is not None:
                shutil.rmtree(entry, ignore_errors=True)
                os.unlink(folder / f".{entry.name}.lock")
                os.close(fd)
        except OSError:
            continue


def _lock(folder: Path, name: str, exclusive: bool) -> int | None:
    """A lock (shared, or `exclusive`) on the stage `name` (its file `.NAME.lock`), held by the
    descriptor returned, or None if another holds it otherwise."""
    import fcntl  # POSIX only: a sandbox is Linux's

    how = fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH
    fd = os.open(folder / f".{name}.lock", os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o600)
    try:
        fcntl.flock(fd, how | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        return None
    return fd


@functools.cache
def stage() -> Stage:
    """This installation's stage, made on first use and held (a shared lock) while this process
    lives. OSError if it cannot be made."""
    sources, python, env = _sources()
    digest = hashlib.sha256(repr((FORMAT, sys.version)).encode())
    for host, inside in sources:
        digest.update("\0".join([inside, *_identity(host, inside == f"{LIB}/robots")]).encode())
    name, folder = digest.hexdigest()[:24], home()
    for _ in range(50):  # another referee may be removing it (unused for days): then it is made again
        held = _lock(folder, name, exclusive=False)
        if held is not None:
            _held[name] = held
            break
        time.sleep(0.1)
    else:
        raise OSError(f"the sandbox's view {folder / name} stays locked")
    target = folder / name
    if not target.is_dir():
        part = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".part", dir=folder))
        try:
            for host, inside in sources:
                _copy(host, part / inside)
            _compile(part)
            os.chmod(part, 0o755)
            os.rename(part, target)
        except OSError:
            shutil.rmtree(part, ignore_errors=True)
            if not target.is_dir():  # made by another referee meanwhile, or not at all
                raise
    os.utime(target)
    _sweep(folder, name)
    binds = [(str(target / LIB / n), f"{LIB_DIR}/{n}") for _, n in _allowed()]
    if python.startswith(PYTHON_DIR):
        binds.append((str(target / "python"), PYTHON_DIR))
    return Stage(python, tuple(binds), tuple(sorted(env.items())))
