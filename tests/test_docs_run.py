"""Docs that run. Every fenced block of the README and the tutorial docs is one of:

- `<!-- run -->` before a ```sh or ```python block: run here, in a fresh folder with the
  venv's `laserarena` and `python` first on PATH, with a bound on its time (any doc);
- `<!-- run: notebook -->`: a cell of the doc's notebook; its cells run in order in one
  process, each known to `linecache` under a cell name, as Jupyter runs them;
- `<!-- quickstart -->`: the README's quickstart, followed on a fresh copy by test_quickstart.py;
- ```text: an output sample;
- `<!-- fragment: WHY -->`: a part of something larger, saying why it does not run alone.

A block that is none of these fails `test_every_block_runs_or_says_why`. The controllers
tutorial's steps are fragments of one file, mybot.py: put together as the tutorial says, they
run, and the tutorial's commands run against it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
TUTORIALS = ["README.md", "controllers.md", "python-api.md", "cli.md", "contests.md", "levels.md"]
FENCE = re.compile(r"^(?:<!--\s*(?P<marker>[^\n]*?)\s*-->\n)?```(?P<lang>[\w-]*)\n(?P<code>.*?)^```\s*$", re.S | re.M)
TIMEOUT = 300  # seconds, for any one block or notebook


@dataclass(frozen=True)
class Block:
    doc: str
    index: int
    lang: str
    marker: str
    code: str

    @property
    def name(self) -> str:
        return f"{self.doc}#{self.index}"


def _blocks(doc: Path) -> list[Block]:
    text = doc.read_text(encoding="utf-8")
    return [
        Block(doc.name, i, m.group("lang"), m.group("marker") or "", m.group("code"))
        for i, m in enumerate(FENCE.finditer(text))
    ]


def _all(marker: str) -> list[Block]:
    return [b for doc in DOCS for b in _blocks(doc) if b.marker == marker]


def _kind(block: Block) -> str | None:
    """How a block is accounted for, or None when it is not."""
    if block.marker in ("run", "run: notebook") and block.lang in ("sh", "python"):
        return block.marker
    if block.marker == "quickstart" and block.lang == "sh":
        return "quickstart"
    if block.lang == "text" and not block.marker:
        return "output"
    if block.marker.startswith("fragment:") and block.marker.partition(":")[2].strip():
        return "fragment"
    return None


def test_every_block_runs_or_says_why():
    docs = {d.name: d for d in DOCS}
    unaccounted = [
        f"{b.name} (```{b.lang or 'no language'} {b.marker!r}): {b.code.strip().splitlines()[0][:60]}"
        for name in TUTORIALS
        for b in _blocks(docs[name])
        if _kind(b) is None
    ]
    assert not unaccounted, "blocks neither run nor marked as output or fragment:\n" + "\n".join(unaccounted)
    kinds = [_kind(b) for name in TUTORIALS for b in _blocks(docs[name])]
    assert kinds.count("run") >= 8 and "run: notebook" in kinds and kinds.count("quickstart") == 1


def test_the_checker_sees_an_unmarked_block(tmp_path):
    doc = tmp_path / "x.md"
    doc.write_text("A.\n\n```sh\nls\n```\n\n<!-- fragment: -->\n```python\nx\n```\n\n```\nout\n```\n")
    assert [_kind(b) for b in _blocks(doc)] == [None, None, None]


def _env() -> dict[str, str]:
    return dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")


def _folder() -> tempfile.TemporaryDirectory:
    d = tempfile.TemporaryDirectory(prefix="laserarena-doc-")
    os.chmod(d.name, 0o755)  # the controllers run as another user and read the team files here
    return d


def _fenced(text: str, heading: str) -> str:
    """The first ```python block after a heading."""
    part = text[text.index(heading) :]
    return re.search(r"```python\n(.*?)```", part, re.S).group(1)


def mybot() -> str:
    """The controllers tutorial's mybot.py, put together as it says: steps 1 and 2 as written,
    step 3 at the top of `step()`."""
    text = (ROOT / "docs" / "controllers.md").read_text(encoding="utf-8")
    step1, step2, step3 = (_fenced(text, h) for h in ("## 1.", "## 2.", "## 3."))
    head, _, ret = step1.rpartition("        return")
    return "import math\n" + head + step3 + "        return" + ret + step2


SETUP = {"controllers.md": {"mybot.py": mybot}}  # files a doc's commands expect the reader to have made


def _run(block: Block, cmd: list[str], folder: Path) -> None:
    for name, make in SETUP.get(block.doc, {}).items():
        (folder / name).write_text(make(), encoding="utf-8")
        (folder / name).chmod(0o644)
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=folder, env=_env(), timeout=TIMEOUT)
    assert out.returncode == 0, f"{block.name}:\n{out.stdout[-2000:]}\n{out.stderr[-3000:]}"
    assert "Traceback" not in out.stderr, out.stderr


@pytest.mark.parametrize("block", _all("run"), ids=[b.name for b in _all("run")])
def test_block_runs(block):
    with _folder() as d:
        (Path(d) / "block.py").write_text(block.code, encoding="utf-8")  # run as a script a user saved
        (Path(d) / "block.py").chmod(0o644)
        # a line that shows a failure handles it itself (`|| echo`)
        cmd = [sys.executable, "block.py"] if block.lang == "python" else ["bash", "-eu", "-c", block.code]
        _run(block, cmd, Path(d))


NOTEBOOK = """
import linecache

CELLS = {cells!r}

if __name__ == "__main__":  # a pool's worker imports this file: the cells run once, here
    for number, cell in enumerate(CELLS, start=1):
        name = f"<ipython-input-{{number}}>"
        linecache.cache[name] = (len(cell), None, cell.splitlines(True), name)
        exec(compile(cell, name, "exec"), globals())
"""
NOTEBOOKS = sorted({b.doc for b in _all("run: notebook")})


@pytest.mark.parametrize("doc", NOTEBOOKS)
def test_notebook_runs(doc):
    cells = [b.code for b in _all("run: notebook") if b.doc == doc]
    with _folder() as d:
        (Path(d) / "notebook.py").write_text(NOTEBOOK.format(cells=cells), encoding="utf-8")
        _run(Block(doc, 0, "python", "run: notebook", ""), [sys.executable, "notebook.py"], Path(d))


def test_controllers_tutorial_put_together_runs(shared_dir):
    (shared_dir / "mybot.py").write_text(mybot())
    (shared_dir / "mybot.py").chmod(0o644)
    out = subprocess.run(
        [sys.executable, "-m", "referee", "run", "bac-line", "--team", "mybot.py", "--ideal", "--json", "-", "--quiet"],
        capture_output=True,
        text=True,
        cwd=shared_dir,
        timeout=TIMEOUT,
    )
    assert out.returncode == 0, out.stderr
    assert '"faults":[]' in out.stdout.replace(" ", "")


def test_controllers_tutorial_step_6_is_the_starters_return():
    """Step 6 shows the end of the starter's `step()`: its lines are there, in that order."""
    import robots.controllers.starter as starter

    text = (ROOT / "docs" / "controllers.md").read_text(encoding="utf-8")
    shown = [line.split("#")[0].strip() for line in _fenced(text, "## 6.").splitlines()]
    source = [line.split("#")[0].strip() for line in Path(starter.__file__).read_text(encoding="utf-8").splitlines()]
    at = source.index(shown[0])
    assert source[at : at + len(shown)] == shown
