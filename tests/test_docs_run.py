"""Docs that run. Every fenced block of the README and the tutorial docs is one of:

- `<!-- run -->` before a ```sh or ```python block: run here, in a fresh folder with the
  venv's `laserarena` and `python` first on PATH, with a bound on its time (any doc);
- `<!-- save: FILE -->` before a ```python block: a whole file the reader saves as FILE; the
  doc's run blocks after it find it in their folder, as its last saved version;
- `<!-- run: notebook -->`: a cell of the doc's notebook; its cells run in order in one
  process, each known to `linecache` under a cell name, as Jupyter runs them;
- `<!-- quickstart -->`: the README's quickstart, followed on a fresh copy by test_quickstart.py;
- `<!-- output: COMMAND -->` before a ```text block: what COMMAND prints, run here in a fresh
  folder and compared with the block, character for character; `<!-- sample: NAME -->`: a
  sample whose figures vary, held to the program's shape by test_docs_samples.py;
- `<!-- fragment: WHY -->`: a part of something larger, saying why it does not run alone.

A block that is none of these fails `test_every_block_runs_or_says_why`. The controllers
tutorial saves mybot.py step by step, each step run by the commands under it; its last step is
the starter controller, word for word, and finishes the 'ASABE' letters."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

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
    if block.marker.startswith("save:") and block.lang == "python" and block.marker.partition(":")[2].strip():
        return "save"
    if block.lang == "text" and block.marker.startswith("sample:") and block.marker.partition(":")[2].strip():
        return "sample"  # its shape held to the program's by test_docs_samples.py
    if block.lang == "text" and block.marker.startswith("output:") and block.marker.partition(":")[2].strip():
        return "checked output"
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


def _saved(block: Block) -> dict[str, str]:
    """The files a reader has saved when reaching `block`: each file's last `save:` block before it."""
    doc = next(d for d in DOCS if d.name == block.doc)
    return {b.marker.partition(":")[2].strip(): b.code for b in _blocks(doc)[: block.index] if _kind(b) == "save"}


def _run(block: Block, cmd: list[str], folder: Path) -> None:
    for name, code in _saved(block).items():
        (folder / name).write_text(code, encoding="utf-8")
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


CHECKED = [b for doc in DOCS for b in _blocks(doc) if _kind(b) == "checked output"]


@pytest.mark.parametrize("block", CHECKED, ids=[b.name for b in CHECKED])
def test_output_is_what_the_command_prints(block):
    command = block.marker.partition(":")[2].strip()
    with _folder() as d:
        out = subprocess.run(
            ["bash", "-eu", "-c", command], capture_output=True, text=True, cwd=d, env=_env(), timeout=TIMEOUT
        )
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout == block.code, f"{block.name}: `{command}` prints\n{out.stdout}"


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


def test_each_saved_file_is_run_before_it_changes():
    """A step's file is run by a command under it, before the next step saves it again."""
    for doc in DOCS:
        blocks = _blocks(doc)
        for b in blocks:
            if _kind(b) != "save":
                continue
            later = blocks[b.index + 1 :]
            nxt = next((c.index for c in later if c.marker == b.marker), len(blocks))
            assert any(_kind(c) == "run" for c in blocks[b.index + 1 : nxt]), f"{b.name} saves a file no command runs"


def _tutorial_robot() -> str:
    steps = [b for b in _blocks(ROOT / "docs" / "controllers.md") if b.marker == "save: mybot.py"]
    assert len(steps) >= 5
    return steps[-1].code


def test_the_tutorials_last_step_is_the_starter_kits_robot():
    """`laserarena new` writes the tutorial robot's source: the page and the kit cannot drift apart."""
    import robots.controllers.tutorial as tutorial

    assert _tutorial_robot() == Path(tutorial.__file__).read_text(encoding="utf-8")


ASABE_WAYPOINTS = len(yaml.safe_load((ROOT / "levels" / "asabe.yaml").read_text())["task"]["path"])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_tutorials_robot_finishes_the_letters(shared_dir, seed):
    (shared_dir / "mybot.py").write_text(_tutorial_robot())
    (shared_dir / "mybot.py").chmod(0o644)
    out = subprocess.run(
        ["laserarena", "run", "asabe", "--team", "mybot.py", "--seed", str(seed), "--json", "-", "--quiet"],
        capture_output=True,
        text=True,
        cwd=shared_dir,
        env=_env(),
        timeout=TIMEOUT,
    )
    assert out.returncode == 0, out.stderr
    robot = json.loads(out.stdout)["robots"][0]
    assert robot["faults"] == []
    assert robot["task"]["reached"] == robot["task"]["total"] == ASABE_WAYPOINTS == 33
    assert robot["task"]["finished"] is not None
