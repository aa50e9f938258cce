"""`laserarena new NAME`: a ready controller package for a team to start from; with
`--from-policy`, a package team that plays a trained policy (docs/rl.md)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import robots.controllers.tutorial as tutorial
from referee.errors import UserError
from robots.toolkit.policy import Policy

README = """# {name}

A LaserArena controller, started from `laserarena new {name}`. The controller is in
`controller.py`: it localizes on labelled beacons and follows the task's waypoints. Read
its comments, then make it better; the API is in LaserArena's docs/api.md and the
tutorial in docs/controllers.md.

## Run it

`laserarena` must be on your PATH: activate the environment LaserArena is installed in
(`. /path/to/laserarena/.venv/bin/activate`, or `pip install laserarena` into your own), or
call it by its path (`/path/to/laserarena/.venv/bin/laserarena`).

```sh
laserarena run bac-line --team controller.py --json result.json --logs logs
laserarena run asabe --team controller.py --replay asabe.replay
```

The first prints the score table and writes the result (`result.json`) and whatever your
controller prints (`logs/slot0.log`). Add `--ideal` to switch every sensor noise off while
you debug, and `--in-process` to run it inside the referee for a debugger.

## Test it

```sh
python test_controller.py
```

(or `python -m pytest -q test_controller.py`, where pytest is installed)

## Submit it

Hand in this folder (`laserarena run bac-line --team {name}` from the folder above runs it
so): `controller.py` runs, and the `.py` files beside it ship with it, so it may import them
by name as well as the standard library, `robots`, numpy and msgspec, nothing else. To bring
data files or a pure-Python library of your own, make this folder a package: add an
`__init__.py` that imports your Controller. The grader runs exactly what `laserarena run`
runs here: your controller in its own process, with the level's time and memory limits,
seeing only sensor events.
"""

TEST = '''"""Runs the controller on a level, as the grader would, and checks that it scores."""

import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def test_controller_follows_the_line(tmp_path):
    out = tmp_path / "result.json"
    subprocess.run([sys.executable, "-m", "referee", "run", "bac-line", "--ideal", "--quiet",
                    "--team", str(HERE / "controller.py"), "--json", str(out)], check=True)
    robot = json.loads(out.read_text())["robots"][0]
    assert robot["faults"] == []
    assert robot["task"]["reached"] >= 5
    assert robot["localization"]["fraction"] > 0.9


if __name__ == "__main__":  # without pytest: python test_controller.py
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        test_controller_follows_the_line(Path(scratch))
    print("ok: the controller follows the line")
'''


POLICY_INIT = '''"""{name}: a LaserArena team that plays the trained policy in policy.npz (docs/rl.md)."""

from pathlib import Path

from robots.controllers.policy import PolicyController


class Team(PolicyController):
    """Plays policy.npz, shipped beside this file, on the envs' own observation encoding."""

    weights = Path(__file__).parent / "policy.npz"
'''

POLICY_README = """# {name}

A LaserArena team made by `laserarena new {name} --from-policy`: `__init__.py` plays the
trained policy in `policy.npz` ({layers} layer(s), {inputs} inputs, goal block {goal}) with
`robots.controllers.policy.PolicyController`, which encodes what the controller sees exactly
as the training env did (LaserArena's docs/rl.md).

Run it from the folder above this one, and hand in this folder:

```sh
laserarena run asabe --team {name} --json result.json
laserarena tournament asabe --team {name} --team ref:idle --team ref:dead-reckoning
```
"""


def _folder(name: str, where: Path) -> Path:
    """`where/name`, made empty; refuse a bad name or anything that exists."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]{0,63}", name):
        raise UserError(f"{name}: a team name is a letter followed by letters, digits, - or _")
    folder = where / name
    if folder.exists():
        raise UserError(f"{folder}: already exists; choose another name or folder")
    folder.mkdir(parents=True)
    return folder


def create(name: str, where: Path = Path(".")) -> Path:
    """Write the starter kit into `where/name`; refuse to overwrite anything."""
    folder = _folder(name, where)
    (folder / "controller.py").write_text(Path(tutorial.__file__).read_text())
    (folder / "test_controller.py").write_text(TEST)
    (folder / "README.md").write_text(README.format(name=name))
    return folder


def create_from_policy(name: str, weights: Path, where: Path = Path(".")) -> Path:
    """Write a package team into `where/name` that plays the policy saved at `weights`
    (robots.toolkit.policy's .npz); refuse a file that is not one, or to overwrite anything."""
    if not name.isidentifier():
        raise UserError(f"{name}: a policy team is a Python package; its name is letters, digits and _")
    try:
        policy = Policy.load(weights)
    except FileNotFoundError:
        raise UserError(f"{weights}: no such file") from None
    except (OSError, ValueError, KeyError) as e:
        raise UserError(f"{weights}: not a policy .npz (robots.toolkit.policy): {e}") from None
    folder = _folder(name, where)
    shutil.copyfile(weights, folder / "policy.npz")
    (folder / "__init__.py").write_text(POLICY_INIT.format(name=name))
    goal = "on" if policy.goal else "off"
    (folder / "README.md").write_text(
        POLICY_README.format(name=name, layers=len(policy.weights), inputs=policy.inputs, goal=goal)
    )
    return folder
