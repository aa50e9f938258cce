"""`laserarena new` writes a kit whose README commands work; installed controllers load by name."""

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import run_cli

from referee.records.replay_reader import load


def test_new_kit_and_its_readme_commands_work(shared_dir):
    proc = run_cli("new", "myteam", "--dir", str(shared_dir))
    assert proc.returncode == 0, proc.stderr
    kit = shared_dir / "myteam"
    assert sorted(p.name for p in kit.iterdir()) == ["README.md", "controller.py", "test_controller.py"]
    readme = kit.joinpath("README.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", readme, re.S)
    commands = [line for block in blocks for line in block.splitlines() if line.strip()]
    assert len(commands) == 3
    bindir = Path(sys.executable).parent
    for command in commands:  # exactly as a team would type them, in the kit's folder
        argv = shlex.split(command)
        argv[0] = str(bindir / argv[0]) if argv[0] == "laserarena" else sys.executable
        done = subprocess.run(argv, cwd=kit, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, (command, done.stdout[-2000:], done.stderr[-2000:])
    result = json.loads((kit / "result.json").read_text())  # the bac-line run's
    (robot,) = result["robots"]
    assert result["level"]["name"] == "bac-line" and robot["team"] == "controller.py" and not robot["faults"]
    assert robot["task"]["total"] == 10 and robot["localization"]["estimates"] > 0
    replay = load(kit / "asabe.replay")  # the asabe run's, with its result and frames to its end
    assert replay.header["level"]["name"] == "asabe" and replay.result["robots"][0]["team"] == "controller.py"
    assert replay.frames[-1][0] == pytest.approx(replay.result["end_time"], abs=0.05)
    assert (kit / "logs" / "slot0.log").is_file()
    # and it refuses to overwrite
    again = run_cli("new", "myteam", "--dir", str(shared_dir))
    assert again.returncode == 2 and "already exists" in again.stderr


def test_installed_controller_found_by_entry_point(shared_dir, tmp_path):
    # a package installed the usual way: its module and a dist-info with an entry point
    site = shared_dir / "site"
    (site / "fastbot").mkdir(parents=True)
    (site / "fastbot" / "__init__.py").write_text(
        "from robots.api import Command, Controller\n"
        "class Fast(Controller):\n"
        "    def step(self, obs):\n"
        "        return Command(0.17, 0.17)\n"
    )
    info = site / "fastbot-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fastbot\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[laserarena.controllers]\nfastbot = fastbot:Fast\n")
    for p in [site, site / "fastbot", info]:
        p.chmod(0o755)
    env = {"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin"}
    out = tmp_path / "r.json"
    done = subprocess.run(
        [sys.executable, "-m", "referee", "run", "bac-line", "--team", "fastbot", "--json", str(out), "--quiet"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    import json

    robot = json.loads(out.read_text())["robots"][0]
    assert robot["team"] == "fastbot" and robot["faults"] == []
    assert robot["final_pose"][0] > 0.40 + 0.5  # it drove: the installed class ran
    missing = run_cli("run", "bac-line", "--team", "nosuchbot")
    assert missing.returncode == 2 and "entry point group laserarena.controllers" in missing.stderr
