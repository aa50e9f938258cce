"""grade's progress bar: shown on a terminal and taken off it at the end; a pipe or a log file
gets no bar lines at all."""

from __future__ import annotations

import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios

from helpers import MINI_LEVEL

ARGS = ["-m", "referee", "grade", "level.yaml", "--team", "ref:idle", "--seeds", "2", "--workers", "1"]


def test_no_bar_in_a_pipe(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    out = subprocess.run([sys.executable, *ARGS], capture_output=True, text=True, cwd=shared_dir, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stderr.splitlines()[0].startswith("2 matches in the journal")  # only the summary line
    assert "match/s" not in out.stderr and "\r" not in out.stderr and "ETA" not in out.stderr


def test_bar_on_a_terminal_vanishes(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # a 100-column terminal
    proc = subprocess.Popen(
        [sys.executable, *ARGS, "--db", "t.sqlite"],
        cwd=shared_dir,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=follower,
    )
    os.close(follower)
    seen = b""
    while True:
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the terminal closed: the process is gone
            break
        if not chunk:
            break
        seen += chunk
    assert proc.wait(timeout=300) == 0
    os.close(leader)
    text = seen.decode("utf-8", "replace")
    parts = text.split("\r")
    assert any("0/2" in p and "match" in p for p in parts)  # the bar, counting matches
    # leave=False: its line is blanked out before the summary is printed
    blank = max(i for i, p in enumerate(parts) if p and set(p) == {" "})
    assert all("/2" not in p for p in parts[blank:]) and "2 matches in the journal" in parts[blank + 1]
