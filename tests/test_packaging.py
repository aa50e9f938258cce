"""The installed package: console script, `python -m referee`, levels as package data, role borders."""

import ast
import subprocess
import sys
from pathlib import Path

from helpers import run_cli

import levels
import robots


def test_levels_ship_inside_the_package():
    for name in levels.names():
        p = levels.path(name)
        assert p.is_file() and p.parent == Path(levels.__file__).parent


def test_console_script_and_module_agree(tmp_path):
    script = Path(sys.executable).parent / "laserarena"
    assert script.exists(), "the laserarena console script is installed beside python"
    a = subprocess.run([str(script), "levels"], capture_output=True, text=True, cwd=tmp_path)
    b = run_cli("levels", cwd=tmp_path)
    assert a.returncode == b.returncode == 0
    assert a.stdout == b.stdout and len(a.stdout.splitlines()) == len(levels.names())


def test_robots_imports_nothing_from_arena_or_referee():
    root = Path(robots.__file__).parent
    for f in root.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            for n in names:
                assert n.split(".")[0] not in ("arena", "referee", "levels", "pymunk", "pygame"), (f, n)
    code = (
        "import sys, robots, robots.controllers.idle, robots.controllers.dead_reckoning; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'levels','arena','referee','pymunk','pygame'}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert out.stdout.strip() == "[]", out.stderr


def test_robots_exports_every_public_name_of_its_api():
    """`from robots import X` works for every class and constant the API module defines (the
    docs import them from `robots.api`; either way is the same object)."""
    import robots.api as api

    tree = ast.parse(Path(api.__file__).read_text())
    defined = {node.name for node in tree.body if isinstance(node, ast.ClassDef)}
    defined |= {
        t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets if isinstance(t, ast.Name)
    }
    defined = {name for name in defined if not name.startswith("_")}
    assert "StartInfo" in defined and "API_VERSION" in defined
    assert set(robots.__all__) == defined
    assert all(getattr(robots, name) is getattr(api, name) for name in defined)
