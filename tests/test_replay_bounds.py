"""A crafted replay costs its reader a bounded amount: a gzip bomb (a few MB that would
decompress to a GiB) or a line without end is refused in one line, naming the file and the
bound, with the exit code of other bad input, by verify, render and render --html, and the
reader's peak memory stays far below what reading it whole would take."""

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import MINI_LEVEL

from levels.loader import parse_level
from referee.errors import EXIT_BAD_INPUT
from referee.match.loop import play_match
from referee.records.replay_format import MAX_RECORD, MAX_REPLAY
from referee.sandbox.teams import resolve

GIB = 1 << 30
PEAK_MB = 400  # a reader's peak memory at most (the interpreter, numpy and pygame take ~160 MB)

# runs the command line and prints, last, its peak memory (ru_maxrss of the child, in KiB)
PEAK = """
import json, resource, subprocess, sys
r = subprocess.run([sys.executable, "-m", "referee", *sys.argv[1:]], capture_output=True, text=True, timeout=300)
print(json.dumps([r.returncode, r.stderr, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))
"""


def _bomb(path: Path, header: bytes, line: bytes) -> None:
    """A replay with `header` then `line` repeated to 1 GiB, written as gzip members of 16 MiB
    (each compressed once, repeated: a few MB on disk)."""
    member = gzip.compress(line * ((16 << 20) // len(line)), compresslevel=9, mtime=0)
    with path.open("wb") as f:
        f.write(gzip.compress(header, mtime=0))
        for _ in range(GIB // (16 << 20)):
            f.write(member)


@pytest.fixture(scope="module")
def header(tmp_path_factory) -> bytes:
    """The first line of a real replay: the bombs are replays but for their size."""
    path = tmp_path_factory.mktemp("bounds") / "real.replay"
    play_match(
        parse_level(MINI_LEVEL.encode(), "mini.yaml"), [resolve("ref:dead-reckoning")], replay=path, isolate=False
    )
    return gzip.open(path).readline()


def _peak(*args: str) -> tuple[int, str, int]:
    """(exit code, stderr, peak memory in MB) of `laserarena ARGS`, run as a child of its own."""
    out = subprocess.run([sys.executable, "-c", PEAK, *args], capture_output=True, text=True, timeout=600)
    code, stderr, kib = json.loads(out.stdout)
    return code, stderr, kib // 1024


@pytest.mark.parametrize(
    "kind, line, words",
    [
        ("frames", b'{"k":"f","p":[[1.5,2.5,0.5]],"t":1.0}\n', f"over {MAX_REPLAY} bytes decompressed"),
        ("endless line", b"[" * 4096, f"is over {MAX_RECORD} bytes"),
    ],
)
def test_a_gzip_bomb_is_refused_in_one_line_within_bounded_memory(tmp_path, header, kind, line, words):
    bomb = tmp_path / "bomb.replay"
    _bomb(bomb, header, line)
    assert bomb.stat().st_size < 16 << 20  # a few MB: gzip's own bound, not the file size, is what is tested
    for args in (["verify"], ["render", "--html", str(tmp_path / "b.html")], ["render", "--out", str(tmp_path / "b")]):
        code, stderr, peak = _peak(args[0], str(bomb), *args[1:])
        assert code == EXIT_BAD_INPUT, stderr
        assert stderr.count("\n") == 1 and str(bomb) in stderr and words in stderr, stderr
        assert "Traceback" not in stderr
        assert peak < PEAK_MB, (args, peak)
    assert not (tmp_path / "b.html").exists()
