"""The rooms' borders are import-linter contracts (pyproject.toml) that `make lint` runs: each
contract is shown failing on a copy of the tree given one import that breaks it, and the rules
agree with the project's dependencies and with docs/architecture.md."""

import ast
import re
import shutil
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

from robots._host.loading import STANDARD_VIEW

ROOT = Path(__file__).resolve().parents[1]
CONFIG = tomllib.loads((ROOT / "pyproject.toml").read_text())
CONTRACTS = {c["name"]: c for c in CONFIG["tool"]["importlinter"]["contracts"]}
LINT_IMPORTS = Path(sys.executable).parent / "lint-imports"


def lint(tree: Path) -> subprocess.CompletedProcess:
    """lint-imports over the packages of `tree` (not the installed ones), with the project's contracts."""
    return subprocess.run(
        [str(LINT_IMPORTS), str(tree / "pyproject.toml"), "--no-cache"],
        cwd=tree,
        env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def tree(tmp_path_factory) -> Path:
    """A copy of the four packages and pyproject.toml."""
    out = tmp_path_factory.mktemp("tree")
    for package in ("levels", "arena", "robots", "referee"):
        shutil.copytree(ROOT / package, out / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", out)
    return out


def test_the_tree_keeps_every_contract(tree):
    done = lint(tree)
    assert done.returncode == 0, done.stdout[-3000:]
    assert f"Contracts: {len(CONTRACTS)} kept, 0 broken." in done.stdout


BREAKS = [
    ("levels/model.py", "import arena.angles", "levels is the bottom: the level model imports nothing of the product"),
    ("arena/world.py", "import referee.errors", "arena knows nothing of teams or scores"),
    ("robots/api.py", "import referee.version", "robots runs in a team's process: no arena, no referee"),
    ("robots/toolkit/ekf.py", "import yaml", "robots imports no third-party package but numpy and msgspec"),
    ("referee/records/canonical.py", "import referee.match.scoring", "the referee's rooms, top to bottom"),
    ("referee/records/canonical.py", "import referee.sandbox.uids", "the referee's rooms, top to bottom"),
    ("referee/media/plot.py", "import referee.contest.ratings", "the referee's rooms, top to bottom"),
    ("referee/newroom/__init__.py", "", "the referee's rooms, top to bottom"),
    ("referee/match/rules.py", "import robots.toolkit.ekf", "the match core runs team code only through the sandbox"),
    (
        "referee/media/render.py",
        "import referee.sandbox.teams",
        "media shows records; it runs controllers only through the match core",
    ),
    (
        "referee/sandbox/affinity.py",
        "import arena.world",
        "the sandbox runs team code and knows the world only as a level",
    ),
    (
        "referee/records/canonical.py",
        "import arena.world",
        "records can be read by anyone: they import no world and no team code",
    ),
    ("referee/contest/schedule.py", "import robots.api", "contests ship team code as bytes and never import it"),
    ("referee/match/scoring.py", "import gymnasium", "optional extras stay in their rooms"),
    ("referee/media/plot.py", "import dask", "dask stays in the contest room"),
]


def test_every_contract_is_shown_broken():
    assert {name for _, _, name in BREAKS} == set(CONTRACTS)


@pytest.mark.parametrize("module, line, contract", BREAKS, ids=[f"{m}:{c[:30]}" for m, _, c in BREAKS])
def test_an_import_across_a_border_fails_lint(tmp_path, tree, module, line, contract):
    copy = tmp_path / "tree"
    shutil.copytree(tree, copy)
    target = copy / module
    target.parent.mkdir(exist_ok=True)
    target.write_text((target.read_text() if target.exists() else "") + f"\n{line}\n")
    done = lint(copy)
    assert done.returncode == 1, done.stdout[-2000:]
    assert f"{contract} BROKEN" in done.stdout
    assert f"Contracts: {len(CONTRACTS) - 1} kept, 1 broken." in done.stdout


def _import_names(requirement: str) -> set[str]:
    """The top-level modules a requirement such as `dask[distributed]>=2024.1` installs (with its extras)."""
    m = re.match(r"([A-Za-z0-9_.-]+)(?:\[([^\]]*)\])?", requirement)
    assert m
    dists = [m.group(1)] + [e.strip() for e in (m.group(2) or "").split(",") if e.strip()]
    tops = metadata.packages_distributions()
    wanted = {re.sub(r"[-_.]+", "-", d).lower() for d in dists}
    return {top for top, owners in tops.items() if any(re.sub(r"[-_.]+", "-", o).lower() in wanted for o in owners)}


def test_the_team_side_may_import_what_its_sandbox_holds_and_nothing_else():
    project = CONFIG["project"]
    requirements = project["dependencies"] + [
        r for extra in ("dask", "rl") for r in project["optional-dependencies"][extra]
    ]
    installed = set().union(*(_import_names(r) for r in requirements))
    installed = {m for m in installed if not m.startswith("_") and m.isidentifier()}
    forbidden = set(CONTRACTS["robots imports no third-party package but numpy and msgspec"]["forbidden_modules"])
    assert set(STANDARD_VIEW) <= installed
    assert forbidden == installed - set(STANDARD_VIEW)


PAGE = (ROOT / "docs" / "architecture.md").read_text()
PACKAGES = ["levels", "arena", "arena/sensing", "robots", "robots/_host", "referee"]
ROOMS = sorted(p.parent.name for p in (ROOT / "referee").glob("*/__init__.py"))


def docstring(package: str) -> str:
    return ast.get_docstring(ast.parse((ROOT / package / "__init__.py").read_text())) or ""


def test_the_architecture_page_gives_each_rooms_own_first_line():
    """The page's tables quote each package's and room's `__init__` (its first line), so the
    two cannot drift; every room has its row."""
    rows = dict(re.findall(r"^\| `([\w/]+)/` \| (.*) \|$", PAGE, re.M))
    expected = [p for p in PACKAGES if "/" not in p] + [f"referee/{room}" for room in ROOMS]
    assert sorted(rows) == sorted(expected)
    for package, holds in rows.items():
        assert holds == docstring(package).splitlines()[0], package


def test_the_architecture_page_gives_the_layers_and_contracts_as_pyproject_does():
    layers = CONTRACTS["the referee's rooms, top to bottom"]["layers"]
    line = " > ".join(" | ".join(f"`{room.strip()}`" for room in layer.split("|")) for layer in layers)
    assert f"\n{line}\n" in PAGE
    listed = re.findall(r"^- (.+)$", PAGE.split("## Borders", 1)[1].split("\n## ", 1)[0], re.M)
    assert listed == list(CONTRACTS)


@pytest.mark.parametrize("package", PACKAGES + [f"referee/{room}" for room in ROOMS])
def test_each_package_names_every_module_it_holds(package):
    """A package's `__init__` says what it holds, module by module: every module and
    subpackage in it is named there."""
    folder = ROOT / package
    held = {p.stem for p in folder.glob("*.py") if p.stem not in ("__init__", "__main__")}
    held |= {p.parent.name for p in folder.glob("*/__init__.py")}
    text = docstring(package)
    named = set(re.findall(r"`(\w+)`", text))
    assert held <= named, f"{package}/__init__.py does not name {sorted(held - named)}"


def test_no_module_docstring_runs_past_fifteen_lines():
    """A module's docstring says what and why in a few lines; algorithms and quotes go to docs/."""
    long = {}
    for package in ("levels", "arena", "robots", "referee"):
        for path in (ROOT / package).rglob("*.py"):
            text = ast.get_docstring(ast.parse(path.read_text()), clean=False)
            if text and len(text.strip("\n").splitlines()) > 15:
                long[str(path.relative_to(ROOT))] = len(text.strip("\n").splitlines())
    assert not long
