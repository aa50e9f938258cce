"""Docs that run: every fenced ```python or ```sh block marked `<!-- run -->` in the README and
docs/ runs, in a fresh folder with the venv's `laserarena` and `python` first on PATH, with a
bound on its time; and the controllers tutorial's steps 1 to 3, put together as written, load
and step without an error."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BLOCK = re.compile(r"<!-- run -->\n```(python|sh)\n(.*?)```", re.S)


def _blocks() -> list[tuple[str, str, str]]:
    found = []
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for i, m in enumerate(BLOCK.finditer(doc.read_text(encoding="utf-8"))):
            found.append((f"{doc.name}#{i}", m.group(1), m.group(2)))
    return found


def test_the_docs_have_runnable_blocks():
    names = [n for n, _, _ in _blocks()]
    assert any(n.startswith("python-api.md") for n in names) and any(n.startswith("cli.md") for n in names)


@pytest.mark.parametrize("name,lang,code", _blocks(), ids=[b[0] for b in _blocks()])
def test_block_runs(name, lang, code):
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    with tempfile.TemporaryDirectory(prefix="laserarena-doc-") as d:
        os.chmod(d, 0o755)
        (Path(d) / "block.py").write_text(code, encoding="utf-8")  # run as a script a user saved
        (Path(d) / "block.py").chmod(0o644)
        # a line that shows a failure handles it itself (`|| echo`)
        cmd = [sys.executable, "block.py"] if lang == "python" else ["bash", "-eu", "-c", code]
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=d, env=env, timeout=300)
    assert out.returncode == 0, f"{name}:\n{out.stderr}"
    assert "Traceback" not in out.stderr, out.stderr


def _fenced(text: str, heading: str) -> str:
    """The first ```python block after a heading."""
    part = text[text.index(heading) :]
    return re.search(r"```python\n(.*?)```", part, re.S).group(1)


def test_controllers_tutorial_steps_1_to_3_as_written(shared_dir):
    text = (ROOT / "docs" / "controllers.md").read_text(encoding="utf-8")
    step1, step2, step3 = (_fenced(text, h) for h in ("## 1.", "## 2.", "## 3."))
    head, _, ret = step1.rpartition("        return")  # step 3 goes at the top of step()
    code = "import math\n" + head + step3 + "        return" + ret + step2
    (shared_dir / "mybot.py").write_text(code)
    (shared_dir / "mybot.py").chmod(0o644)
    out = subprocess.run(
        [sys.executable, "-m", "referee", "run", "bac-line", "--team", "mybot.py", "--ideal", "--json", "-", "--quiet"],
        capture_output=True,
        text=True,
        cwd=shared_dir,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    assert '"faults":[]' in out.stdout.replace(" ", "")
