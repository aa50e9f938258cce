"""The README's quickstart on a fresh machine: a copy of the checkout (its git files only), no
virtual environment, `laserarena` on no PATH; the quickstart's lines run as written, in one
shell (a fresh venv, `pip install .`, the first commands). Then the README that `laserarena
new` wrote: its commands, as written, from the new folder, with only that venv activated.

Installing needs the package index (or pip's cache): without it this test fails, it never
skips."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from helpers import edited

ROOT = Path(__file__).resolve().parent.parent
QUICKSTART = re.compile(r"^<!-- quickstart -->\n```sh\n(.*?)^```", re.S | re.M)
SH = re.compile(r"^```sh\n(.*?)^```", re.S | re.M)
INSTALL_TIMEOUT = 900  # seconds: a first install downloads numpy, pygame-ce, pymunk...


def _fresh_env() -> dict[str, str]:
    """This environment without any virtual environment: no venv on PATH, no VIRTUAL_ENV."""
    venvs = {str(Path(sys.executable).parent), str(Path(sys.prefix) / "bin")}
    path = [p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p not in venvs]
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME")}
    env["PATH"] = os.pathsep.join(path or ["/usr/local/bin", "/usr/bin", "/bin"])
    return env


def _checkout_copy(into: Path) -> Path:
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, timeout=60
    ).stdout.split(b"\0")
    copy = into / "laserarena"
    for name in filter(None, (f.decode() for f in files)):
        source = ROOT / name
        if source.is_file():  # a file deleted in the working tree is not part of it
            (copy / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, copy / name)
    return copy


def _bash(script: str, cwd: Path, timeout: int) -> subprocess.CompletedProcess:
    out = subprocess.run(
        ["bash", "-eu", "-c", script], cwd=cwd, env=_fresh_env(), capture_output=True, text=True, timeout=timeout
    )
    assert out.returncode == 0, f"{script}\n---\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}"
    assert "Traceback" not in out.stderr, out.stderr
    return out


def test_readme_quickstart_then_the_starter_kits_readme():
    (block,) = QUICKSTART.findall((ROOT / "README.md").read_text(encoding="utf-8"))
    assert "pip install" in block and "laserarena new myteam" in block
    # under /tmp (which every sandbox replaces with a /tmp of its own) and closed to other users
    # (as a clone in /root is), with whatever `python3` is first on PATH (a pyenv build under
    # /root, often): the venv is bound into each controller's sandbox all the same
    with tempfile.TemporaryDirectory(prefix="laserarena-fresh-", dir="/tmp") as d:
        os.chmod(d, 0o700)
        copy = _checkout_copy(Path(d))
        assert not (copy / ".venv").exists() and shutil.which("laserarena", path=_fresh_env()["PATH"]) is None
        out = _bash(block, copy, INSTALL_TIMEOUT)
        demo = json.loads((copy / "demo.json").read_text())["robots"][0]
        assert demo["faults"] == [] and demo["task"]["reached"] > 0, demo  # the controller ran and drove
        assert "asabe" in out.stdout and "demo.replay: identical" in out.stdout  # levels listed, replay verified
        # the first match after `pip install .` compiles the kernels, and says so, once
        assert out.stderr.count("laserarena: compiling the simulator's kernels") == 1, out.stderr
        kit = copy / "myteam"
        commands = SH.findall((kit / "README.md").read_text(encoding="utf-8"))
        assert len(commands) >= 2
        out = _bash(". ../.venv/bin/activate\n" + "\n".join(commands), kit, 600)
        assert json.loads((kit / "result.json").read_text())["robots"][0]["faults"] == []
        assert (kit / "logs" / "slot0.log").is_file() and (kit / "asabe.replay").is_file()
        assert "ok: the controller follows the line" in out.stdout
        # and there, a hostile team in a four-robot match harms no other
        (kit / "race.yaml").write_text(edited("asabe-race", {"time_limit": 6}))
        (kit / "hostile.py").write_text(HOSTILE)
        out = _bash(
            ". ../.venv/bin/activate\nlaserarena run race.yaml --team hostile.py --json race.json --quiet", kit, 600
        )
        assert out.stderr == "", out.stderr  # sandboxed: no warning
        hostile, *others = json.loads((kit / "race.json").read_text())["robots"]
        assert [f["kind"] for f in hostile["faults"]] == ["exception"], hostile["faults"]
        assert all(not r["faults"] and not r["stopped"] for r in others), others


HOSTILE = """import os, signal
from robots.api import Command, Controller


class Hostile(Controller):  # every process it can name, killed; the others' files, read
    def step(self, obs):
        if obs.tick == 3:
            os.kill(-1, signal.SIGKILL)
            raise RuntimeError(f"still here, seeing {sorted(os.listdir('/proc'))[:3]}")
        return Command(0.05, 0.05)
"""
