"""Without the POSIX-only modules (Windows has no pwd, resource or fcntl; macOS refuses an
address-space limit) the package imports, lists its levels and runs a match, saying in one
line what it cannot enforce. The absence is simulated in a fresh interpreter."""

from __future__ import annotations

import subprocess
import sys

from helpers import MINI_LEVEL

WITHOUT_POSIX = (
    "import sys\nfor name in ('pwd', 'resource', 'fcntl', 'grp', 'termios'):\n    sys.modules[name] = None\n"
)


def _python(code: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=cwd)


def test_imports_and_levels_without_posix_modules():
    out = _python(
        WITHOUT_POSIX + "import arena, robots, referee, referee.contest.grading, robots._host.runner\n"
        "from referee.cli.main import main\nraise SystemExit(main(['levels']))"
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[0].split()[0] == "asabe" and out.stderr == ""


def test_runner_limits_missing_or_refused_are_one_line_warnings():
    missing = _python(
        WITHOUT_POSIX + "from robots._host.runner import _limit\nprint(_limit('RLIMIT_AS', 1 << 30, 'memory'))"
    )
    assert missing.stdout.strip() == "False"
    assert missing.stderr.strip() == (
        "laserarena: warning: no memory limit on this system (RLIMIT_AS: "
        "ModuleNotFoundError); the controller runs without it"
    )
    # macOS: setrlimit(RLIMIT_AS) raises ValueError
    refused = _python(
        "import resource\ndef refuse(*a): raise ValueError('not supported')\n"
        "resource.setrlimit = refuse\nfrom robots._host.runner import _limit\n"
        "print(_limit('RLIMIT_AS', 1 << 30, 'memory'))"
    )
    assert refused.stdout.strip() == "False" and len(refused.stderr.strip().splitlines()) == 1
    assert "RLIMIT_AS: ValueError" in refused.stderr


def test_a_match_on_windows_runs_in_process_with_one_warning(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL)
    out = _python(
        "import sys\nfrom referee import run_match\nfrom robots.api import Command, Controller\n"
        "class Go(Controller):\n    def step(self, obs):\n        return Command(0.1, 0.1)\n"
        "sys.platform = 'win32'\n"
        "r = run_match('level.yaml', teams=[Go], ideal=True)\n"
        "print(len(r.robots[0].faults), r.robots[0].final_pose[0] > 0.7)",
        cwd=shared_dir,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0", "True"]
    # a library caller gets a Python warning it may filter (the command line prints it in one line)
    (warning,) = [line for line in out.stderr.splitlines() if "Warning" in line]
    assert warning.endswith(
        "LaserArenaWarning: controllers run in this process (Windows has no select() on pipes): nothing isolates them"
    )
